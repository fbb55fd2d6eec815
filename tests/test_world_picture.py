"""The picture world end to end: ``hila exec programs/picture.hila`` on the PyBullet back end.

The robot matches its eye images of a moved, turned, smaller and bent map against the
demonstration's, binds the matched ICPs and retraces the route; the referee's report gives the
route error and the matching figures.  Seed 2's task sheet is bent 2-4 cm (seeded).
"""

import json
from pathlib import Path

import numpy as np
import pytest

from hila_lang.cli import main

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = str(ROOT / "programs" / "picture.hila")


def run(tmp_path, *extra):
    out = tmp_path / "out"
    assert main(["exec", PROGRAM, "--seed", "2", "--out", str(out), *extra]) == 0
    return json.loads((out / "report.json").read_text()), out


@pytest.fixture(scope="module")
def matched(tmp_path_factory):
    return run(tmp_path_factory.mktemp("picture"))


def test_the_program_checks():
    assert main(["check", PROGRAM]) == 0


@pytest.mark.parametrize("line, message", [
    ("let n = ask pairs(1)", "3:13: error: question 'pairs' of the picture world takes 0 argument(s), got 1"),
    ("let n = ask matchd", "3:13: error: the picture world has no question 'matchd'"),
    ("wait moved", "3:5: error: the picture world has no event 'moved'"),
])
def test_check_knows_the_picture_worlds_questions(tmp_path, capsys, line, message):
    """The world's questions are its declared table (plugins/names.py): a misspelt one, or one
    given arguments it does not take, is a located error of 'hila check', before any run."""
    prog = tmp_path / "p.hila"
    prog.write_text(f"world picture\nmain {{\n    {line}\n}}\n")
    assert main(["check", str(prog)]) == 2
    assert f"{prog}:{message}" in capsys.readouterr().err


@pytest.mark.slow
def test_matched_icps_retrace_the_route_on_a_bent_sheet(matched):
    report, out = matched
    assert report["bent_m"] > 0.015
    err = report["route_error_mm"]
    assert err["median"] < 4.0 and err["p95"] < 12.0
    m = report["matching"]
    assert m["matched"] == m["kept"] + m["rejected"] and m["kept"] >= 15
    assert m["precision_after"] >= m["precision_before"]
    controls = report["controls_planned_mm"]
    assert controls["corners"]["median"] > 4 * err["median"]  # the bend is what the corners miss
    for name in ("route.png", "eyes.png"):
        assert (out / name).stat().st_size > 1000


@pytest.mark.slow
def test_four_corners_instead_of_matching_lose_the_route(tmp_path, monkeypatch, matched):
    """Keep, of the robot's matched pairs, only the four nearest the corners of the sheet as it
    saw it: the route error on the bent sheet rises."""
    from hila_lang.worlds.picture.world import PictureWorld

    real = PictureWorld._match

    def corners_only(self):
        real(self)
        kept = np.flatnonzero(self.pairs.kept)
        uv = self.pairs.template_uv[kept]
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        corners = [kept[np.argmin(np.linalg.norm(uv - c, axis=1))] for c in
                   (lo, hi, [lo[0], hi[1]], [hi[0], lo[1]])]
        for i in kept:
            if i not in corners:
                self.points_now[f"match.{self.names[self.pairs.template_index[i]]}"] = None

    monkeypatch.setattr(PictureWorld, "_match", corners_only)
    report, _ = run(tmp_path)
    assert report["route_error_mm"]["median"] > 2 * matched[0]["route_error_mm"]["median"]


def test_without_eyes_the_world_says_which_back_end_it_needs(tmp_path, capsys):
    assert main(["exec", PROGRAM, "--backend", "dry", "--out", str(tmp_path / "out")]) == 1  # a run that cannot go on
    assert "run it with --backend pybullet" in capsys.readouterr().err
