"""Nothing clobbered (issue 20, item 1): an output path that names a symlink, a FIFO, a device or
this process's stdout is written through, never renamed over; a reused --out folder is published
as a whole, with a manifest naming the run."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from hila_lang import cli
from hila_lang.core.fileio import MANIFEST, AtomicFile, OutputFolder, atomic_write_text, ensure_writable

ROOT = Path(__file__).resolve().parent.parent
ABC = str(ROOT / "programs" / "abc.hila")
GAME = str(ROOT / "programs" / "game.hila")


def test_a_symlink_is_written_through_to_its_target(tmp_path, capsys):
    target = tmp_path / "real" / "fsm.txt"
    target.parent.mkdir()
    target.write_text("old\n")
    os.chmod(target, 0o640)
    link = tmp_path / "link.txt"
    link.symlink_to(target)
    assert cli.main(["compile", ABC, "-o", str(link)]) == 0
    assert link.is_symlink() and os.readlink(link) == str(target)  # the link is still a link
    assert target.read_text().startswith("fsm ") or "state" in target.read_text()
    assert target.read_text() != "old\n" and stat.S_IMODE(target.stat().st_mode) == 0o640
    assert sorted(os.listdir(target.parent)) == ["fsm.txt"]  # no temporary file left


def test_a_dangling_symlink_creates_its_target(tmp_path):
    link = tmp_path / "link.txt"
    link.symlink_to(tmp_path / "new.txt")
    atomic_write_text(link, "x\n")
    assert link.is_symlink() and (tmp_path / "new.txt").read_text() == "x\n"


def test_a_fifo_is_streamed_to_its_reader_and_stays_a_fifo(tmp_path):
    fifo = tmp_path / "p"
    os.mkfifo(fifo)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # a reader is there (never blocks)
    try:
        f = AtomicFile(fifo)
        f.write("line 1\n")
        f.write("line 2\n")
        f.commit()
        try:
            got = os.read(reader, 1000)
        except BlockingIOError:
            got = b""
    finally:
        os.close(reader)
    assert got == b"line 1\nline 2\n" and stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert os.listdir(tmp_path) == ["p"]


def test_a_fifo_nobody_reads_is_refused_at_once_by_name(tmp_path, capsys):
    fifo = tmp_path / "p"
    os.mkfifo(fifo)
    code = cli.main(["compile", ABC, "-o", str(fifo)])
    err = capsys.readouterr().err
    assert code == 2 and err == f"{fifo}: error: a FIFO with no reader (start the reader first)\n"
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    ensure_writable(fifo)  # checked without opening it (a reader would get an end of file)


def _device(tmp_path, name: str, major: int, minor: int, system: str) -> str:
    """A node that acts as ``system`` (``/dev/null``, ``/dev/full``): as root a copy of its
    device number made in ``tmp_path``, so a regression replaces the copy and never the
    system's node; without root the system's node itself (a user cannot replace it)."""
    if os.geteuid() != 0:
        return system
    node = tmp_path / name
    try:
        os.mknod(node, 0o666 | stat.S_IFCHR, os.makedev(major, minor))
        os.close(os.open(node, os.O_WRONLY))
    except OSError:
        pytest.skip("cannot make a device node here (nodev)")
    return str(node)


def test_a_device_is_written_directly_never_replaced(tmp_path, capsys):
    node = _device(tmp_path, "null", 1, 3, "/dev/null")
    before = os.stat(node)
    assert cli.main(["compile", ABC, "-o", node]) == 0
    after = os.stat(node)
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)


@pytest.mark.parametrize("option", [["compile", ABC, "-o"], ["exec", "{prog}", "--quiet", "--trace"],
                                    ["exec", "{prog}", "--quiet", "--record"]])
def test_a_full_device_is_exit_2_by_name_and_stays_a_device(tmp_path, option):
    """The issue's input: ``-o /dev/full`` exited 0 and, as root, turned it into a file."""
    prog = tmp_path / "p.hila"
    prog.write_text("main {\n  let a = 1\n}\n")
    node = _device(tmp_path, "full", 1, 7, "/dev/full")
    before = os.stat(node)
    argv = [a.format(prog=prog) for a in option] + [node]
    proc = subprocess.run([sys.executable, "-m", "hila_lang", *argv], capture_output=True, text=True, timeout=60)
    after = os.stat(node)
    assert proc.returncode == 2 and f"{node}: error: No space left on device" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)


def test_dev_stdout_names_this_process_s_descriptor():
    from hila_lang.core.fileio import _own_fd

    assert [_own_fd(Path(p)) for p in ("/dev/stdout", "/dev/stderr", "/dev/fd/7", "/proc/self/fd/3",
                                       f"/proc/{os.getpid()}/fd/4", "/proc/1/fd/1", "/dev/null")] == [1, 2, 7, 3, 4, None, None]


@pytest.mark.parametrize("name", ["/dev/fd/1", "/proc/self/fd/1"])  # /dev/stdout's own path: the same code,
def test_stdout_by_name_prints_and_appends(tmp_path, name):  # and no node a regression could replace
    out = tmp_path / "log.txt"
    out.write_text("before\n")
    with open(out, "a") as log:  # 'hila compile -o /dev/stdout >> log.txt'
        proc = subprocess.run([sys.executable, "-m", "hila_lang", "compile", ABC, "-o", name],
                              stdout=log, stderr=subprocess.PIPE, text=True, timeout=60)
    text = out.read_text()
    assert proc.returncode == 0 and text.startswith("before\n") and "main" in text, proc.stderr
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "compile", ABC, "-o", name],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and "main" in proc.stdout


def test_trace_and_record_through_a_symlink(tmp_path):
    prog = tmp_path / "p.hila"
    prog.write_text("main {\n  let a = 1\n}\n")
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "t.txt").symlink_to(real / "t.txt")
    (tmp_path / "r.hilarec").symlink_to(real / "r.hilarec")
    assert cli.main(["exec", str(prog), "--quiet", "--trace", str(tmp_path / "t.txt"),
                     "--record", str(tmp_path / "r.hilarec")]) == 0
    assert (tmp_path / "t.txt").is_symlink() and (tmp_path / "r.hilarec").is_symlink()
    assert "set a = 1" in (real / "t.txt").read_text() and (real / "r.hilarec").stat().st_size > 100


def test_an_out_folder_is_published_whole_with_a_manifest(tmp_path, capsys):
    out = tmp_path / "game"
    assert cli.main(["exec", GAME, "--backend", "dry", "--out", str(out), "--quiet"]) == 0
    manifest = json.loads((out / MANIFEST).read_text())
    report = json.loads((out / "report.json").read_text())
    assert manifest["complete"] and sorted(manifest["files"]) == sorted(report["files"])
    assert not [p for p in out.iterdir() if p.name.startswith(".hila-staging")]


def test_a_failure_while_writing_leaves_the_previous_run_whole(tmp_path, monkeypatch):
    """A full disk (or a kill) between two files: the folder keeps the old run, not a mixture."""
    out = tmp_path / "o"
    first = OutputFolder(out, "x", owned=("a.txt", "b.txt"))
    first.write_text("a.txt", "run 1")
    first.write_text("b.txt", "run 1")
    first.close()
    second = OutputFolder(out, "x", owned=("a.txt", "b.txt"))
    second.write_text("a.txt", "run 2")
    import hila_lang.core.fileio as fileio

    real = fileio.atomic_write_text

    def full(path, text):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(fileio, "atomic_write_text", full)
    with pytest.raises(OSError, match="No space left"):
        second.write_text("b.txt", "run 2")
    monkeypatch.setattr(fileio, "atomic_write_text", real)
    assert (out / "a.txt").read_text() == "run 1" and (out / "b.txt").read_text() == "run 1"
    assert sorted(p.name for p in out.iterdir()) == sorted(["a.txt", "b.txt", MANIFEST])


def test_a_killed_runs_staging_folder_is_removed_by_the_next(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    (out / f".hila-staging-{proc.pid}-abc").mkdir()
    (out / f".hila-staging-{proc.pid}-abc" / "traces.csv").write_text("half")
    OutputFolder(out, "x")
    assert list(out.iterdir()) == []
