"""hila learn --library / --report (issue 26): the game's second demonstration, the report, bad libraries."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stumpy")
pytest.importorskip("dtaidistance")

from hila_lang.cli import main  # noqa: E402
from hila_lang.osila.motion import minimum_jerk_samples  # noqa: E402
from hila_lang.recognition.shape import procrustes_distance  # noqa: E402
from hila_lang.osila.template import load_template  # noqa: E402
from hila_lang.worlds.tictactoe.board import Grid  # noqa: E402
from hila_lang.worlds.tictactoe.demonstration import RATE_HZ, demonstrate  # noqa: E402
from hila_lang.worlds.tictactoe.marks import cross_strokes  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CIRCLE = ROOT / "primitives" / "circle.yaml"


def _move(a, b, seconds):
    n = max(int(round(seconds * RATE_HZ)), 3)
    return a + minimum_jerk_samples(n + 1)[1:, None] * (b - a)


def circle_then_cross(seed: int):
    """The demonstration model's reach and circle in one cell, then a cross drawn in another.

    Returns (path (T, 3), times (T,), icps, truth [(tag, start, stop)], first sample of the cross).
    """
    rng = np.random.default_rng(seed + 100)
    cell = 1 + seed % 9
    d = demonstrate(seed, cell=cell)
    reach, draw = d.phases["reach"], d.phases["draw"]
    pieces = [d.path[: draw[1]]]
    here = d.path[draw[1] - 1]
    other = next(c for c in (3, 7, 9, 2) if c != cell)
    for bar in cross_strokes(Grid.demonstration(), other, rng, points_per_stroke=20):
        up, above = here + [0, 0, 0.02], bar[0] + [0, 0, 0.02]
        stroke = bar[0] + minimum_jerk_samples(int(0.7 * RATE_HZ))[:, None] * (bar[-1] - bar[0])
        pieces += [_move(here, up, 0.25), _move(up, above, 0.6), _move(above, bar[0], 0.25), stroke[1:]]
        here = stroke[-1]
    path = np.vstack(pieces) + np.random.default_rng(seed).normal(scale=0.0003, size=(sum(map(len, pieces)), 3))
    return path, np.arange(len(path)) / RATE_HZ, d.icps, [("reach", *reach), ("draw", *draw)], draw[1]


def _write_demo(tmp_path: Path, path, times, icps) -> tuple[str, str]:
    demo = tmp_path / "demo2.csv"
    demo.write_text("t,x,y,z\n" + "".join(f"{float(t)!r},{float(p[0])!r},{float(p[1])!r},{float(p[2])!r}\n" for t, p in zip(times, path)))
    scene = tmp_path / "scene.yaml"
    scene.write_text("".join(f"{k}: [{', '.join(repr(float(x)) for x in v)}]\n" for k, v in icps.items()))
    return str(demo), str(scene)


@pytest.fixture()
def library(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    shutil.copy(CIRCLE, lib / "circle.yaml")
    return lib


@pytest.mark.parametrize("seed", [0, 2, 5])
def test_game_reach_circle_known_cross_new(tmp_path, library, capsys, seed):
    path, times, icps, truth, cross = circle_then_cross(seed)
    demo, scene = _write_demo(tmp_path, path, times, icps)
    out, report = tmp_path / "second.yaml", tmp_path / "parts.json"
    rc = main(["learn", demo, "--icps", scene, "--library", str(library), "--report", str(report),
               "--tags", "cross", "--contact", "cross", "-o", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    doc = json.loads(report.read_text())
    assert list(doc) == ["segments"]
    segs = doc["segments"]
    assert all(list(s) == ["start", "end", "template", "tag", "distance"] for s in segs)
    assert segs[0]["start"] == 0 and segs[-1]["end"] == len(path)
    assert all(a["end"] == b["start"] for a, b in zip(segs, segs[1:]))
    known = [s for s in segs if s["template"] is not None]
    assert [(s["template"], s["tag"]) for s in known] == [("circle", "reach"), ("circle", "draw")]
    for s, (tag, a, b) in zip(known, truth):
        assert abs(s["start"] - a) <= 0.15 * (b - a) + 1 and abs(s["end"] - b) <= 0.15 * (b - a) + 1, (s, tag, a, b)
        assert 0 <= s["distance"] < 0.2
    # the cross is new: every sample after the circle is in a part with no template
    after = [s for s in segs if s["end"] > known[-1]["end"]]
    assert after and all(s["template"] is None for s in after) and after[-1]["end"] - after[0]["start"] >= len(path) - cross - 4
    assert "known  reach" in text and "= circle.draw" in text and "new    cross" in text
    written = load_template(out)
    assert [s.tag for s in written.segments][:2] == ["reach", "draw"] and "cross" in written.tags()
    assert written.segment("draw").contact and written.segment("cross").contact
    assert "circle.draw from" in written.description
    # the known parts are the library's sub-templates, moved to where they were seen
    lib = load_template(CIRCLE)
    for tag in ("reach", "draw"):
        seg = written.segment(tag)
        mine = written.path[seg.start:seg.stop]
        theirs = lib.sub(tag).path
        k = np.linspace(0, len(theirs) - 1, len(mine))
        theirs = np.column_stack([np.interp(k, np.arange(len(theirs)), theirs[:, d]) for d in range(3)])
        assert procrustes_distance(mine, theirs) < 1e-6
        assert np.linalg.norm(mine[0] - path[seg.start]) < 0.02


def test_without_icps_the_library_run_uses_the_demonstrations_own_ends(tmp_path, library, capsys):
    path, times, icps, truth, _ = circle_then_cross(0)
    demo, _ = _write_demo(tmp_path, path, times, icps)
    out, report = tmp_path / "second.yaml", tmp_path / "parts.json"
    rc = main(["learn", demo, "--library", str(library), "--report", str(report), "--tags", "cross", "-o", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "no --icps: the demonstration's own ends are its ICPs: start (" in text  # said, not silent
    written = load_template(out)
    assert list(written.icps) == ["start", "end"]
    np.testing.assert_array_equal(written.icps["start"], path[0])
    np.testing.assert_array_equal(written.icps["end"], path[-1])
    assert "its own ends as ICPs" in written.description
    known = [s for s in json.loads(report.read_text())["segments"] if s["template"] is not None]
    assert [(s["template"], s["tag"]) for s in known] == [("circle", "reach"), ("circle", "draw")]
    # without --library a CSV demonstration still needs its scene
    assert main(["learn", demo, "-o", str(tmp_path / "x.yaml")]) == 2
    assert "DEMO.csv needs its scene ICPs: add --icps ICPS.yaml" in capsys.readouterr().err


def test_report_needs_library(tmp_path, capsys):
    path, times, icps, *_ = circle_then_cross(0)
    demo, scene = _write_demo(tmp_path, path, times, icps)
    assert main(["learn", demo, "--icps", scene, "--report", str(tmp_path / "r.json"), "-o", str(tmp_path / "x.yaml")]) == 2
    assert "--report goes with --library" in capsys.readouterr().err


@pytest.mark.parametrize("case, message", [
    ("missing", r"lib: error: library folder does not exist"),
    ("empty", r"lib: error: library folder holds no templates"),
    ("broken", r"lib/b_broken\.yaml.*missing field 'path'|lib/b_broken\.yaml.*error"),
    ("file", r"error: expected a folder of templates"),
])
def test_bad_library_is_located_and_nothing_written(tmp_path, capsys, case, message):
    path, times, icps, *_ = circle_then_cross(0)
    demo, scene = _write_demo(tmp_path, path, times, icps)
    lib = tmp_path / "lib"
    if case != "missing" and case != "file":
        lib.mkdir()
    if case == "broken":
        shutil.copy(CIRCLE, lib / "a_circle.yaml")
        (lib / "b_broken.yaml").write_text("hila_template: 1\nname: broken\nicps: {}\n")
    if case == "file":
        lib.write_text("not a folder\n")
    out, report = tmp_path / "x.yaml", tmp_path / "r.json"
    out.write_text("precious\n")
    rc = main(["learn", demo, "--icps", scene, "--library", str(lib), "--report", str(report), "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 2
    assert pytest.importorskip("re").search(message, err), err
    assert "Traceback" not in err
    assert out.read_text() == "precious\n" and not report.exists()


PROGRAM = """\
# The second demonstration, recognised against the library, run at once on a new cell.
import second

point cell.tl = (0.36, -0.02, 0.571)
point cell.tr = (0.36, -0.09, 0.571)
point cell.br = (0.29, -0.09, 0.571)
point cell.bl = (0.29, -0.02, 0.571)
hand at (0.22, -0.30, 0.74)

main {
    run second.reach(tl = cell.tl, tr = cell.tr, br = cell.br, bl = cell.bl, hand = none)
    run second.draw(tl = cell.tl, tr = cell.tr, br = cell.br, bl = cell.bl, hand = none)
    run second.cross(tl = cell.tl, tr = cell.tr, br = cell.br, bl = cell.bl, hand = none)
}
"""


def test_recognised_demonstration_runs_and_explain_names_library_parts(tmp_path, library, capsys):
    path, times, icps, *_ = circle_then_cross(0)
    demo, scene = _write_demo(tmp_path, path, times, icps)
    (tmp_path / "primitives").mkdir()
    assert main(["learn", demo, "--icps", scene, "--library", str(library), "--tags", "cross", "--contact", "cross",
                 "-o", str(tmp_path / "primitives" / "second.yaml")]) == 0
    program = tmp_path / "task.hila"
    program.write_text(PROGRAM)
    capsys.readouterr()
    assert main(["exec", str(program)]) == 0
    assert main(["explain", str(program)]) == 0
    out = capsys.readouterr().out.splitlines()
    used = [line for line in out if line.startswith("  library part: ")]
    assert used == [
        f"  library part: circle.reach (from {library / 'circle.yaml'}, recognised at distance {d}) as reach"
        for d in [used[0].split("distance ")[1].split(")")[0]]
    ] + [
        f"  library part: circle.draw (from {library / 'circle.yaml'}, recognised at distance {d}) as draw"
        for d in [used[1].split("distance ")[1].split(")")[0]]
    ]
    # the new part is not a library part: its state says nothing of the library
    cross = out.index(next(line for line in out if "second.cross" in line))
    assert not out[cross + 1].startswith("  library part:")
