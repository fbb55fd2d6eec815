"""``track``: a run whose ICPs stay live while it runs (issue 34) -- the clause, the checker's
refusals, the FSM, the engine's re-warp on the dry back end with a scripted moving world, the
trace, the recording and ``--verify`` of a run with re-plans."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import CheckError
from hila_lang.engine.interpreter import Interpreter
from hila_lang.engine.tracking import Prediction, blend_in, motion, nearest_stamp, tracked_icps
from hila_lang.language import load_program
from hila_lang.language.ast import dump
from hila_lang.language.fsm import FSM
from hila_lang.language.transformer import parse_program
from hila_lang.lsp.analysis import Document
from hila_lang.plugins import registry
from hila_lang.robot.dry import DryBackend
from hila_lang.worlds.scripted.world import ScriptedWorld

ROOT = Path(__file__).resolve().parent.parent
CELL = {"board.cell5.tl": [0.33, -0.07, 0.58], "board.cell5.tr": [0.33, -0.11, 0.58],
        "board.cell5.br": [0.29, -0.11, 0.58], "board.cell5.bl": [0.29, -0.07, 0.58]}
HOME = [0.25, -0.20, 0.80]
PROGRAM = """world scripted
import circle
main {{
    run circle.reach(board.cell5.*, hand = hand)
    run circle.draw(board.cell5.*, hand = none){track}
}}
"""
TRACK = " track board.cell5 every 100 ms blend 5 mm"


def program(tmp_path, track: str = TRACK, name: str = "p.hila") -> Path:
    path = tmp_path / name
    path.write_text(PROGRAM.format(track=track), encoding="utf-8")
    return path


def run(tmp_path, track: str = TRACK, motion_script=None):
    checked, fsm = load_program(program(tmp_path, track))
    world = ScriptedWorld(CELL, home=HOME, motion=motion_script)
    backend = DryBackend(HOME)
    interp = Interpreter(checked, fsm, world, backend)
    return interp.run(), world, backend


SLIDE = [{"points": "board.cell5", "state": "main/draw", "at": 0.5, "seconds": 1.0, "shift": [0.01, 0.005, 0.0],
          "turn": 10}]


# --------------------------------------------------------------------------- the clause


def test_the_clause_parses_in_any_order_and_names_do_not_become_keywords():
    text = ("world tictactoe\nimport circle\ntask mark(c) {\n run circle.reach(c.*, hand = arm.lift, start = none)\n"
            " run circle.draw(c.*, hand = none) track c lift above 6 mm every 50 ms blend 2.5 mm threshold 1.5 mm\n}\n"
            "main { let lift = 3\n let every = 2\n mark(board.cell5) }\n")
    tree = dump(parse_program(text, "t.hila").items)
    assert "TrackOption @5:44  kind='lift' value=6" in tree and "kind='every' value=50" in tree
    assert "kind='blend' value=2.5" in tree and "kind='threshold' value=1.5" in tree
    _, fsm = load_program(ROOT / "programs" / "x.hila", text)
    draw = fsm.states["main/mark/draw"]
    assert (draw.track.every, draw.track.threshold, draw.track.blend, draw.track.lift) == (0.05, 0.0015, 0.0025, 0.006)
    assert draw.describe().endswith("track {main/mark:c} every 50 ms threshold 1.5 mm blend 2.5 mm lift above 6 mm")
    assert FSM.from_dict(json.loads(fsm.to_json())) == fsm  # round-trips
    # defaults: every 100 ms, threshold 1 mm, blend 5 mm, never lift
    _, fsm = load_program(ROOT / "programs" / "x.hila", text.replace(
        "lift above 6 mm every 50 ms blend 2.5 mm threshold 1.5 mm", ""))
    t = fsm.states["main/mark/draw"].track
    assert (t.every, t.threshold, t.blend, t.lift) == (0.1, 0.001, 0.005, None)


@pytest.mark.parametrize("clause, message", [
    ("track board.cell9", "'track board.cell9': no ICP of 'circle.draw' is bound through 'board.cell9'"),
    ("track board.cell5 every 100 ms every 50 ms", "'every' is given twice in one 'track'"),
    ("track board.cell5 every 2 ms", "'every 2 ms': expected at least 5 ms and at most 10000 ms"),
    ("track board.cell5 threshold 0 mm", "'threshold 0 mm': expected more than 0 mm and at most 1000 mm"),
    ("track board.cell5 threshold 2 mm lift above 1 mm",
     "'lift above 1 mm' is below the threshold of 2 mm: a move that small is not followed at all, so the pen would "
     "never lift for it"),
])
def test_a_bad_clause_is_a_located_check_error(tmp_path, clause, message):
    with pytest.raises(CheckError) as info:
        load_program(program(tmp_path, " " + clause))
    assert info.value.message == message and info.value.line == 5 and info.value.column >= 48


def test_check_refuses_track_in_a_world_that_cannot_show_its_points_while_the_robot_moves(tmp_path, capsys):
    text = ('world letters\nimport circle\nmain {\n run circle.draw(tl = (0.33, -0.07, 0.58), tr = (0.33, -0.11, 0.58), '
            'br = (0.29, -0.11, 0.58), bl = (0.29, -0.07, 0.58), hand = none) track tl\n}\n')
    path = tmp_path / "l.hila"
    path.write_text(text)
    code = cli.main(["check", str(path), "--backend", "dry"])
    err = capsys.readouterr().err.replace(str(path), "l.hila")
    lines = err.splitlines()
    assert code == 2 and lines[0] == (
        "l.hila:4:135: error: 'track' needs a world that shows the robot its points again while a step runs; world "
        "'letters' cannot: it tells its points only between steps")
    assert lines[1].endswith("hand = none) track tl") and lines[2].endswith("^") and len(lines) == 4
    assert lines[1][len(lines[2]) - 1:].startswith("track tl")  # the caret under 'track'
    assert lines[3] == "hint: remove the 'track' clause, or run in a world that can (picture, scripted, tictactoe)"


def test_check_refuses_track_on_a_back_end_that_cannot_stream(tmp_path, monkeypatch):
    real = registry.backend

    def backend(name):  # a back end that takes a whole path at a time
        from dataclasses import replace

        return replace(real("dry"), name="blocking", streaming=False) if name == "blocking" else real(name)

    monkeypatch.setattr(registry, "backend", backend)
    with pytest.raises(CheckError) as info:
        load_program(program(tmp_path), backend="blocking")
    assert info.value.message == ("'track' needs a back end that can change the path it follows while the arm moves; "
                                  "back end 'blocking' cannot: it takes a whole path and runs it to the end")
    assert (info.value.line, info.value.column) == (5, 49)
    assert info.value.hint == "run it with --backend dry or pybullet, or remove the 'track' clause"
    load_program(program(tmp_path), backend="dry")  # the dry back end streams


def test_the_language_server_explains_the_clause(tmp_path):
    path = program(tmp_path, " track board.cell5 every 100 ms lift above 5 mm")
    doc = Document(str(path))
    text = path.read_text()
    doc.analyse(text)
    line = text.splitlines()[4]
    hover = doc.hover(4, line.index("track") + 1)
    assert hover.text.startswith("**track board.cell5 every 100 ms lift above 5 mm**: keeps the ICPs bound through")
    hover = doc.hover(4, line.index("lift above") + 2)
    assert hover.text.startswith("**lift above 5 mm**: when the scene under a pen that is down moved more than this")
    assert {"track", "every", "blend", "lift", "threshold"} <= {c.label for c in doc.completion(4, 0)}


# --------------------------------------------------------------------------- the engine


def test_a_tracked_step_with_still_points_is_the_untracked_step(tmp_path):
    tracked, _, moves = run(tmp_path)
    plain, _, plain_moves = run(tmp_path, "")
    draw, draw0 = tracked[1], plain[1]
    assert draw.replans == [] and draw.text.endswith("; tracked board.cell5: 0 re-plan(s)")
    assert np.array_equal(draw.path, draw0.path) and np.array_equal(draw.executed, draw0.executed)
    assert np.array_equal(draw.executed, draw.path)  # the dry hand follows it exactly, streamed or not
    assert draw.text.split("; tracked")[0] == draw0.text
    assert [m[1].tolist() for m in moves.moves] == [m[1].tolist() for m in plain_moves.moves]


def test_a_moving_cell_is_warped_again_from_where_the_pen_is(tmp_path):
    entries, world, _ = run(tmp_path, motion_script=SLIDE)
    draw = entries[1]
    assert len(draw.replans) >= 4
    lines = draw.text.splitlines()
    assert lines[0].endswith(f"; tracked board.cell5: {len(draw.replans)} re-plan(s)")
    assert lines[1].startswith("      re-plan at 0.") and "moved" in lines[1] and "blended over 5 mm" in lines[1]
    times = [r.t for r in draw.replans]
    assert times == sorted(times) and all(abs(t * 10 - round(t * 10)) < 1e-9 for t in times)  # at the ticks
    # the last plan is the step warped onto the cell where it ended up (within the threshold, 1 mm:
    # the last bit of the move was too small to follow): its end is the moved end
    still = run(tmp_path, "")[0][1].path
    moved = motion(np.array(list(CELL.values())), np.array(list(world.points().values())))
    assert np.linalg.norm(draw.path[-1] - moved(still[-1])) < 1e-3
    assert np.linalg.norm(draw.executed[-1] - moved(still[-1])) < 1e-3
    assert np.linalg.norm(still[-1] - moved(still[-1])) > 0.01  # where the untracked circle ends
    # untracked, the same motion leaves the circle where the cell was
    plain = run(tmp_path, "", motion_script=SLIDE)[0][1]
    assert plain.replans == [] and np.array_equal(plain.path, still)
    # each new tail starts at the pen's measured position and the path has no jump
    for r in draw.replans:
        assert np.linalg.norm(np.diff(r.tail, axis=0), axis=1).max() < 0.006


def test_a_jump_under_a_pen_that_is_down_lifts_it_and_puts_it_down_where_the_ink_stopped(tmp_path):
    jump = [{"points": "board.cell5", "state": "main/draw", "at": 0.8, "shift": [0.012, 0.0, 0.0]}]
    entries, world, _ = run(tmp_path, TRACK + " lift above 5 mm", jump)
    draw = entries[1]
    lifted = [r for r in draw.replans if r.lifted]
    assert len(lifted) == 1 and lifted[0].moved > 0.011
    assert "the pen lifted, carried and put down where its ink stopped" in draw.text
    tail = lifted[0].tail
    assert tail[0][2] == pytest.approx(0.59, abs=1e-4) and tail[1][2] == pytest.approx(0.59, abs=1e-4)  # up, over
    down = tail[2]  # put down 12 mm from where the pen was at the look before, with the cell
    assert down[2] == pytest.approx(0.58, abs=1e-4) and abs(down[0] - (tail[0][0] + 0.012)) < 0.006
    # without 'lift above' the pen is dragged across instead
    dragged = run(tmp_path, TRACK, jump)[0][1]
    assert not any(r.lifted for r in dragged.replans)


def test_tracked_icps_are_those_bound_through_the_tracked_names(tmp_path):
    checked, fsm = load_program(program(tmp_path))
    st = fsm.states["main/draw"]
    assert tracked_icps(st, checked.templates["circle"].sub("draw")) == ["tl", "tr", "br", "bl"]


def test_blend_and_the_resume_point_are_what_they_say():
    path = np.column_stack([np.linspace(0.0, 0.03, 7), np.zeros(7), np.zeros(7)])
    points, stamps = blend_in(np.array([0.0, 0.002, 0.0]), path, np.arange(7.0) + 3, 0.005)
    assert np.allclose(points[0], [0.0, 0.002, 0.0]) and np.allclose(points[-1], path[-1])
    assert np.all(np.diff(stamps) > 0) and stamps[0] == 3 and stamps[-1] == 9
    beyond = points[:, 0] >= 0.005 - 1e-12
    assert np.allclose(points[beyond, 1], 0.0) and np.all(points[~beyond, 1] > 0)  # let go within 5 mm
    assert np.diff(points[~beyond, 0]).max() <= 0.0005 + 1e-9  # sampled every 0.5 mm of the path
    # a closed circle passes its start again at its end: the pen near its start resumes at its start
    t = np.linspace(0, 2 * np.pi, 33)
    circle = np.column_stack([np.cos(t), np.sin(t), 0 * t]) * 0.02
    assert nearest_stamp(circle, circle[1] + [0.0005, 0, 0], 1.0, 0.01) < 3
    assert nearest_stamp(circle, circle[31] + [0.0005, 0, 0], 31.0, 0.01) > 29


# --------------------------------------------------------------------------- recorded, replayed, verified


def test_a_run_with_replans_is_recorded_replayed_and_verified(tmp_path, capsys):
    script = tmp_path / "slide.yaml"
    script.write_text(json.dumps({"home": HOME, "points": CELL, "motion": SLIDE}))
    prog = program(tmp_path)
    rec = tmp_path / "run.hilarec"
    assert cli.main(["exec", str(prog), "--backend", "dry", "--set", f"script={script}", "--record", str(rec)]) == 0
    out = capsys.readouterr().out
    assert "re-plan at 0.800 s" in out
    with zipfile.ZipFile(rec) as z:
        record = json.loads(z.read("record.json"))
    draw = record["steps"][1]
    assert len(draw["replans"]) >= 4 and set(draw["replans"][0]) >= {"t", "stamp", "moved", "blend", "lifted", "tail"}
    assert "replans" not in record["steps"][0] or record["steps"][0]["replans"] == []  # the reach: streamed, no look
    assert cli.main(["replay", "--verify", str(rec)]) == 0
    assert "no difference: 3 steps verified" in capsys.readouterr().out
    # a recording whose re-plan differs is caught, at that re-plan
    bad = tmp_path / "bad.hilarec"
    record["steps"][1]["replans"][1]["tail"][3][0] += 0.001
    with zipfile.ZipFile(bad, "w") as z:
        z.writestr("record.json", json.dumps(record))
    assert cli.main(["replay", "--verify", str(bad)]) == 1
    assert "re-plan 2's new tail differs by up to 1 mm (point 3" in capsys.readouterr().out


# --------------------------------------------------------------------------- the prediction

SQUARE = np.array([[0.33, -0.07, 0.58], [0.33, -0.11, 0.58], [0.29, -0.11, 0.58], [0.29, -0.07, 0.58]])


def _looks(motion_at, latency, every, n, noise, seed):
    """Feed a Prediction ``n`` looks (clock ``k * every``) of the square where ``motion_at(time)``
    (a shift (3,)) puts it ``latency`` before, with a seeded common error of ``noise`` per axis;
    yields (clock, what it returned, its state, the look)."""
    rng = np.random.default_rng(seed)
    pred = Prediction(SQUARE, latency, every)
    for k in range(1, n + 1):
        t = k * every
        seen = SQUARE + motion_at(t - latency) + np.r_[rng.normal(0.0, noise, 2), 0.0]
        placed, state = pred.add(t, np.ones(4, bool), seen)
        yield t, placed, state, seen


def test_a_steadily_moving_sheet_is_predicted_where_it_is_while_the_plan_is_drawn():
    # 2 cm/s, seen 100 ms late with 1 mm of noise, looked at every 100 ms: the plan made from a look
    # is drawn during the next 100 ms, when the sheet is on average 150 ms further on than seen
    velocity = np.array([0.02, -0.01, 0.0])
    pred_err, raw_err, states = [], [], []
    for seed in range(5):
        for t, placed, state, seen in _looks(lambda s: velocity * s, 0.1, 0.1, 30, 0.001, seed):
            truth = SQUARE + velocity * (t + 0.05)
            if t > 1.0:
                pred_err.append(np.linalg.norm(placed - truth, axis=1).mean())
                raw_err.append(np.linalg.norm(seen - truth, axis=1).mean())
                states.append(state)
    assert np.mean(raw_err) > 3.0e-3  # 22 mm/s * 150 ms behind
    # what is left is the last look's noise and its velocity's over 150 ms (about 1.3 and 0.9 mm)
    assert np.mean(pred_err) < 0.6 * np.mean(raw_err) and np.mean(pred_err) < 2.2e-3
    assert states.count("moving") > 0.9 * len(states)


def test_still_points_are_averaged_not_moved_and_never_predicted_to_move():
    for _, placed, state, _ in _looks(lambda s: np.zeros(3), 0.1, 0.1, 30, 0.0, 0):
        assert np.abs(placed - SQUARE).max() < 1e-12 and state != "moving"
    est, raw = [], []
    for seed in range(10):
        for t, placed, state, seen in _looks(lambda s: np.zeros(3), 0.1, 0.1, 30, 0.001, seed):
            if t > 1.0:
                est.append(np.linalg.norm(placed - SQUARE, axis=1).mean())
                raw.append(np.linalg.norm(seen - SQUARE, axis=1).mean())
    assert np.median(est) < 0.6 * np.median(raw)  # the noise averaged out, not followed


def test_a_knock_is_taken_as_seen_and_the_looks_before_it_forgotten():
    jump = np.array([0.01, 0.0, 0.0])
    looks = list(_looks(lambda s: jump if s >= 1.45 else np.zeros(3), 0.1, 0.1, 25, 0.001, 1))
    first = next(i for i, (t, *_) in enumerate(looks) if t - 0.1 >= 1.45)
    t, placed, state, seen = looks[first]
    assert state == "knock" and np.allclose(placed, seen, rtol=0, atol=1e-12)  # as seen (through the similarity)
    for t, placed, state, seen in looks[first + 1:]:
        assert np.linalg.norm(placed - (SQUARE + jump), axis=1).max() < 3e-3  # where it is now, not averaged with before


def test_a_predicted_replan_lands_closer_to_the_moving_cell_than_an_unpredicted_one(tmp_path, monkeypatch):
    from hila_lang.engine import tracking
    from hila_lang.worlds.scripted.motion import Move

    move = Move.of(SLIDE[0], 0)

    def truth(t):
        pts = {k: np.asarray(v, dtype=float) for k, v in CELL.items()}
        move.apply(pts, list(pts), move.done(t))
        return pts

    def error(entries):
        # each re-plan's points against where the cell is half a look later (while its plan is drawn)
        return np.mean([np.mean([np.linalg.norm(p - truth(r.t + 0.05)["board.cell5." + k]) for k, p in r.points.items()])
                        for r in entries[1].replans])

    predicted = run(tmp_path, motion_script=SLIDE)[0]
    monkeypatch.setattr(tracking, "PREDICT_WINDOW", 0.0)
    plain = run(tmp_path, motion_script=SLIDE)[0]
    assert len(predicted[1].replans) >= 4 and len(plain[1].replans) >= 4
    carried = [r for r in predicted[1].replans if r.ahead > 0]
    assert carried and all(r.ahead == pytest.approx(0.05) for r in carried)  # no latency: half a look
    assert "the moving points carried 50 ms ahead" in predicted[1].text
    assert not any(r.ahead for r in plain[1].replans)
    assert error(predicted) < 0.75 * error(plain)  # 0.56 against 0.84 mm
