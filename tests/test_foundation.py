"""The CLI shell, the error root and atomic file I/O that every stage relies on."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import (
    CheckError,
    ConstraintError,
    HilaError,
    HilaRuntimeError,
    InputError,
)
from hila_lang.core.fileio import atomic_write_text, dump_yaml, load_yaml, read_text
from hila_lang.core.resources import grammar_path


def test_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name in cli.COMMANDS:
        assert name in out, f"'hila --help' does not list {name!r}"


def test_every_command_module_exists_and_has_help():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert set(sub.choices) == set(cli.COMMANDS), "a registered command failed to load"


def test_help_is_instant_and_imports_nothing_heavy():
    code = (
        "import sys, hila_lang.cli as c\n"
        "c.build_parser()\n"
        "heavy = [m for m in ('numpy', 'pybullet', 'sklearn', 'cv2', 'scipy', 'lark', 'pygls', 'lsprotocol') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    elapsed = time.perf_counter() - start
    assert out.stdout.strip() == "", f"building the CLI imported {out.stdout.strip()}"
    assert elapsed < 5.0


def test_no_command_is_bad_usage(capsys):
    assert cli.main([]) == 2


def test_unknown_command_exits_2(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["frobnicate"])
    assert exc.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_error_renders_location_source_and_caret():
    err = CheckError("unknown task 'mrak'", file="game.hila", line=3, column=5,
                     source_line="    mrak(c)\n", hint="did you mean 'mark'?")
    text = str(err)
    assert text.splitlines() == [
        "game.hila:3:5: error: unknown task 'mrak'",
        "        mrak(c)",
        "        ^",
        "hint: did you mean 'mark'?",
    ]
    assert err.exit_code == 2


def test_runtime_errors_name_the_state_and_exit_1():
    err = ConstraintError("forced waypoint 2 contradicts obstacle 0", state="game/mark#2/draw",
                          file="game.hila", line=12, column=9)
    assert isinstance(err, HilaRuntimeError) and err.exit_code == 1
    assert str(err).startswith("game.hila:12:9: error: forced waypoint 2 contradicts obstacle 0 (in state game/mark#2/draw)")


def test_input_error_is_a_value_error():
    assert issubclass(InputError, ValueError) and issubclass(InputError, HilaError)


def test_atomic_write_replaces_whole_file_and_leaves_no_temp(tmp_path):
    target = tmp_path / "sub" / "t.yaml"
    atomic_write_text(target, "a: 1\n")
    atomic_write_text(target, "a: 2\n")
    assert target.read_text() == "a: 2\n"
    assert sorted(os.listdir(target.parent)) == ["t.yaml"]
    mask = os.umask(0)
    os.umask(mask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~mask


def test_atomic_write_failure_keeps_old_content(tmp_path, monkeypatch):
    target = tmp_path / "t.txt"
    atomic_write_text(target, "old")

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        atomic_write_text(target, "new")
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["t.txt"]


def test_yaml_round_trip_and_errors(tmp_path):
    path = dump_yaml(tmp_path / "d.yaml", {"name": "x", "icps": {"a": [1.0, 2.5]}}, header="made by a test")
    assert path.read_text().startswith("# made by a test\n")
    assert load_yaml(path) == {"name": "x", "icps": {"a": [1.0, 2.5]}}

    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nicps: [1, 2\n")
    with pytest.raises(InputError, match=r"not valid YAML") as exc:
        load_yaml(bad)
    assert exc.value.file == str(bad) and exc.value.line is not None

    with pytest.raises(InputError, match="not found"):
        load_yaml(tmp_path / "missing.yaml")

    binary = tmp_path / "b.yaml"
    binary.write_bytes(b"ok\n\xff\xfe")
    with pytest.raises(InputError, match=r"not UTF-8 text \(byte 0xff at offset 3\)"):
        read_text(binary)


def test_grammar_is_found():
    assert grammar_path().name == "hila.lark"
    assert grammar_path().read_text().strip()


def test_unwritable_output_path_is_a_message_not_a_traceback(tmp_path, capsys):
    data = Path(__file__).parent / "data" / "core"
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    rc = cli.main(["learn", str(data / "demo.csv"), "--icps", str(data / "icps.yaml"),
                   "-o", str(blocker / "t.yaml")])
    err = capsys.readouterr().err
    assert rc == 2
    assert str(blocker) in err and "error:" in err and "Traceback" not in err
    assert blocker.read_text() == "not a folder"


def test_atomic_write_onto_a_directory_names_the_destination(tmp_path):
    target = tmp_path / "out.yaml"
    target.mkdir()
    with pytest.raises(OSError) as exc:
        atomic_write_text(target, "a: 1\n")
    assert exc.value.filename == str(target)
    assert os.listdir(tmp_path) == ["out.yaml"]  # no temporary file left behind


def test_write_png_keeps_channel_order(tmp_path):
    import cv2

    rgb = np.zeros((4, 5, 3), np.uint8)
    rgb[..., 0] = 200  # red in RGB
    from hila_lang.core.fileio import write_png

    write_png(tmp_path / "rgb.png", rgb)
    write_png(tmp_path / "bgr.png", rgb[..., ::-1], bgr=True)
    for name in ("rgb.png", "bgr.png"):
        back = cv2.imread(str(tmp_path / name))  # BGR
        assert back.shape == (4, 5, 3) and (back[..., 2] == 200).all() and (back[..., :2] == 0).all()


def test_output_folder_is_fresh_unless_given(tmp_path, monkeypatch):
    from hila_lang.core.fileio import output_folder

    monkeypatch.chdir(tmp_path)
    a, b = output_folder(None, "run-{time}"), output_folder(None, "run-{time}")
    assert a != b and a.parent == b.parent == Path("runs") and a.is_dir() and b.is_dir()
    assert b.name.startswith(a.name)  # the same second: a numbered sibling, never the same folder
    given = tmp_path / "mine" / "deep"
    assert output_folder(given, "ignored") == given and given.is_dir()
