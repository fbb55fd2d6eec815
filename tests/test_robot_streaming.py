"""The back ends' ``streaming`` capability (issue 34): begin a path, advance the clock, replace the
tail from a waypoint not yet passed, finish -- on the dry back end and on the PyBullet arm."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.core.errors import InputError, UnreachableError
from hila_lang.plugins.protocols import Streaming, conformance
from hila_lang.robot.dry import DryBackend
from hila_lang.robot.streaming import profile_from

START = np.array([0.30, -0.10, 0.62])


def line(n=11, length=0.05, start=START):
    return start + np.column_stack([np.linspace(0, length, n), np.zeros(n), np.zeros(n)])


# --------------------------------------------------------------------------- dry


def test_the_dry_stream_is_the_dry_move_when_nothing_is_replaced():
    path = line()
    a, b = DryBackend(START), DryBackend(START)
    moved = a.move(path, pen_down=True)
    s = b.streaming
    assert conformance(s, Streaming) == [] and isinstance(s, Streaming)
    seconds = s.begin(path, pen_down=True)
    assert seconds == pytest.approx(0.05 / 0.05, abs=s.dt)  # 5 cm at 5 cm/s
    ticks = []
    progress = s.advance(0.5, ticks.append)
    assert progress.t == pytest.approx(0.5) and len(ticks) == 120 and not progress.done
    assert progress.index == 6  # 2.5 cm of 5: waypoints 0-5 passed
    assert np.allclose(b.hand_position(), START + [0.025, 0, 0])
    executed = s.finish(ticks.append)
    assert np.array_equal(executed, moved) and np.array_equal(executed, path)
    assert ticks[-1] == pytest.approx(seconds) and [m[0] for m in b.moves] == [m[0] for m in a.moves]


def test_the_dry_stream_replaces_its_tail_from_where_the_hand_is():
    b = DryBackend(START)
    s = b.streaming
    s.begin(line(), pen_down=True)
    p = s.advance(0.21)  # 10.5 mm: between waypoints 2 and 3
    assert p.index == 3
    here = b.hand_position()
    tail = np.array([here, here + [0.0, 0.01, 0.0], here + [0.01, 0.01, 0.0]])
    with pytest.raises(InputError, match="not yet passed"):
        s.replace(2, tail)
    s.replace(p.index, tail)
    executed = s.finish()
    assert np.allclose(executed[:3], line()[:3]) and np.allclose(executed[3], here)
    assert np.allclose(executed[-2:], tail[1:]) and len(executed) == 6  # the tail starts where the hand was: once


def test_the_dry_stream_checks_paths_as_the_dry_move_does():
    b = DryBackend(START, surface_z=0.62)
    with pytest.raises(UnreachableError):
        b.streaming.begin(line() - [0, 0, 0.01])  # into the table
    b.streaming.begin(line())
    with pytest.raises(UnreachableError):
        b.streaming.replace(1, line() + [1.0, 0, 0])  # out of the arm's reach
    assert len(b.streaming.stop()) >= 0 and b.streaming._run is None


def test_the_speed_profile_from_a_moving_start_brakes_to_the_end():
    prof = profile_from(0.01, 0.05, 0.03, 0.05, 0.5, 1 / 240)
    s = np.array([p[0] for p in prof])
    v = np.array([p[1] for p in prof])
    assert s[-1] == pytest.approx(0.04) and np.all(np.diff(s) > 0) and v.max() <= 0.05 + 1e-12
    # it brakes along v = sqrt(2 a d), d the distance left: at most the acceleration, but for the
    # discretisation of the last steps (1.3 times it)
    assert v[-1] < 0.01 and np.all(np.abs(np.diff(v)) <= 1.3 * 0.5 / 240)


# --------------------------------------------------------------------------- PyBullet


@pytest.fixture(scope="module")
def pybullet_pair():
    from hila_lang.robot.backend import PyBulletBackend

    a, b = PyBulletBackend(), PyBulletBackend()
    yield a, b
    a.close()
    b.close()


def _circle(hand, dz=-0.1):
    """A 4 cm circle through ``hand``'s x, y, ``dz`` below it (the ready pen is 0.10 m above the paper)."""
    t = np.linspace(0, 2 * np.pi, 40)
    return hand + np.column_stack([0.02 * np.cos(t) - 0.02, 0.02 * np.sin(t), dz + 0 * t])


def test_a_pybullet_stream_never_replaced_executes_exactly_the_move(pybullet_pair):
    a, b = pybullet_pair
    circle = _circle(a.hand_position())
    assert np.array_equal(a.hand_position(), b.hand_position())
    a.move(circle[:1])
    b.move(circle[:1])
    moved = a.move(circle, pen_down=True)
    s = b.streaming
    assert conformance(s, Streaming) == []
    s.begin(circle, pen_down=True)
    while not s.advance(0.1).done:
        pass
    streamed = s.finish()
    assert np.array_equal(streamed, moved)  # the same IK, the same profile, the same control steps
    assert b.traces[-1].inked == a.traces[-1].inked


def test_a_pybullet_stream_follows_a_replaced_tail_within_a_millimetre(pybullet_pair):
    _, b = pybullet_pair
    circle = _circle(b.hand_position(), 0.0)  # the pen is on the paper, where the test before left it
    b.move(circle[:1])
    s = b.streaming
    s.begin(circle, pen_down=True)
    p = s.advance(1.0)
    shifted = circle[p.index:] + [0.004, 0.003, 0.0]
    tail = np.vstack([b.hand_position(), shifted])
    solves = b.stats["ik_solves"]
    s.replace(p.index, tail)
    assert b.stats["ik_solves"] == solves  # the new tail's IK is solved as the arm gets there, not now
    executed = s.finish()
    trace = b.traces[-1]
    assert len(trace.planned) == p.index + len(tail)
    # the arm follows the new tail: its last point, and within 1 mm of its polyline throughout
    assert np.linalg.norm(executed[-1] - shifted[-1]) < 2e-4
    assert np.abs(trace.executed - trace.reference).max() < 1e-3
