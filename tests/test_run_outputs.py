"""Every run can be seen (issue 23 item 2): ``--out DIR`` writes a picture of the planned and
executed paths with the states named and ``report.json`` in every world, the default scripted
one included; a run prints one line per state unless ``--quiet``, and the result line always."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from hila_lang import cli

ROOT = Path(__file__).resolve().parent.parent
PROGRAM = """import reach
point home = (0.18, -0.25, 0.75)
point cup = (0.30, -0.18, 0.60)
hand at home
main {
    run reach.reach(object = cup, home = home)
    run reach.back(object = cup, home = home)
}
"""


def _program(tmp_path, text=PROGRAM) -> Path:
    prog = tmp_path / "mine.hila"
    prog.write_text(text)
    (tmp_path / "reach.yaml").write_text((ROOT / "primitives" / "reach.yaml").read_text())
    return prog


def test_out_writes_a_picture_and_a_report_for_a_scripted_world_program(tmp_path, capsys):
    import cv2

    prog, out = _program(tmp_path), tmp_path / "out"
    assert cli.main(["exec", str(prog), "--out", str(out), "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines == ["result: finished: 3 steps, 2 run states", f"outputs written to {out}"]  # --quiet: no trace
    report = json.loads((out / "report.json").read_text())
    assert report["world"] == "scripted" and report["backend"] == "dry" and report["finished"] is True
    assert [s["state"] for s in report["states"]] == ["main/reach", "main/back"]
    assert [s["line"] for s in report["states"]] == [6, 7] and report["states"][0]["template"] == "reach"
    assert np.allclose(report["states"][0]["planned_end"], [0.30, -0.18, 0.60], atol=2e-3)
    assert report["states"][0]["end_error_mm"] < 0.01  # the dry back end follows the plan exactly
    image = cv2.imread(str(out / "path.png"))
    assert image is not None and image.shape[1] > 600
    red = (image[:, :, 2] > 180) & (image[:, :, 1] < 80) & (image[:, :, 0] < 80)
    orange = (image[:, :, 2] > 200) & (image[:, :, 1] > 90) & (image[:, :, 1] < 180) & (image[:, :, 0] < 60)
    assert red.sum() > 200 and orange.sum() > 20  # the executed path and the states' marks are drawn


def test_without_quiet_one_line_per_state_and_the_result(tmp_path, capsys):
    prog = _program(tmp_path)
    assert cli.main(["exec", str(prog)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split()[1] for ln in lines[:3]] == ["main/reach", "main/back", "end"]
    assert lines[-1] == "result: finished: 3 steps, 2 run states"
    assert not (tmp_path / "runs").exists()  # no --out: nothing written


def test_a_failed_run_keeps_its_report_and_says_where_it_stopped(tmp_path, capsys):
    script = tmp_path / "s.yaml"
    script.write_text("answers: {ready: [true]}\n")
    text = PROGRAM.replace("    run reach.back(object = cup, home = home)\n",
                           "    if ask ready { run reach.back(object = cup, home = home) }\n"
                           "    if ask ready { run reach.back(object = cup, home = home) }\n")
    prog, out = _program(tmp_path, text), tmp_path / "out"
    assert cli.main(["exec", str(prog), "--out", str(out), "--quiet", "--set", f"script={script}"]) == 1
    captured = capsys.readouterr()
    assert "the script has no more answers to 'ready'" in captured.err
    assert captured.out.splitlines()[0].startswith("result: stopped at step ")
    report = json.loads((out / "report.json").read_text())
    assert report["finished"] is False and report["stopped"]["line"] == 8 and len(report["states"]) == 2


def test_a_bad_out_is_refused_before_the_run(tmp_path, capsys):
    prog = _program(tmp_path)
    (tmp_path / "file").write_text("x")
    assert cli.main(["exec", str(prog), "--out", str(tmp_path / "file")]) == 2
    captured = capsys.readouterr()
    assert "expected a folder, got a file" in captured.err and "main/reach" not in captured.out
