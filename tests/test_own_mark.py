"""The robot knows its mark by what it was shown (issue 30 item 1).

A person's mark -- drawn by the seeded pointer model (``hila_lang.worlds.tictactoe.drawing``),
learned as ``hila learn`` learns it -- is what the robot's eyes call its own on the paper; any
other ink is the opponent's; ink it cannot tell is said ("?"), never guessed; a mark too like
the opponent's cross is refused by ``hila check`` before the game.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from hila_lang.cli import main
from hila_lang.osila.segmentation import segment_template
from hila_lang.osila.template import Template, load_template
from hila_lang.worlds.tictactoe import rules as ttt
from hila_lang.worlds.tictactoe.drawing import draw_mark, write_demonstration
from hila_lang.worlds.tictactoe.ownmark import (OTHER_ABOVE, OWN_BELOW, OwnMark, Reference, _Ink, cross_samples,
                                                inked_strokes, render)

ROOT = Path(__file__).resolve().parents[1]


def learned(mark: str, style: str = "careful", seed: int = 0) -> Template:
    """A person's drawing of ``mark``, cut where the pen touched and left the paper."""
    d = draw_mark(mark, style, seed=seed)
    return segment_template(Template(mark, d.path, d.icps, times=d.times), 3, ["reach", "draw", "retract"],
                            method="contact", contact=["draw"], pen=d.pen)


def mark_of(template: Template) -> OwnMark:
    return OwnMark.from_templates({f"{template.name}.draw": template.sub("draw")})


# --------------------------------------------------------------------------- what the robot was shown


def test_the_reference_is_what_the_pen_inked_not_the_pen_up_moves():
    t = learned("A", "quick")  # two strokes, the pen lifted between them
    strokes = inked_strokes(t.sub("draw"))
    d = draw_mark("A", "quick")
    assert len(strokes) == 2
    # every pen-down sample, and the pen-up ones the pen still inks (within 1 mm of the paper)
    draw = t.segment("draw")
    low = (d.path[draw.start:draw.stop, 2] - d.path[:, 2].min()) < 0.001
    assert sum(len(s) for s in strokes) == int(low.sum()) and low[d.pen[draw.start:draw.stop]].all()
    # in the paper's plane seen from above (x, y), metres: the A is about the size drawn
    span = np.ptp(np.vstack(strokes), axis=0)
    assert 0.02 < span.max() < 0.06
    assert inked_strokes(learned("triangle").sub("reach")) == []  # a pen-up part inks nothing


def test_a_two_d_template_inks_its_contact_segments():
    t = learned("tick")
    flat = Template("flat", t.path[:, :2], {k: v[:2] for k, v in t.icps.items()}, segments=t.segments)
    strokes = inked_strokes(flat.sub("draw"))
    assert len(strokes) == 1 and strokes[0].shape == (t.segment("draw").stop - t.segment("draw").start, 2)


@pytest.mark.parametrize("mark", ["triangle", "tick", "square", "star", "A", "scribble", "circle"])
def test_its_own_mark_turned_scaled_and_moved_is_its_own_and_a_cross_is_not(mark):
    """Rendered as the reader sees ink (1 mm pixels, a 3 mm pen), the robot's mark turned by any
    angle, scaled and shifted is close to its reference; the world's crosses are far."""
    own = mark_of(learned(mark, "quick", 1))
    ref = own.references[0]
    rng = np.random.default_rng(3)
    for _ in range(4):
        turn, scale = rng.uniform(0, 2 * np.pi), rng.uniform(0.7, 0.9)
        rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        shift = rng.uniform(-0.1, 0.1, 2)
        moved = [s @ rot.T * scale + shift for s in ref.strokes]
        assert own.classify(render(moved, 0.001, 0.003), 0.001)[0] == "O"
    for cross in cross_samples(6, seed=9):
        assert own.classify(render(cross, 0.001, 0.003), 0.001)[0] == "X"


def test_the_fit_is_as_good_as_a_brute_force_search_over_turns_and_sizes():
    """The distance comes from a coarse turn search refined by ICP; it must not be worse than
    the best of a fine grid of turns (2 degrees) and sizes (2 %) tried one by one."""
    ref = mark_of(learned("triangle", "careful", 2)).references[0]
    turn = np.radians(33.0)
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    ink = _Ink(render([s @ rot.T * 0.8 for s in ref.strokes], 0.001, 0.003), 0.001)
    fitted = ink.distance(ref)
    grid = [(ink.rms * k, np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]), ink.centre)
            for a in np.radians(np.arange(0, 360, 2.0)) for k in np.linspace(0.9, 1.1, 11)]
    brute = min(ink._cost(ink._gaps(ref, [fit])[0]) for fit in grid)
    assert fitted <= brute + 1e-9 and fitted < 0.5 * OWN_BELOW


def test_fits_placed_together_are_placed_as_each_alone():
    """The k-d tree queries of many fits are made at once (:meth:`_Ink._gaps`); each fit's
    distances and nearest points must be those of the fit queried alone."""
    ref = mark_of(learned("triangle", "careful", 2)).references[0]
    ink = _Ink(render(cross_samples(1)[0], 0.001, 0.003), 0.001)
    rng = np.random.default_rng(3)
    fits = [(ink.rms * rng.uniform(0.5, 1.5), np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]),
             ink.centre + rng.normal(0, 3, 2)) for a in rng.uniform(0, 2 * np.pi, 5)]
    together = ink._gaps(ref, fits)
    for fit, gaps in zip(fits, together):
        (alone,) = ink._gaps(ref, [fit])
        for a, b in zip(gaps, alone):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
        assert len(gaps[0]) == len(ref.dense) and len(gaps[1]) == len(ink.points)


def test_a_mark_is_told_by_its_shape_not_by_being_no_cross():
    """A square drawn on the paper is not the robot's when its mark is a triangle, and the
    triangle is not when its mark is a square."""
    triangle, square = mark_of(learned("triangle")), mark_of(learned("square"))
    tri_ink = render(triangle.references[0].strokes, 0.001, 0.003)
    square_ink = render(square.references[0].strokes, 0.001, 0.003)
    assert triangle.classify(tri_ink, 0.001)[0] == "O" and square.classify(square_ink, 0.001)[0] == "O"
    assert triangle.distance(square_ink, 0.001) > OWN_BELOW and square.distance(tri_ink, 0.001) > OWN_BELOW


def test_ink_between_the_thresholds_is_unclear_and_says_how_far_it_is():
    own = mark_of(learned("tick"))
    ref = own.references[0].strokes[0]
    half = [ref[: len(ref) // 2]]  # half of its mark: not its mark, and not surely a cross
    mark, confidence, distance = own.classify(render(half, 0.001, 0.003), 0.001)
    assert distance > OWN_BELOW
    assert (mark, confidence) == ("?", 0.0) if distance <= OTHER_ABOVE else mark == "X"


# --------------------------------------------------------------------------- through the robot's eyes


def robot_draws(backend, template, spec, cell):
    """The iCub draws ``template``'s mark in ``cell`` with its arm, as programs/game.hila does:
    the reach from above the board, then the draw placed by the cell's corners alone."""
    from hila_lang.hierarchy.step import hila_step
    from hila_lang.worlds.tictactoe.board import cell_corners

    corners = {k: v - [0, 0, 0.0005] for k, v in cell_corners(spec, cell).items()}
    lift = spec.grid_to_world(0.0, 0.0) + [0.0, 0.0, 0.10]
    backend.reset_hand(lift)
    backend.move(hila_step(template.sub("reach"), {**corners, "hand": lift}, lift).path)
    draw = hila_step(template.sub("draw"), {**corners, "hand": None, "start": None}, backend.hand_position())
    backend.move(draw.path, pen_down=True)


@pytest.mark.parametrize("mark, style, other", [("triangle", "careful", "square"), ("tick", "quick", "triangle"),
                                                ("square", "small", "tick")])
def test_the_robots_eyes_read_its_own_drawn_marks_as_its_own_and_crosses_as_the_opponents(mark, style, other):
    """On PyBullet's paper the iCub draws its mark in cells 1, 5 and 9; the world inks crosses,
    neat and sloppy, in 3, 6 and 7; with the arm beside the board both eyes read the board with
    the robot's mark from its template: its cells "O", the crosses "X".  Read with another mark
    as its own, the same images show none of its cells as the robot's."""
    pytest.importorskip("pybullet")
    from hila_lang.robot.backend import PyBulletBackend
    from hila_lang.worlds.tictactoe.board import Grid
    from hila_lang.worlds.tictactoe.marks import cross_strokes
    from hila_lang.worlds.tictactoe.reading import read_board

    spec = Grid.game()
    template = learned(mark, style, 1)
    with PyBulletBackend(spec.paper()) as backend:
        for cell in (1, 5, 9):
            robot_draws(backend, template, spec, cell)
        rng = np.random.default_rng(4)
        for k, cell in enumerate((3, 6, 7)):
            for stroke in cross_strokes(spec, cell, rng, sloppy=k == 1):
                backend.ink.ink_polyline(stroke)
        backend.reset_hand(spec.grid_to_world(0.16, -0.10) + [0.0, 0.0, 0.10])  # beside the board
        images = [(backend.eyes.camera_image(eye), backend.eyes.body_outline()) for eye in ("left", "right")]
    expected = ["O", "", "X", "", "O", "X", "X", "", "O"]
    for image, body in images:
        reading = read_board(image, spec.surface_z, body=body, own=mark_of(template))
        assert reading.marks == expected, reading.distance
        assert min(reading.confidence) >= 0.5, reading.confidence
        wrong = read_board(image, spec.surface_z, body=body, own=mark_of(learned(other, style, 1)))
        assert [wrong.marks[c - 1] for c in (1, 5, 9)].count("O") == 0, wrong.distance


# --------------------------------------------------------------------------- refused before the game


def program(folder: Path, template: Path) -> Path:
    """The shipped game with ``template`` as its circle.yaml, in ``folder``."""
    (folder / "circle.yaml").write_bytes(template.read_bytes())
    out = folder / "game.hila"
    out.write_text((ROOT / "programs" / "game.hila").read_text())
    return out


def line_of(program: Path, text: str) -> int:
    """The line of ``program`` that holds ``text`` (the shipped game's lines move as it grows)."""
    return next(i for i, line in enumerate(program.read_text().splitlines(), 1) if text in line)


def learn_drawn(folder: Path, mark: str, style: str = "careful", seed: int = 0) -> Path:
    demo, icps = write_demonstration(folder, mark, draw_mark(mark, style, seed=seed))
    out = folder / f"{mark}.yaml"
    assert main(["learn", str(demo), "--icps", str(icps), "-k", "3", "--tags", "reach,draw,retract",
                 "--contact", "draw", "-o", str(out)]) == 0
    return out


def test_a_mark_like_the_cross_is_refused_by_hila_check_at_the_run_that_draws_it(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    game = program(tmp_path, learn_drawn(tmp_path, "X", "careful"))  # the letter X: a cross
    capsys.readouterr()
    assert main(["check", str(game)]) == 2
    err = capsys.readouterr().err
    at = f"game.hila:{line_of(game, 'run circle.draw(')}:9"
    assert f"{at}: error: the robot's mark (circle.draw) is too like the opponent's cross" in err
    assert "run circle.draw(c.*, hand = none, start = none)" in err and "hint: teach the robot a mark" in err
    assert main(["exec", str(game), "--backend", "dry"]) == 2  # nothing is played
    game = program(tmp_path, learn_drawn(tmp_path, "triangle", "quick"))
    capsys.readouterr()
    assert main(["check", str(game)]) == 0


# --------------------------------------------------------------------------- the world is told, the board says "?"


def test_the_world_is_told_the_programs_mark_before_it_runs(tmp_path, monkeypatch):
    from hila_lang.plugins.options import RunOptions
    from hila_lang.session.runner import finish, prepare

    monkeypatch.chdir(tmp_path)
    game = program(tmp_path, learn_drawn(tmp_path, "star", "careful"))
    out = io.StringIO()
    interp = prepare(game, RunOptions(seed=0, out=tmp_path / "o", stdin=io.StringIO(), stdout=out), "dry")
    try:
        mark = interp.world.player.mark
        assert mark.names == ["circle.draw"]
        np.testing.assert_allclose(np.vstack(mark.references[0].strokes),
                                   np.vstack(inked_strokes(load_template(tmp_path / "star.yaml").sub("draw"))))
        assert "the robot's mark: what circle.draw inks (O on the board)" in out.getvalue()
    finally:
        finish(interp)


def test_a_cell_it_cannot_tell_takes_the_cell_for_neither_side():
    from hila_lang.worlds.tictactoe.player import OPPONENT, ROBOT, Player

    board = ("O", "?", "X", "", "", "", "", "", "")
    assert ttt.winner(("?", "?", "?", "", "", "", "", "", "")) is None  # "?" never completes a line
    assert 2 not in ttt.free_cells(board) and ttt.best_move(board, ttt.CIRCLE) != 2
    player = Player("robot", np.zeros(3))
    player._blind_board = board
    assert player.to_move() == OPPONENT  # three marks, the robot started: the opponent's turn
    player._blind_board = ("O", "?", "X", "X", "", "", "", "", "")
    assert player.to_move() == ROBOT


def test_the_referee_lists_unclear_cells_apart_from_misreads():
    from hila_lang.worlds.tictactoe.board import Grid, cell_corners
    from hila_lang.worlds.tictactoe.referee import Referee

    referee = Referee(Grid.game(), "robot", 0)
    referee.record.board = ("O", "X", "", "", "", "", "", "", "")
    sight = {"look": 1, "board": ("O", "?", "X", "", "", "", "", "", ""), "views": [], "arm": "still",
             "unsure": [2], "surface_z": Grid.game().surface_z, "seconds": 0.0,
             "corners": {c: cell_corners(Grid.game(), c) for c in range(1, 10)}}
    misreads = referee.score_sighting(sight)
    assert misreads == [{"look": 1, "moves_before": 0, "cell": 3, "seen": "X", "true": ""}]
    assert referee.unclear == [{"look": 1, "moves_before": 0, "cell": 2, "true": "X"}]


# --------------------------------------------------------------------------- the shipped game plays any mark (item 2)


def test_the_shipped_game_plays_a_drawn_mark_whose_retract_heads_elsewhere(tmp_path, capsys, monkeypatch):
    """A person's triangle whose retract leaves the way the reach did not come: the game as it was
    (retract with hand = arm.park) ran the final retract 48.6 mm under the paper (exit 1, before
    issue 37's TPS limit); the
    shipped game leaves `hand` out of the retract (as demonstrated, placed by the cell and the
    pen) and plays to the end, and hila check warns about the old binding: it depends on where
    the demonstration's retract went."""
    monkeypatch.chdir(tmp_path)
    game = program(tmp_path, learn_drawn(tmp_path, "triangle", "small", 1))
    capsys.readouterr()
    assert main(["check", str(game)]) == 0
    assert "warning" not in capsys.readouterr().err
    assert main(["exec", str(game), "--backend", "dry", "--seed", "1", "--set", "report=no"]) == 0
    old = tmp_path / "old.hila"
    old.write_text(game.read_text().replace("run circle.retract(last.*, hand = none)",
                                            "run circle.retract(last.*, hand = arm.park)"))
    capsys.readouterr()
    assert main(["check", str(old)]) == 0
    err = capsys.readouterr().err
    assert f"{old}:{line_of(old, 'run circle.retract(')}:32: warning: ICP 'hand' of 'circle.retract' is bound here, but its path never comes near " \
           "'hand' in the template" in err
    # (the old binding's run itself ended 48.6 mm under the paper before issue 37 limited how much
    # the TPS may amplify; with main's OSILA it now ends above it for this seed: the warning stands,
    # as the path still depends on where the demonstration's retract went)
    # the shipped circle's retract comes back near its hand: no warning for it
    assert main(["check", str(ROOT / "programs" / "game.hila")]) == 0
    assert "warning" not in capsys.readouterr().err


def test_a_route_drawn_on_a_photo_draws_in_the_tictactoe_world_instead_of_crashing(tmp_path, capsys):
    """A 2-D template (a route drawn on a picture in the studio: x right, y up, metres) run in the
    tic-tac-toe world: the referee took its path's z (IndexError, exit 3); now its ink is the
    robot's mark like any other, scored against the strokes the template inks."""
    import json

    import yaml

    t = np.linspace(0, 1, 60)
    route = np.column_stack([0.05 + 0.1 * t, 0.05 + 0.02 * np.sin(2 * np.pi * t)])
    (tmp_path / "route.yaml").write_text(yaml.safe_dump({
        "hila_template": 1, "name": "route", "units": "m",
        "icps": {"a": route[0].tolist(), "b": route[-1].tolist()},
        "segments": [{"tag": "draw", "start": 0, "stop": 60, "contact": True}], "path": route.tolist()}))
    prog = tmp_path / "p.hila"
    prog.write_text("world tictactoe\nimport route\nmain {\n    run route.draw(a = board.cell5.tl, b = board.cell5.br)\n}\n")
    assert main(["exec", str(prog), "--backend", "dry", "--out", str(tmp_path / "out")]) == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert [m["cell"] for m in report["marks"]] == [5] and report["marks"][0]["r"] > 0.95


# --------------------------------------------------------------------------- whole games with a person's mark


@pytest.mark.slow  # a whole game through the robot's eyes: 6.7-7.2 s of CPU a case
@pytest.mark.parametrize("mark, style, opponent, seed", [("triangle", "careful", "minimax", 0),
                                                         ("tick", "quick", "random", 1),
                                                         ("square", "shaky", "minimax", 2)])
def test_a_person_s_mark_plays_the_game_through_the_robot_s_eyes(tmp_path, monkeypatch, mark, style, opponent, seed):
    """The docs' recipe: a mark drawn on the tic-tac-toe sheet (reach, mark, retract), learned
    with hila learn, saved as circle.yaml beside the shipped game.hila, played on PyBullet: no
    misread, nothing unclear, every mark inside its cell, the robot's marks read as its own.
    (The issue's 30 games, three marks x two opponents x seeds 0-4:
    ``python bench/vision_game.py --marks triangle,tick,square --only still --opponent both``.)"""
    pytest.importorskip("pybullet")
    import json

    monkeypatch.chdir(tmp_path)
    game = program(tmp_path, learn_drawn(tmp_path, mark, style, seed))
    out = tmp_path / "out"
    assert main(["exec", str(game), "--backend", "pybullet", "--seed", str(seed), "--opponent", opponent,
                 "--out", str(out), "--quiet"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["result"] in ("robot", "draw") and (opponent == "random" or report["result"] == "draw")
    vision = report["vision"]
    assert vision["robot_mark"] == ["circle.draw"]
    assert vision["misreads"] == [] and vision["unclear"] == []
    assert report["marks_outside_cell"] == 0 and report["fouls"] == []
    robot = [m["cell"] for m in report["moves"] if m["player"] == "robot"]
    last = vision["per_look"][-1]["board"]
    assert [last[c - 1] for c in robot] == ["O"] * len(robot)  # its marks, read by its eyes as its own
    assert all(m["r"] > 0.95 for m in report["marks"])


# --------------------------------------------------------------------------- a mark once read


class _Counting:
    """An own mark that counts its comparisons and answers ``answer``."""

    def __init__(self, answer):
        self.answer, self.calls = answer, 0

    def classify(self, mask, resolution, own="O", other="X", place=None):
        self.calls += 1
        return self.answer


def test_a_sure_reading_is_kept_while_the_cell_holds_the_same_ink():
    """The robot's looks read the same mark again and again: in its cell, ink a pixel off and a
    little ragged (what the next look sees) keeps the sure reading; other ink there (a half hidden
    by the arm, a cross), or the same ink read without a place, is compared anew."""
    from hila_lang.worlds.tictactoe.ownmark import SAME_INK, KeptReadings, ink_overlap

    own = mark_of(learned("triangle", "quick", 1))
    ref = own.references[0]
    mark = render([s * 0.8 for s in ref.strokes], 0.001, 0.003)
    again = np.pad(mark, ((1, 0), (0, 2)))  # a pixel down, two right: the next look's crop
    ys, xs = np.nonzero(again)
    again[ys[::15], xs[::15]] = False  # a few pixels lost to noise
    assert ink_overlap(mark, again) >= SAME_INK
    half = mark.copy()
    half[:, mark.shape[1] // 2:] = False
    cross = render(cross_samples(1, seed=4)[0], 0.001, 0.003)
    assert ink_overlap(mark, half) < SAME_INK and ink_overlap(mark, cross) < SAME_INK
    assert ink_overlap(mark, np.zeros_like(mark)) == 0.0

    kept = KeptReadings(own)
    first = kept.classify(mark, 0.001, place=5)
    assert first[0] == "O" and first[1] == 1.0
    assert kept.classify(again, 0.001, place=5) == first and (kept.compared, kept.kept) == (1, 1)
    assert kept.classify(again, 0.001, place=4) == own.classify(again, 0.001)  # another cell: compared
    assert kept.classify(cross, 0.001, place=5)[0] == "X" and kept.compared == 3  # other ink: compared
    assert kept.classify(mark, 0.001, place=5)[0] == "O" and kept.compared == 4
    assert kept.classify(half, 0.001, place=5) == own.classify(half, 0.001) and kept.compared == 5
    assert kept.classify(mark, 0.001) == first and kept.compared == 6  # no place: no memory


def test_an_unsure_reading_is_never_kept():
    from hila_lang.worlds.tictactoe.ownmark import UNCLEAR, KeptReadings

    mask = render([np.array([[0.0, 0.0], [0.02, 0.0], [0.02, 0.02]])], 0.001, 0.003)
    for answer in ((UNCLEAR, 0.0, 0.02), ("O", 0.6, 0.009), ("X", 0.3, 0.033)):
        counting = _Counting(answer)
        kept = KeptReadings(counting)
        for _ in range(3):
            assert kept.classify(mask, 0.001, place=1) == answer
        assert counting.calls == 3 and kept.kept == 0
    sure = _Counting(("X", 1.0, 0.2))
    kept = KeptReadings(sure)
    for _ in range(3):
        kept.classify(mask, 0.001, place=1)
    assert sure.calls == 1 and kept.kept == 2
