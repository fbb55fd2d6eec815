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
        ("t,x,y,pen\n0,0,0,1\n1,1,1,0.5\n", r"demo\.csv:3: error: expected 1 \(pen down, touching\) or 0 \(pen up\) "
                                          r"in column 'pen', got '0.5'"),
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


# --------------------------------------------------------------------------- the pen's contact (issue 30 item 3)


def drawn_demonstration(tmp_path, mark="triangle", style="careful", seed=0):
    """A person's drawing of ``mark`` on the tic-tac-toe sheet, pen down/up recorded (the seeded
    pointer model), written as hila learn reads it: (demo.csv, icps.yaml, the drawing)."""
    from hila_lang.worlds.tictactoe.drawing import draw_mark, write_demonstration

    drawing = draw_mark(mark, style, seed=seed)
    demo, icps = write_demonstration(tmp_path, mark, drawing)
    return str(demo), str(icps), drawing


def test_a_demonstration_that_records_the_pen_is_cut_where_the_pen_touches_and_leaves(tmp_path, capsys):
    """The issue's case: speed dips put the draw segment where the pen was up; the recorded pen
    puts the cuts exactly at the first touch and the last lift, by default."""
    demo, icps, drawing = drawn_demonstration(tmp_path, "triangle", "careful")
    touch, lift = np.flatnonzero(drawing.pen)[[0, -1]]
    rc = main(["learn", demo, "--icps", icps, "-k", "3", "--tags", "reach,draw,retract", "--contact", "draw",
               "-o", str(tmp_path / "tri.yaml")])
    assert rc == 0
    t = load_template(tmp_path / "tri.yaml")
    assert [(s.start, s.stop) for s in t.segments] == [(0, touch), (touch, lift + 1), (lift + 1, len(drawing.path))]
    assert "where the pen touches and leaves the paper, as recorded" in t.description
    # the careful person pauses at the triangle's corners: the deepest speed dips are there
    rc = main(["learn", demo, "--icps", icps, "-k", "3", "--tags", "reach,draw,retract", "--contact", "draw",
               "--method", "speed", "-o", str(tmp_path / "speed.yaml")])
    speed = load_template(tmp_path / "speed.yaml").segment("draw")
    assert rc == 0 and (speed.start, speed.stop) != (touch, lift + 1)


def test_a_letter_of_two_strokes_keeps_the_pen_up_move_between_them_in_the_draw(tmp_path):
    demo, icps, drawing = drawn_demonstration(tmp_path, "A", "quick")
    strokes = np.flatnonzero(np.diff(drawing.pen.astype(int)) == 1)
    assert len(strokes) == 2  # the letter A: two strokes, the pen up between them
    rc = main(["learn", demo, "--icps", icps, "--tags", "reach,draw,retract", "-o", str(tmp_path / "a.yaml")])
    t = load_template(tmp_path / "a.yaml")
    draw = t.segment("draw")
    assert rc == 0 and draw.start == strokes[0] + 1 and draw.stop == np.flatnonzero(drawing.pen)[-1] + 1
    # without --contact the tags whose samples are mostly pen-down touch
    assert [s.contact for s in t.segments] == [False, True, False]


def test_cuts_moved_by_hand_are_remade_by_one_command(tmp_path, capsys):
    demo, icps, drawing = drawn_demonstration(tmp_path, "tick", "quick")
    out = tmp_path / "tick.yaml"
    rc = main(["learn", demo, "--icps", icps, "--tags", "reach,draw,retract", "--contact", "draw", "--cuts", "9,30",
               "-o", str(out)])
    t = load_template(out)
    assert rc == 0 and [(s.start, s.stop, s.contact) for s in t.segments] == [
        (0, 9, False), (9, 30, True), (30, len(drawing.path), False)]
    assert "Cut by hand at samples 9, 30 (--cuts; k = 3)." in t.description
    capsys.readouterr()
    for cuts, message in [("9", r"--cuts 9: expected 2 cut\(s\) for k = 3 segments, got 1"),
                          ("9,10", r"expected increasing cuts that leave every tag 2 samples or more of the \d+, got a "
                                   r"tag \[9, 10\)"),
                          ("9,x", r"--cuts 9,x: expected sample indices separated by commas")]:
        rc = main(["learn", demo, "--icps", icps, "--tags", "reach,draw,retract", "--cuts", cuts, "-o", str(out)])
        assert rc == 2 and re.search(message, capsys.readouterr().err)
    rc = main(["learn", demo, "--icps", icps, "--tags", "a,b,c", "--cuts", "9,30", "--method", "speed", "-o", str(out)])
    assert rc == 2 and "--cuts and --method both say where to cut: give one" in capsys.readouterr().err


def test_contact_cuts_need_a_recorded_pen_that_changes(tmp_path, capsys):
    demo = write(tmp_path, "d.csv", "t,x,y\n" + "".join(f"{i / 20},{i / 100},0\n" for i in range(20)))
    icps = write(tmp_path, "i.yaml", "a: [0, 0]\n")
    rc = main(["learn", demo, "--icps", icps, "--tags", "a,b,c", "--method", "contact", "-o", str(tmp_path / "x.yaml")])
    assert rc == 2 and "d.csv: error: segmentation method 'contact' needs the pen's contact at every sample" in \
        capsys.readouterr().err
    down = write(tmp_path, "p.csv", "t,x,y,pen\n" + "".join(f"{i / 20},{i / 100},0,1\n" for i in range(20)))
    rc = main(["learn", down, "--icps", icps, "--tags", "a,b,c", "-o", str(tmp_path / "x.yaml")])
    assert rc == 2 and "cannot cut by the pen's contact: the pen touches the surface throughout" in \
        capsys.readouterr().err
    assert not (tmp_path / "x.yaml").exists()
