"""``hila learn`` and ``hila imitate``: happy paths, exit codes, messages without tracebacks."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hila_lang.cli import main
from hila_lang.osila.template import load_template

DATA = Path(__file__).parent / "data" / "core"


def read_csv(path):
    lines = Path(path).read_text().splitlines()
    return lines[0], np.array([[float(c) for c in ln.split(",")] for ln in lines[1:]])


def test_learn_then_imitate(tmp_path, capsys):
    out = tmp_path / "primitives" / "circle.yaml"
    rc = main(["learn", str(DATA / "demo.csv"), "--icps", str(DATA / "icps.yaml"), "-k", "3",
               "--tags", "reach,draw,retract", "--contact", "draw", "-o", str(out)])
    assert rc == 0
    t = load_template(out)
    assert t.tags() == ["reach", "draw", "retract"] and t.segment("draw").contact
    assert t.name == "circle" and t.path.shape == (200, 3) and t.times is not None
    assert "learned template 'circle'" in capsys.readouterr().out

    csv = tmp_path / "out.csv"
    rc = main(["imitate", str(out), "--task", str(DATA / "task.yaml"), "-o", str(csv)])
    assert rc == 0
    summary = capsys.readouterr().out
    assert "warp tps" in summary and "forced waypoint 0: passed" in summary
    header, rows = read_csv(csv)
    assert header == "t,x,y,z" and rows.shape == (200, 4)
    # forced waypoint passed within the task's threshold, obstacle avoided
    assert np.linalg.norm(rows[:, 1:] - [0.2, -0.12, 0.82], axis=1).min() <= 0.002 + 1e-12
    assert (np.linalg.norm(rows[:, 1:] - [0.17, -0.16, 0.84], axis=1) >= 0.015).all()


def test_imitate_sub_to_stdout(capsys):
    rc = main(["imitate", str(DATA / "circle.yaml"), "--task", str(DATA / "task.yaml"), "--sub", "draw",
               "--threshold", "0.001"])
    assert rc == 0
    cap = capsys.readouterr()
    assert cap.out.startswith("t,x,y,z\n") and len(cap.out.splitlines()) == 1 + 128
    assert "imitated 'circle.draw'" in cap.err and "threshold 0.001" in cap.err


def write(tmp_path, name, text):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


@pytest.mark.parametrize(
    "csv_text,message",
    [
        ("t,x,y\n0,0,0\n1,1\n", r"demo\.csv:3: error: expected 3 columns \(t,x,y\), got 2"),
        ("t,x,y\n0,0,0\n1,1,abc\n", r"demo\.csv:3: error: expected a finite number in column 'y', got 'abc'"),
        ("t,x,y\n0,0,0\n0,1,1\n", r"demo\.csv:3: error: expected increasing times in column 't', got 0.0 after 0.0"),
        ("a,b,c\n0,0,0\n", r"demo\.csv:1: error: expected the header 't,x,y', 't,x,y,z', 'x,y' or 'x,y,z' \(each "
                            r"optionally with a last column 'pen'\), got 'a,b,c'"),
        ("t,x,y\n", r"demo\.csv: error: demonstration CSV has a header but no data rows"),
        ("", r"demo\.csv: error: demonstration CSV is empty"),
    ],
)
def test_learn_bad_csv(tmp_path, capsys, csv_text, message):
    demo = write(tmp_path, "demo.csv", csv_text)
    icps = write(tmp_path, "icps.yaml", "a: [0, 0]\n")
    rc = main(["learn", demo, "--icps", icps, "-o", str(tmp_path / "x.yaml")])
    assert rc == 2
    assert re.search(message, capsys.readouterr().err)
    assert not (tmp_path / "x.yaml").exists()


@pytest.mark.parametrize(
    "task_text,args,message",
    [
        ("icps: {cell.tl: [0, 0, 0]}\ncolour: red\n", [], r"task\.yaml: error: unknown field 'colour' in task"),
        ("icps:\n  cell.tl: [0, 0, 0]\n  cell.tl: [1, 0, 0]\n", [], r"task\.yaml:3:3: error: task is not valid YAML: duplicate key 'cell.tl'"),
        ("icps: {hnad: [0, 0, 0]}\n", [], r"task ICP 'hnad' is not an ICP of template 'circle' \(cell.tl, .*\nhint: did you mean 'hand'\?"),
        ("icps: {cell.tl: [0, 0]}\n", [], r"expected field 'icps.cell.tl' as 3 numbers \(the template's D\), got \[0, 0\]"),
        ("icps: {cell.tl: [0, 0, 0]}\n", [], r"step 0 \(circle\): task gives no ICP 'cell.tr'"),
        ("icps: {cell.tl: [0, 0, 0]}\noptions: {treshold: 1}\n", [], r"unknown option 'treshold' in field 'options'"),
        ("- not a mapping\n", [], r"expected a task mapping with 'icps:', got list"),
        ("icps: {cell.tl: [0, 0, 0]}\n", ["--sub", "drw"], r"template has no sub-template 'drw'; tags: reach, draw, retract\nhint: did you mean 'draw'\?"),
        ("icps: {1: [0, 0, 0]}\n", [], r"task\.yaml: error: expected ICP names as strings in field 'icps', got 1"),
        ("icps: {cell.tl: [0, 0, 0], cell.tr: [0, 1, 0], cell.bl: [1, 0, 0], cell.br: [1, 1, 0], hand: [0, 0, 1]}\n"
         "obstacles: [[0, 0, 1]]\n", [],
         r"expected obstacles of shape \(K, 4\) \(D = 3 centre coordinates, then the radius\), got \(1, 3\)"),
        ("icps: {cell.tl: [0, 0, 0]}\n", ["--threshold", "nan"], r"(?m)^error: expected --threshold >= 0, got nan"),
        ("icps: {cell.tl: [0, 0, 0]}\n", ["--rounds", "0"], r"(?m)^error: expected --rounds >= 1, got 0"),
        ("icps: {cell.tl: [0, 0, 0]}\n", ["--timing", "-1"], r"(?m)^error: expected --timing >= 0, got -1"),
    ],
)
def test_imitate_bad_task(tmp_path, capsys, task_text, args, message):
    task = write(tmp_path, "task.yaml", task_text)
    rc = main(["imitate", str(DATA / "circle.yaml"), "--task", task, *args])
    assert rc == 2
    assert re.search(message, capsys.readouterr().err)


@pytest.mark.parametrize("icps_text, message", [
    ("a: [0, .nan]\n", r"icps\.yaml: error: expected finite numbers for ICP 'a', got \[0, nan\]"),
    (None, r"icps\.yaml: error: scene ICP file not found"),
])
def test_learn_bad_icps(tmp_path, capsys, icps_text, message):
    demo = write(tmp_path, "demo.csv", "x,y\n0,0\n1,1\n")
    icps = write(tmp_path, "icps.yaml", icps_text) if icps_text is not None else str(tmp_path / "icps.yaml")
    rc = main(["learn", demo, "--icps", icps, "-o", str(tmp_path / "x.yaml")])
    assert rc == 2
    assert re.search(message, capsys.readouterr().err)
    assert not (tmp_path / "x.yaml").exists()


def test_contradiction_exits_1(tmp_path, capsys):
    text = (DATA / "task.yaml").read_text().replace("centre: [0.17, -0.16, 0.84]", "centre: [0.2, -0.12, 0.82]")
    task = write(tmp_path, "task.yaml", text)
    rc = main(["imitate", str(DATA / "circle.yaml"), "--task", task])
    assert rc == 1
    assert "contradictory constraints: forced waypoint 0" in capsys.readouterr().err


def test_cli_subprocess_no_traceback(tmp_path):
    bad = write(tmp_path, "bad.yaml", "\x00\x01 not yaml: [")
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "imitate", bad, "--task", bad],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "bad.yaml" in proc.stderr


@pytest.mark.parametrize("args, message", [
    ([], r"expected one demonstration source \(DEMO.csv, --from-sim, --frames or --left/--right\), got none"),
    (["DEMO", "--from-sim"], r"got DEMO.csv and --from-sim"),
    (["DEMO"], r"DEMO.csv needs its scene ICPs: add --icps ICPS.yaml"),
    (["--from-sim", "--icps", "ICPS"], r"--icps goes with DEMO.csv; --from-sim finds the ICPs in the images"),
    (["--left", "l/"], r"expected both --left and --right frames"),
    (["DEMO", "--icps", "ICPS", "--keep-recording", "r/"], r"--keep-recording goes with --from-sim"),
    (["--frames", "rec/", "--method", "equal"], r"expected a recording folder"),
])
def test_learn_source_errors(tmp_path, capsys, args, message):
    args = [str(DATA / "demo.csv") if a == "DEMO" else str(DATA / "icps.yaml") if a == "ICPS" else a for a in args]
    out = tmp_path / "t.yaml"
    assert main(["learn", *args, "-o", str(out)]) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()
