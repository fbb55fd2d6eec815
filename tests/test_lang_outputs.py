"""Nothing lost (issue 13): outputs are checked before any work, written atomically, saved when
a run fails, and a reused folder holds one run; write errors name the user's path."""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import pytest

from hila_lang import cli
from hila_lang.core.fileio import AtomicFile, OutputFolder, atomic_write_text

ROOT = Path(__file__).resolve().parent.parent
GAME = str(ROOT / "programs" / "game.hila")


@pytest.mark.parametrize("out, message", [
    ("/proc/x", "/proc/x: error: cannot make its folder /proc/x: No such file or directory"),
    ("{tmp}/some-file/sub", "{tmp}/some-file/sub: error: cannot make its folder: {tmp}/some-file is a file"),
])
def test_a_bad_out_is_refused_before_the_game_is_played(tmp_path, capsys, monkeypatch, out, message):
    """The issue's inputs: the game used to be played to the end and then lost."""
    (tmp_path / "some-file").write_text("x")
    out, message = out.format(tmp=tmp_path), message.format(tmp=tmp_path)
    asked = io.StringIO("5\n5\n5\n5\n5\n")  # a person at the prompt: never asked
    monkeypatch.setattr("sys.stdin", asked)
    code = cli.main(["exec", GAME, "--backend", "dry", "--opponent", "human", "--out", out])
    captured = capsys.readouterr()
    assert code == 2 and captured.err == message + "\n"
    assert "your move" not in captured.out and "plays cell" not in captured.out and asked.tell() == 0


def test_write_errors_name_the_users_path_not_a_temporary_file(tmp_path, capsys):
    with pytest.raises(OSError) as info:
        atomic_write_text("/proc/x.csv", "a\n")
    assert info.value.filename == "/proc/x.csv"
    task = tmp_path / "task.yaml"
    task.write_text("icps:\n  home: [0.2, -0.2, 0.7]\n  object: [0.3, -0.1, 0.6]\n")
    code = cli.main(["imitate", str(ROOT / "primitives" / "reach.yaml"), "--task", str(task), "-o", "/proc/x.csv"])
    err = capsys.readouterr().err
    assert code == 2 and err == "/proc/x.csv: error: No such file or directory\n" and ".tmp" not in err


def test_an_atomic_file_publishes_whole_or_not_at_all(tmp_path):
    target = tmp_path / "t.txt"
    target.write_text("old\n")
    f = AtomicFile(target)
    f.write("new 1\n")
    assert target.read_text() == "old\n"  # nothing published yet
    f.write("new 2\n")
    f.commit()
    assert target.read_text() == "new 1\nnew 2\n" and sorted(os.listdir(tmp_path)) == ["t.txt"]
    g = AtomicFile(target)
    g.write("half")
    g.discard()
    assert target.read_text() == "new 1\nnew 2\n" and sorted(os.listdir(tmp_path)) == ["t.txt"]


def test_a_reused_out_folder_holds_one_run(tmp_path, capsys):
    """The issue's input: --out reusing a PyBullet run's folder with --backend dry left its eye.png."""
    out = tmp_path / "game"
    out.mkdir()
    (out / "eye.png").write_bytes(b"an earlier PyBullet run's eye image")
    (out / "notes.txt").write_text("mine")  # not a file hila writes: left alone
    assert cli.main(["exec", GAME, "--backend", "dry", "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    files = json.loads((out / "report.json").read_text())["files"]
    assert "eye.png" not in files and not (out / "eye.png").exists()
    assert sorted(p.name for p in out.iterdir()) == sorted(files + ["notes.txt", ".hila-run.json"])


def test_output_folder_made_and_proved_before_use(tmp_path):
    folder = OutputFolder(tmp_path / "a" / "b", "unused", owned=("x.txt", "y.txt"))
    assert folder.path.is_dir() and list(folder.path.iterdir()) == []  # the probe is gone
    (folder.path / "y.txt").write_text("stale")
    folder.write_text("x.txt", "1")
    assert folder.close() == ["x.txt"] and sorted(p.name for p in folder.path.iterdir()) == [".hila-run.json", "x.txt"]
    os.chmod(tmp_path / "a", 0o500)
    try:
        if os.geteuid() != 0:  # root writes anywhere
            with pytest.raises(OSError, match="cannot write in this folder"):
                OutputFolder(tmp_path / "a" / "b", "unused")
    finally:
        os.chmod(tmp_path / "a", 0o700)


def test_a_run_that_fails_still_saves_what_it_did(tmp_path, capsys):
    """The letters world writes its paper and report when the run fails after the first letter."""
    prog = tmp_path / "p.hila"
    prog.write_text(f'world letters\nimport "{ROOT}/primitives/letters/H.yaml" as H\n'
                    "main {\n  let s = ask next_slot\n  run H(s.*)\n  let z = 1 / 0\n}\n")
    out = tmp_path / "out"
    assert cli.main(["exec", str(prog), "--set", "word=HI", "--out", str(out), "--quiet"]) == 1
    captured = capsys.readouterr()
    assert "division by zero" in captured.err
    report = json.loads((out / "report.json").read_text())
    assert report["written"] == "H" and not report["complete"] and (out / "paper.png").is_file()


def test_hila_exec_names_the_program_as_people_type_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # outside the checkout
    assert cli.main(["check", "game.hila"]) == 0
    assert "game.hila: ok" in capsys.readouterr().out
    other = tmp_path / "mine"
    other.mkdir()
    (other / "game.hila").write_text("main { }\n")  # HILA_PATH comes first
    monkeypatch.setenv("HILA_PATH", str(other))
    assert cli.main(["check", "game.hila"]) == 0
    assert f"{other / 'game.hila'}: ok (1 states" in capsys.readouterr().out
    assert cli.main(["check", "nothere.hila"]) == 2
    assert capsys.readouterr().err == "nothere.hila: error: program not found\n"


def test_templates_are_found_along_the_search_path(tmp_path, monkeypatch, capsys):
    from hila_lang.core.resources import shipped, template_search_path

    monkeypatch.chdir(tmp_path)
    prog = tmp_path / "x.hila"
    prog.write_text("world tictactoe\nimport circle\nmain { let c = ask best_move\n"
                    "  run circle.reach(c.*, hand = arm.lift, start = none) }\n")
    assert cli.main(["check", str(prog)]) == 0  # the package's own circle.yaml
    capsys.readouterr()
    mine = tmp_path / "lib"
    (mine / "primitives").mkdir(parents=True)
    (mine / "primitives" / "circle.yaml").write_text("not: [a template")
    monkeypatch.setenv("HILA_PATH", str(mine))
    assert template_search_path(str(prog))[:2] == [mine, mine / "primitives"]
    assert template_search_path(str(prog))[-1] == shipped("primitives")
    assert cli.main(["check", str(prog)]) == 2  # HILA_PATH's circle.yaml comes first (and is broken)
    assert "cannot load template 'circle'" in capsys.readouterr().err

