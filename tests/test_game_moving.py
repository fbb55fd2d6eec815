"""The sheet moves while the robot draws (issue 34): the referee's moves (``board.slide``,
``board.turn``, ``board.jump``), the robot's glance that follows the grid, and one tracked circle
on the PyBullet iCub with the sheet sliding and turning under its pen."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.sim.motion import SLIDE_SECONDS, SheetMotion, carried, moved
from hila_lang.worlds.tictactoe.board import Grid, cell_corners
from hila_lang.worlds.tictactoe.referee import pose_of
from hila_lang.worlds.tictactoe.tracking import GATE, SheetTracker


def test_the_sheets_moves_are_seeded_stay_near_the_layout_and_are_kept_per_step():
    home = (0.31, -0.09, math.radians(15))
    poses = []
    for seed in range(20):
        motion = SheetMotion(home, np.random.default_rng(seed), slide=0.03, turn=10.0)
        pose = home
        for stroke in range(5):
            motion.begin(pose, 2.0)
            steps = [motion.pose(k / 240) for k in range(1, 241 + int(SLIDE_SECONDS * 240))]
            pose = steps[-1]
            assert len(motion.during) == len(steps)
            assert np.hypot(pose[0] - home[0], pose[1] - home[1]) <= 0.03 + 1e-9  # within D of the layout
            assert abs(pose[2] - home[2]) <= math.radians(10) + 1e-9
            start = motion.moves[-1]["at_s"]
            assert 0.4 <= start <= 1.2  # at 20-60 % of the 2 s stroke
            assert motion.moves[-1]["slide_mm"] == pytest.approx(30.0)
            motion.end()
        poses.append(pose)
    assert len({p[:2] for p in poses}) == 20  # seeded: every seed its own moves
    twice = [SheetMotion(home, np.random.default_rng(3), slide=0.03, turn=10.0) for _ in range(2)]
    for m in twice:
        m.begin(home, 2.0)
    assert twice[0].moves == twice[1].moves and twice[0].pose(1.5) == twice[1].pose(1.5)
    jump = SheetMotion(home, np.random.default_rng(0), jump=0.01)
    jump.begin(home, 2.0)
    at = jump.moves[0]["at_s"]
    before, after = jump.pose(at - 0.01), jump.pose(at + 0.001)
    assert before == home and np.hypot(after[0] - home[0], after[1] - home[1]) == pytest.approx(0.01)


def test_ink_is_carried_to_where_it_lies_on_the_sheet_now():
    start, end = (0.3, -0.1, 0.2), (0.32, -0.09, 0.3)
    point = np.array([[0.33, -0.08, 0.57]])
    on_end = moved(point, start, end)
    assert np.allclose(moved(on_end, end, start), point)  # and back
    assert np.linalg.norm(on_end[0, :2] - end[:2]) == pytest.approx(np.linalg.norm(point[0, :2] - start[:2]))
    pts = np.repeat(point, 3, axis=0)
    out = carried(pts, [start, end], end)  # the last sample: the sheet was where it is now
    assert np.allclose(out[0], on_end[0]) and np.allclose(out[1:], point)


def _ink_of(grid: Grid, rng, n_per_line=150, outliers=200):
    """Grid-ink pixels (x, y) of ``grid``'s four lines, 1 mm jitter, half of each line hidden,
    with stray dark pixels elsewhere (what a glance picks out of an image)."""
    pts = []
    for a, b in ((seg[0], seg[1]) for seg in grid.grid_lines()):
        t = rng.uniform(0.0, 0.5, n_per_line)  # the near half only: the hand hides the rest
        pts.append(a[:2] + t[:, None] * (b - a)[:2] + rng.normal(0, 0.0003, (n_per_line, 2)))
    pts.append(np.asarray(grid.grid_center) + rng.uniform(-0.12, 0.12, (outliers, 2)))
    return np.vstack(pts)


@pytest.mark.parametrize("shift, turn", [((0.003, -0.002), 1.0), ((0.021, 0.012), 4.0), ((-0.03, 0.01), -3.0)])
def test_the_glance_registers_the_known_grid_on_what_is_seen(shift, turn):
    rng = np.random.default_rng(7)
    known = Grid.game()
    from dataclasses import replace

    now = replace(known, grid_center=tuple(np.add(known.grid_center, shift)),
                  grid_rotation=known.grid_rotation + math.radians(turn))
    tracker = SheetTracker({c: cell_corners(known, c) for c in range(1, 10)}, known.surface_z)
    found = tracker.register(_ink_of(now, rng))
    assert found is not None
    phi, tau, inliers, weakest = found
    assert inliers > 300 and weakest > 100
    # apply it as the glance does: the corners the robot binds are where the grid is now
    c, s = math.cos(-phi), math.sin(-phi)
    axes = np.column_stack([tracker.right, tracker.far])
    for cell in (1, 5, 9):
        for name, p in cell_corners(known, cell).items():
            local = tracker._local(p[None, :2])[0] - tau
            xy = tracker.centre[:2] + axes @ np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]])
            assert np.linalg.norm(xy - cell_corners(now, cell)[name][:2]) < 1e-3, (cell, name)


def test_a_glance_that_sees_too_little_of_the_grid_keeps_what_the_robot_knew():
    rng = np.random.default_rng(1)
    known = Grid.game()
    tracker = SheetTracker({c: cell_corners(known, c) for c in range(1, 10)}, known.surface_z)
    lines = known.grid_lines()
    one_line = lines[0][0][:2] + rng.uniform(0, 1, (400, 1)) * (lines[0][1] - lines[0][0])[:2]
    assert tracker.register(one_line) is None  # one direction only: the shift along it is unknown
    assert tracker.register(rng.uniform(-1, 1, (50, 2))) is None
    assert GATE <= 0.005


def test_the_sheet_moves_only_for_a_robot_with_eyes_and_a_streaming_arm(tmp_path, capsys):
    code = cli.main(["exec", "programs/game.hila", "--backend", "dry", "--set", "board.slide=0.03",
                     "--out", str(tmp_path / "g")])
    err = capsys.readouterr().err
    assert code == 2 and "error: --set board.slide moves the sheet while the robot draws, which only a back end with " \
                          "eyes, a paper and a streaming arm can show; back end 'dry' has no eyes" in err


ONE_CIRCLE = """world tictactoe
import circle
task mark(c) {
    run circle.reach(c.*, hand = arm.lift, start = none)
    run circle.draw(c.*, hand = none)TRACK
}
main { mark(board.cell4) }
"""


@pytest.mark.slow
def test_a_circle_drawn_while_the_sheet_slides_and_turns(tmp_path):
    """The issue's scene on the iCub: the sheet slides 3 cm and turns 10 degrees while the pen is
    down; tracked, the circle lands in its cell on the sheet where it ends up; untracked (the same
    seed, the same moves), it strays out of it."""
    import json

    marks = {}
    for name, track in (("tracked", " track c every 100 ms blend 5 mm lift above 8 mm"), ("untracked", "")):
        program = tmp_path / f"{name}.hila"
        program.write_text(ONE_CIRCLE.replace("TRACK", track))
        out = tmp_path / name
        assert cli.main(["exec", str(program), "--seed", "3", "--set", "board.slide=0.03", "--set", "board.turn=10",
                         "--out", str(out), "--quiet"]) == 0
        report = json.loads((out / "report.json").read_text())
        move = report["perturbations"]["sheet_moves"][0]
        assert move["slide_mm"] == pytest.approx(30.0) and abs(move["turn_deg"]) == pytest.approx(10.0)
        (marks[name],) = report["marks"]
    tracked, untracked = marks["tracked"], marks["untracked"]
    assert tracked["cell"] == 4 and tracked["outside_cell_mm"] == 0.0 and tracked["r"] > 0.99
    assert len(tracked["replans"]) >= 4 and not any(r["lifted"] for r in tracked["replans"])
    assert untracked["replans"] == [] and untracked["outside_cell_mm"] > 3.0 and untracked["r"] < tracked["r"] - 0.02


class _GlanceEyes:
    """Eyes for a glance that hand back ink points instead of images (the tracker's ``ink`` is
    bypassed): ``fovea`` what a region's image shows, ``whole`` what a whole image shows."""

    def __init__(self, fovea, whole):
        self.fovea, self.whole, self.calls = fovea, whole, []

    def camera_image(self, eye="left", *, region=None):
        self.calls.append((eye, None if region is None else np.array(region)))
        return self.whole if region is None else self.fovea


def test_a_glance_reads_its_fovea_first_and_the_whole_images_only_when_the_grid_is_not_there():
    from dataclasses import replace

    from hila_lang.worlds.tictactoe.tracking import FOVEA_MARGIN

    rng = np.random.default_rng(3)
    known = Grid.game()
    tracker = SheetTracker({c: cell_corners(known, c) for c in range(1, 10)}, known.surface_z)
    fovea = tracker.fovea()
    # the fovea: the grid's square where the robot knows it, grown by the margin, on the table
    half = 1.5 * tracker.spacing + FOVEA_MARGIN
    assert fovea.shape == (4, 3) and np.allclose(fovea[:, 2], known.surface_z)
    assert np.allclose(np.abs(tracker._local(fovea[:, :2])), half)
    tracker.ink = lambda image, square=None: image
    grid_ink = _ink_of(known, rng)
    still = _GlanceEyes(fovea=grid_ink, whole=None)
    assert tracker.glance(still) is not None
    assert [(e, r is not None) for e, r in still.calls] == [("left", True)]  # one fovea, nothing more
    assert np.allclose(still.calls[0][1], fovea) and tracker.glances[-1]["whole_image"] is False
    # the sheet jumped out of the fovea: neither eye finds it there, the whole image does
    jumped = replace(known, grid_center=tuple(np.add(known.grid_center, (0.002, -0.001))))
    away = _GlanceEyes(fovea=rng.uniform(-1, 1, (300, 2)), whole=_ink_of(jumped, rng))
    assert tracker.glance(away) is not None
    assert [(e, r is not None) for e, r in away.calls] == [("left", True), ("right", True), ("left", False)]
    assert tracker.glances[-1]["whole_image"] is True and tracker.glances[-1]["seen"]
    assert np.linalg.norm(tracker.centre[:2] - np.asarray(jumped.grid_center)) < 1e-3


def test_the_distance_to_the_grid_lines_is_the_obvious_one():
    """:meth:`SheetTracker.distances` against the plain loop over the four lines (each a segment
    1.5 spacings either side of the centre, half a spacing off it), seeded points near and far."""
    known = Grid.game()
    tracker = SheetTracker({c: cell_corners(known, c) for c in range(1, 10)}, known.surface_z)
    s = tracker.spacing
    rng = np.random.default_rng(5)
    m = np.vstack([rng.uniform(-2.5 * s, 2.5 * s, (2000, 2)), [[0.0, 0.0], [s / 2, 0.0], [s / 2, s / 2]]])
    d, kind = tracker.distances(m)
    for p, dp, kp in zip(m, d, kind):
        best, best_kind = np.inf, 0
        for axis in (0, 1):
            for c in (-s / 2, s / 2):
                beyond = max(abs(p[1 - axis]) - 1.5 * s, 0.0)
                dist = math.hypot(p[axis] - c, beyond)
                if dist < best:
                    best, best_kind = dist, axis
        assert dp == pytest.approx(best, abs=1e-15) and kp == best_kind


def test_the_fit_step_is_the_weighted_least_squares_step():
    """:meth:`SheetTracker._refine` (normal equations) against the obvious weighted least squares
    (``lstsq`` of the point-to-line Jacobian, written out row by row), on seeded ink with the grid
    moved; and on pixels near lines of one direction only, where the normal equations are
    singular, the minimum-norm step (no move across the unseen direction)."""
    known = Grid.game()
    tracker = SheetTracker({c: cell_corners(known, c) for c in range(1, 10)}, known.surface_z)
    rng = np.random.default_rng(3)
    from dataclasses import replace

    now = replace(known, grid_center=tuple(np.add(known.grid_center, (0.002, -0.001))),
                  grid_rotation=known.grid_rotation + math.radians(0.7))
    m = tracker._local(_ink_of(now, rng))
    s = tracker.spacing
    for phi, tau in ((0.0, np.zeros(2)), (0.004, np.array([0.001, -0.0015]))):
        got_phi, got_tau = tracker._refine(m, phi, tau, GATE)
        c, sn = math.cos(phi), math.sin(phi)
        rows, rhs = [], []
        for u, v in m:
            p = np.array([c * u - sn * v + tau[0], sn * u + c * v + tau[1]])
            d, kind = tracker.distances(p[None])
            if d[0] >= GATE:
                continue
            axis = int(kind[0])
            r = p[axis] - math.copysign(s / 2, p[axis]) if p[axis] != 0 else p[axis] + s / 2
            q = p - tau
            w = 1.0 / (1.0 + (r / (0.5 * GATE)) ** 2)
            rows.append(w * np.array([-q[1] if axis == 0 else q[0], axis == 0, axis == 1], dtype=float))
            rhs.append(-r * w)
        want = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
        assert got_phi - phi == pytest.approx(want[0], abs=1e-12)
        np.testing.assert_allclose(got_tau - tau, want[1:], atol=1e-12)
    one = np.column_stack([np.full(50, s / 2 + 0.0001), np.linspace(-s, s, 50)])  # lines along far only
    got_phi, got_tau = tracker._refine(one, 0.0, np.zeros(2), GATE)
    assert got_tau[0] == pytest.approx(-0.0001, abs=1e-12) and got_tau[1] == 0.0 and abs(got_phi) < 1e-12


@pytest.mark.parametrize("shift, turn", [((0.002, -0.001), 0.7), ((0.0, 0.0), 0.0), ((0.004, 0.003), -1.5)])
def test_the_fit_stops_once_a_round_moves_the_grid_less_than_its_step(shift, turn):
    """The Gauss-Newton rounds stop when one moves no grid point by ``REFINE_STEP``: the fit is
    then within that of where 60 rounds go (its steps shrink tenfold a round here), in fewer
    rounds than the cap; a looser stop fails it (the first case is still 34 um off after two
    rounds).  The last case is found by the search first (the grid moved beyond the first fit's
    reach)."""
    from dataclasses import replace

    from hila_lang.worlds.tictactoe.tracking import REFINE_ROUNDS, REFINE_STEP, SEARCH

    known = Grid.game()
    now = replace(known, grid_center=tuple(np.add(known.grid_center, shift)),
                  grid_rotation=known.grid_rotation + math.radians(turn))
    tracker = SheetTracker({c: cell_corners(known, c) for c in range(1, 10)}, known.surface_z)
    xy = _ink_of(now, np.random.default_rng(3))
    refine, rounds = tracker._refine, []
    tracker._refine = lambda *args: rounds.append(1) or refine(*args)
    found = tracker.register(xy)
    assert found is not None and 2 < len(rounds) < REFINE_ROUNDS
    m = tracker._local(xy)
    m = m[tracker.distances(m)[0] < SEARCH + tracker.spacing]
    phi, tau = (0.0, np.zeros(2)) if turn != -1.5 else tracker._search(m)
    for _ in range(60):
        phi, tau = refine(m, phi, tau, GATE)
    reach = 1.5 * math.sqrt(2.0) * tracker.spacing  # a grid corner's distance from the centre
    assert abs(found[0] - phi) * reach + np.linalg.norm(found[1] - tau) < REFINE_STEP


class _TwoEyes(_GlanceEyes):
    """Eyes whose fovea images differ: ``fovea`` maps an eye to what its region's image shows."""

    def camera_image(self, eye="left", *, region=None):
        self.calls.append((eye, None if region is None else np.array(region)))
        return self.whole if region is None else self.fovea[eye]


@pytest.mark.parametrize("jump", [0.0, 0.012])
def test_a_glance_searches_for_the_grid_only_when_no_eye_sees_it_where_it_was(jump):
    """One eye sees the grid in place (too few lines for a sure fit), the other only the lines of
    one direction (the arm hides the rest): that eye's view alone would send it searching for a
    jump, but the first eye says the grid did not jump -- no search, the first eye's fit.  When
    the grid did jump beyond the fit's reach, no eye sees it in place and the search finds it."""
    from dataclasses import replace

    from hila_lang.worlds.tictactoe.tracking import GOOD_INLIERS, MIN_INLIERS

    rng = np.random.default_rng(5)
    known = Grid.game()
    now = replace(known, grid_center=tuple(np.add(known.grid_center, (jump, -jump / 2))))
    tracker = SheetTracker({c: cell_corners(known, c) for c in range(1, 10)}, known.surface_z)
    tracker.ink = lambda image, square=None: image
    searched = []
    search = tracker._search
    tracker._search = lambda m: searched.append(len(m)) or search(m)
    sparse = _ink_of(now, rng, n_per_line=70)  # the whole grid, thinly
    dense = _ink_of(now, rng)
    d, kind = tracker.distances(tracker._local(dense))
    one_way = dense[(d < GATE) & (kind == 0)]  # one direction's lines only
    for eye, pts in (("left", sparse), ("right", one_way)):
        count, weak = tracker._inliers(tracker._local(pts), 0.0, np.zeros(2))
        if jump == 0.0:  # the premise: a sure fit for neither, and the right eye's alone would search
            assert (MIN_INLIERS <= count < GOOD_INLIERS) if eye == "left" else (count >= MIN_INLIERS and weak == 0)
    eyes = _TwoEyes(fovea={"left": sparse, "right": one_way}, whole=None)
    assert tracker.glance(eyes) is not None
    note = tracker.glances[-1]
    assert note["seen"] and note["eye"] == "left" and not note["whole_image"]
    assert [e for e, _ in eyes.calls] == ["left", "right"]  # each eye's image once, searched or not
    assert bool(searched) == (jump > 0)
    assert np.linalg.norm(tracker.centre[:2] - np.asarray(now.grid_center)) < 1e-3
