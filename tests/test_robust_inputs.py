"""Limits before reading, and bad input named (issue 20, items 3, 4, 6 and 9): special files,
huge files, YAML bombs, damaged recordings, out-of-range options, a damaged cache -- each exit
status 2 with a message that names the problem, never a hang, a traceback or memory without end."""

from __future__ import annotations

import io
import json
import os
import resource
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from hila_lang import cli

ROOT = Path(__file__).resolve().parent.parent
ABC = ROOT / "programs" / "abc.hila"
MB = 1 << 20


def _limited():  # a child that must never need more than 1.5 GB (the bombs needed > 5 GB)
    resource.setrlimit(resource.RLIMIT_AS, (1536 * MB, 1536 * MB))


def _hila(*argv, timeout=60, env=None, stdin=None):
    return subprocess.run([sys.executable, "-m", "hila_lang", *map(str, argv)], capture_output=True, text=True,
                          timeout=timeout, preexec_fn=_limited, env=env, input=stdin)


# ------------------------------------------------------------------ special and huge files

def test_check_dev_zero_is_refused_at_once():
    proc = _hila("check", "/dev/zero", timeout=30)
    assert proc.returncode == 2
    assert proc.stderr == "/dev/zero: error: expected a program (a regular file), got a character device\n"


def test_a_fifo_template_is_refused_not_waited_for(tmp_path):
    fifo = tmp_path / "t.yaml"
    os.mkfifo(fifo)
    prog = tmp_path / "p.hila"
    prog.write_text(f'import "{fifo}" as t\nmain {{\n}}\n')
    proc = _hila("check", prog, timeout=30)
    assert proc.returncode == 2 and f"template '{fifo}'" in proc.stderr, proc.stderr  # not found as a file
    proc = _hila("imitate", fifo, "--task", tmp_path / "task.yaml", timeout=30)
    assert proc.returncode == 2 and f"{fifo}: error: expected a template (a regular file), got a FIFO" in proc.stderr


def test_a_fifo_program_is_refused(tmp_path):
    fifo = tmp_path / "p.hila"
    os.mkfifo(fifo)
    proc = _hila("check", fifo, timeout=30)
    assert proc.returncode == 2 and "got a FIFO" in proc.stderr


@pytest.mark.parametrize("what, name, size, limit", [("program", "p.hila", 9 * MB, "8.0 MB"),
                                                    ("template", "t.yaml", 5 * MB, "4.0 MB")])
def test_a_file_larger_than_its_limit_is_refused_before_reading(tmp_path, capsys, what, name, size, limit):
    big = tmp_path / name
    with open(big, "wb") as f:
        f.truncate(size)  # sparse: no disk used
    if what == "program":
        code = cli.main(["check", str(big)])
    else:
        code = cli.main(["imitate", str(big), "--task", str(tmp_path / "none.yaml")])
    err = capsys.readouterr().err
    assert code == 2 and f"{big}: error: {what} is too large: {size / MB:.1f} MB, more than hila reads ({limit})" in err


# ------------------------------------------------------------------ YAML

def _template_with(tmp_path, text: str) -> Path:
    t = tmp_path / "t.yaml"
    t.write_text(text)
    return t


def test_a_yaml_alias_bomb_is_refused_with_little_memory(tmp_path):
    bomb = 'hila_template: 1\nname: x\nicps: {a: [0, 0]}\nlol: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
    prev = "a"
    for c in "bcdefghi":
        bomb += f"{c}: &{c} [" + ",".join([f"*{prev}"] * 9) + "]\n"
        prev = c
    bomb += "path: *i\n"
    t = _template_with(tmp_path, bomb)
    proc = _hila("imitate", t, "--task", tmp_path / "none.yaml")
    assert proc.returncode == 2, proc.stderr
    assert "template expands to more than 1,000,000 values through its aliases" in proc.stderr


def test_deeply_nested_yaml_is_a_named_error(tmp_path, capsys):
    t = _template_with(tmp_path, "[" * 5000)
    code = cli.main(["imitate", str(t), "--task", str(tmp_path / "none.yaml")])
    assert code == 2 and "template is nested too deeply" in capsys.readouterr().err


def test_a_huge_number_in_a_template_is_refused_by_field(tmp_path, capsys):
    from hila_lang.core.fileio import load_yaml

    doc = load_yaml(ROOT / "primitives" / "reach.yaml", "template")
    doc["path"][3][1] = 1e308
    t = tmp_path / "t.yaml"
    import yaml

    t.write_text(yaml.safe_dump(doc))
    task = tmp_path / "task.yaml"
    task.write_text("icps:\n  home: [0.2, -0.2, 0.7]\n  object: [0.3, -0.1, 0.6]\n")
    code = cli.main(["imitate", str(t), "--task", str(task)])
    err = capsys.readouterr().err
    assert code == 2 and f"{t}: error: expected coordinates within +-1e+06 in field 'path', got 1e+308" in err


def test_learn_refuses_1e308_coordinates(tmp_path, capsys):
    from hila_lang.osila.demofile import read_demo_csv
    from hila_lang.core.errors import InputError

    csv = tmp_path / "d.csv"
    csv.write_text("t,x,y\n0,0,0\n1,1e308,0\n")
    with pytest.raises(InputError, match=r"expected a coordinate within \+-1e\+06 in column 'x', got '1e308'"):
        read_demo_csv(csv)


# ------------------------------------------------------------------ recordings

@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("rec")
    prog = folder / "p.hila"
    prog.write_text("main {\n  let a = 1\n  let b = a + 1\n}\n")
    path = folder / "good.hilarec"
    assert cli.main(["exec", str(prog), "--quiet", "--record", str(path)]) == 0
    return path


def _rewrite(src: Path, dst: Path, change=None, extra=None, method=zipfile.ZIP_DEFLATED) -> Path:
    with zipfile.ZipFile(src) as z:
        doc = json.loads(z.read("record.json"))
    text = json.dumps(change(doc) if change else doc) if not isinstance(change, str) else change
    with zipfile.ZipFile(dst, "w", compression=method) as z:
        z.writestr("record.json", text)
        for name, data in (extra or {}).items():
            z.writestr(name, data)
    return dst


def _replay(path, capsys) -> tuple[int, str]:
    code = cli.main(["replay", str(path), "--verify"])
    return code, capsys.readouterr().err


def _drop(keys):
    def change(doc):
        d = doc
        for k in keys[:-1]:
            d = d[k]
        del d[keys[-1]]
        return doc
    return change


@pytest.mark.parametrize("change, message", [
    (lambda d: {**d, "result": {}}, "its 'result' has no 'status'"),
    (lambda d: {**d, "steps": {"a": 1}}, "the recording['steps'] is dict, expected a list"),
    (_drop(["program", "sha256"]), "its 'program' has no 'sha256'"),
    (_drop(["command", "seed"]), "its 'command' has no 'seed'"),
    (lambda d: {**d, "steps": [{**d["steps"][0], "hand": [float("nan"), 0, 0]}]},
     "step 1's 'hand' holds a number that is not finite (NaN or infinity)"),
    ('{"a":' * 100000 + "1" + "}" * 100000, "its record.json is nested too deeply"),
], ids=["result-empty", "steps-dict", "no-sha256", "no-seed", "nan-hand", "deep-json"])
def test_a_damaged_recording_is_named(tmp_path, capsys, recording, change, message):
    bad = _rewrite(recording, tmp_path / "bad.hilarec", change)
    code, err = _replay(bad, capsys)
    assert code == 2 and f"{bad}: error: the recording is damaged or not one hila reads: {message}" in err, err


def _patch_bytes(src: Path, dst: Path, patch) -> Path:
    data = bytearray(src.read_bytes())
    patch(data)
    dst.write_bytes(bytes(data))
    return dst


def test_flipped_bytes_bad_compression_and_encryption_are_named(tmp_path, capsys, recording):
    def flip(data):  # inside the compressed record.json (after its 30-byte local header and name)
        for i in range(60, 90):
            data[i] ^= 0xFF

    def method_99(data):  # compression method, in the local header and the central directory
        data[8] = 99
        central = data.rfind(b"PK\x01\x02")
        data[central + 10] = 99

    def encrypted(data):
        data[6] |= 1
        central = data.rfind(b"PK\x01\x02")
        data[central + 8] |= 1

    for patch, message in ((flip, "its member record.json is damaged"),
                           (method_99, "uses compression method 99"),
                           (encrypted, "is encrypted")):
        bad = _patch_bytes(recording, tmp_path / f"{patch.__name__}.hilarec", patch)
        code, err = _replay(bad, capsys)
        assert code == 2 and message in err and "Traceback" not in err, err


def test_a_record_json_beyond_its_limit_is_refused_unread(tmp_path, capsys, recording, monkeypatch):
    import hila_lang.session.recording as rec

    monkeypatch.setattr(rec, "RECORD_JSON_LIMIT", 1000)
    code, err = _replay(recording, capsys)
    assert code == 2 and "decompressed, more than hila reads (1,000)" in err


def test_unused_members_are_not_read(tmp_path, capsys, recording):
    """A huge (here: damaged) eyes/ image is never read unless asked for: replay and verify work."""
    bad = _rewrite(recording, tmp_path / "eyes.hilarec", extra={"eyes/0001.png": b"\0" * (4 * MB)})
    data = bytearray(bad.read_bytes())
    start = data.find(b"eyes/0001.png") + len("eyes/0001.png")
    data[start + 10: start + 40] = b"\xff" * 30  # its deflate stream broken
    bad.write_bytes(bytes(data))
    from hila_lang.core.errors import InputError
    from hila_lang.session.recording import read_record

    doc = read_record(bad)
    assert list(doc["images"]) == ["eyes/0001.png"]
    with pytest.raises(InputError, match="cannot read the recording's image eyes/0001.png"):
        doc["images"]["eyes/0001.png"]
    assert _replay(bad, capsys)[0] == 0


def test_a_ctrl_c_recording_verifies(tmp_path, capsys, recording):
    """A recording of a run stopped by Ctrl-C (its result: failed, exit 130) used to never verify."""
    def interrupted(doc):
        doc["steps"] = doc["steps"][:1]
        doc["result"] = {"status": "failed", "error": "interrupted (Ctrl-C) between two states", "exit": 130,
                         "state": doc["steps"][0]["next"]}
        return doc

    bad = _rewrite(recording, tmp_path / "c.hilarec", interrupted)
    code = cli.main(["replay", str(bad), "--verify"])
    out = capsys.readouterr().out
    assert code == 0 and "the recording was interrupted at step 2" in out and "no difference: 1 steps verified" in out


# ------------------------------------------------------------------ options and limits

@pytest.mark.parametrize("pair, message", [
    ("osila.shells=100000000", "expected candidate shells from 0 to 100"),
    ("osila.directions=1e8", "expected candidate directions per shell from 1 to 2000"),
    ("osila.shells=10000", "expected candidate shells from 0 to 100"),
    ("osila.rounds=100000", "expected plan-adjustment rounds from 1 to 1000"),
    ("osila.threshold=1e309", "expected a distance in the template's units from 0 to 1000"),
    ("osila.margin=-1", "from 0 to 1000"),
    ("osila.seed=-3", "expected a seed from 0"),
])
def test_every_osila_option_has_a_range_checked_before_any_work(capsys, pair, message):
    code = cli.main(["check", str(ABC), "--set", pair])
    assert code == 2 and message in capsys.readouterr().err


def test_shells_times_directions_is_bounded(capsys):
    code = cli.main(["check", str(ABC), "--set", "osila.shells=100", "--set", "osila.directions=2000"])
    assert code == 2 and "candidates around each waypoint, at most 2000" in capsys.readouterr().err


def test_jobs_are_clamped_to_the_cores_with_a_note():
    from hila_lang.core.resources import clamp_jobs, usable_cores

    note = io.StringIO()
    assert clamp_jobs(1_000_000, note) == usable_cores()
    assert f"--jobs 1000000 is more than the {usable_cores()} cores" in note.getvalue()
    assert clamp_jobs(1, note) == 1 and clamp_jobs(-1, note) == -1


def test_a_main_too_long_is_a_located_error_not_max_of_nothing(tmp_path, capsys, monkeypatch):
    """The issue's 5 MB program: max() of an empty sequence (exit 3) when main has no call."""
    import hila_lang.language.calls as calls

    monkeypatch.setattr(calls, "MAX_STATES", 5)
    prog = tmp_path / "p.hila"
    prog.write_text("main {\n" + "".join(f"  let a{i} = {i}\n" for i in range(10)) + "}\n")
    code = cli.main(["check", str(prog)])
    assert code == 2 and "the program would compile to 11 states (at most 5)" in capsys.readouterr().err


def test_ascii_output_encoding_escapes_instead_of_crashing(tmp_path):
    """PYTHONIOENCODING=ascii: the trace's non-ASCII text was a UnicodeEncodeError (exit 3)."""
    prog = tmp_path / "p.hila"
    prog.write_text('main {\n  let s = "caf\u00e9 \u2192"\n}\n', encoding="utf-8")
    env = {**os.environ, "PYTHONIOENCODING": "ascii"}
    proc = _hila("exec", prog, env=env)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    assert 'set s = "caf\\xe9 \\u2192"' in proc.stdout


def test_a_full_disk_during_trace_is_exit_2_named(tmp_path, capsys, monkeypatch):
    import hila_lang.core.fileio as fileio

    real = fileio.AtomicFile.__init__

    class Full(io.StringIO):
        def write(self, data):
            raise OSError(28, "No space left on device")

    def init(self, path, **kwargs):
        real(self, path, **kwargs)
        if str(path).endswith(".trace"):
            self._fh.close()
            self._fh = Full()

    monkeypatch.setattr(fileio.AtomicFile, "__init__", init)
    prog = tmp_path / "p.hila"
    prog.write_text("main {\n  let a = 1\n}\n")
    trace, record = tmp_path / "run.trace", tmp_path / "run.hilarec"
    code = cli.main(["exec", str(prog), "--quiet", "--trace", str(trace), "--record", str(record)])
    err = capsys.readouterr().err
    assert code == 2 and err == f"{trace}: error: No space left on device\n"
    assert record.is_file() and not list(tmp_path.glob(".run.trace*"))  # the recording still saved


# ------------------------------------------------------------------ cache

def test_the_shared_cache_folder_is_private_and_ours(tmp_path, monkeypatch, capsys):
    from hila_lang.core.fileio import cache_folders

    monkeypatch.setattr("tempfile.gettempdir", lambda: str(tmp_path))
    shared = tmp_path / f"hila-{os.getuid()}"
    assert cache_folders("robot")[-1] == shared / "robot" and (shared.stat().st_mode & 0o777) == 0o700
    os.chmod(shared, 0o777)  # others may have planted files
    assert shared / "robot" not in cache_folders("robot")
    assert "others may write in it (mode 0777" in capsys.readouterr().err
    os.chmod(shared, 0o755)  # ours, readable: made private
    assert cache_folders("robot")[-1] == shared / "robot" and (shared.stat().st_mode & 0o777) == 0o700
    if os.geteuid() == 0:
        os.chown(shared, 12345, 12345)
        assert shared / "robot" not in cache_folders("robot")
        assert "belongs to another user (uid 12345)" in capsys.readouterr().err
    os.rmdir(shared)
    shared.symlink_to(tmp_path)
    assert shared / "robot" not in cache_folders("robot")


def test_a_truncated_cached_robot_model_is_rebuilt_with_a_note(tmp_path, monkeypatch, capsys):
    pytest.importorskip("icub_models")
    from hila_lang.robot import model

    monkeypatch.setenv("HILA_CACHE_DIR", str(tmp_path))
    model.urdf_path.cache_clear()
    try:
        path = model.urdf_path()
        whole = path.read_text()
        path.write_text(whole[: len(whole) // 2])  # truncated
        model.urdf_path.cache_clear()
        assert model.urdf_path() == path and path.read_text() == whole
        assert f"note: the cached robot model {path} is damaged" in capsys.readouterr().err
    finally:
        model.urdf_path.cache_clear()


# ------------------------------------------------------------------ smaller ones (issue 20, item 9)

def test_a_number_too_large_for_a_float_is_a_located_error(tmp_path, capsys):
    """1e309 used to pass check as inf (exec then failed)."""
    prog = tmp_path / "p.hila"
    prog.write_text("main {\n  let a = 1e309\n}\n")
    assert cli.main(["check", str(prog)]) == 2
    assert capsys.readouterr().err.startswith(f"{prog}:2:11: error: the number 1e309 is too large")


def test_cr_only_line_ends_are_lines(tmp_path, capsys):
    prog = tmp_path / "p.hila"
    prog.write_bytes(b"# a comment\rmain {\r  let a = 1\r  let b = 2\r}\r")
    assert cli.main(["check", str(prog)]) == 0
    assert "ok (3 states" in capsys.readouterr().out


def test_learning_one_row_does_not_hint_k_le_0(tmp_path, capsys):
    csv, icps = tmp_path / "one.csv", tmp_path / "one.icps.yaml"
    csv.write_text("t,x,y\n0,0.1,0.2\n")
    icps.write_text("a: [0.1, 0.2]\n")
    code = cli.main(["learn", str(csv), "--icps", str(icps), "-o", str(tmp_path / "t.yaml"), "-k", "2"])
    err = capsys.readouterr().err
    assert code == 2 and "k <= 0" not in err
    assert "a demonstration this short cannot be segmented: record at least 2 points, or use k = 1" in err


def test_a_stopped_games_report_says_unfinished(tmp_path, capsys):
    """Ctrl-C's report.json had result: null while the README says 'unfinished'."""
    from hila_lang.session.runner import finish, prepare
    from hila_lang.plugins.options import RunOptions

    out = tmp_path / "g"
    interp = prepare(str(ROOT / "programs" / "game.hila"), RunOptions(out=out, stdout=io.StringIO()), "dry")
    interp.step()  # one step, then stopped
    finish(interp)
    assert json.loads((out / "report.json").read_text())["result"] == "unfinished"
