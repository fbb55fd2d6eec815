"""Following a path whose tail changes while the arm moves: the back ends' ``streaming`` capability.

:class:`ArmStream` (PyBullet) and :class:`DryStream` (the dry back end) implement
:class:`hila_lang.plugins.protocols.Streaming`: ``begin`` a path, ``advance`` the clock,
``replace`` the tail from a waypoint not yet passed, ``finish`` (or ``stop``).  The engine's
``track`` clause drives them (:mod:`hila_lang.engine.tracking`).

PyBullet.  :meth:`ArmStream.begin` plans the first path as :meth:`~.arm.Arm.move` does (IK for
every 2 mm waypoint before anything moves, so an unreachable first path moves nothing) and runs
it through the same control steps (:meth:`~.arm.Arm.control_step`, 240 Hz) with the same
trapezoidal speed profile: a stream whose tail is never replaced executes exactly what ``move``
executes.  :meth:`ArmStream.replace` keeps what was passed, adds the point the controller aims at
now, and densifies the new tail; its IK is solved lazily, each 2 mm point when the reference
reaches the segment before it (one solve of about 1 ms, warm-started from the point before, within
the 4.2 ms control step), and the speed profile goes on from the current speed over the new
remaining length.  A new point the arm cannot reach stops the stream where it is
(:class:`~hila_lang.core.errors.UnreachableError`).  The pen tip is recorded at every step in the
paper's frame as the paper lies at that step, so a sheet moved during the stroke (a world's
``board.slide``) carries the ink with it; the ink is laid and the texture uploaded once, at the
end.  Everything goes through the arm's chain and IK (``arm.plan``, ``arm.solve_at``,
``arm.control_step``), nothing iCub-specific.

Dry.  :class:`DryStream` moves the hand along the polyline at the arm's pen speeds (5 cm/s down,
15 cm/s up), one control step of 1/240 s at a time, with no acceleration: deterministic, for
tests.  Its executed trace is the polyline it followed (the path exactly when nothing was
replaced; a replaced tail starts with the point where the hand was).
"""

from __future__ import annotations

import math
import time
from bisect import bisect_right

import numpy as np

from ..core.errors import HilaRuntimeError, InputError
from ..core.validation import check_path
from ..plugins.protocols import StreamProgress
from .arm import ACCELERATION, DRAW_SPEED, SETTLE_STEPS, SETTLED, SIM_RATE, Trace, TRAVEL_SPEED, WAYPOINT_SPACING
from .reach import check_planned
from .trajectory import densify, trapezoid_profile


def _checked(path, label: str, surface_z, reach=None) -> np.ndarray:
    """``path`` as a (T, 3) array, refused as the back end's move refuses it: its reach bound
    (``reach``; None: the iCub's) and the paper."""
    arr = check_path(path, "path")
    if arr.shape[1] != 3:
        raise InputError(f"expected a path of shape (T, 3) with T >= 1, got {arr.shape}")
    if reach is None:
        check_planned(arr, surface_z, label)
    else:
        check_planned(arr, surface_z, label, reach)
    return arr


def profile_from(s0: float, v0: float, length: float, speed: float, accel: float, dt: float) -> list[tuple[float, float]]:
    """(arc position, speed) at every control step from arc ``s0`` at speed ``v0`` over ``length``
    more metres: speed up at ``accel`` to ``speed``, brake to stop at the end (a trapezoid that
    starts moving; ``v0`` above ``speed`` slows down to it)."""
    out: list[tuple[float, float]] = []
    s, v = 0.0, float(v0)
    floor = accel * dt  # the last steps creep at one step's speed gain, so the end is reached
    while s < length - 1e-12:
        v = max(min(speed if v <= speed else v - accel * dt, v + accel * dt,
                    math.sqrt(2.0 * accel * max(length - s, 0.0))), floor)
        s = min(s + v * dt, length)
        out.append((s0 + s, v))
    return out


class _Stream:
    """What both streams share: one path at a time, the control step of the arm's loop, the checks
    of a new path and of where a tail may be replaced from."""

    def __init__(self, backend) -> None:
        self.b = backend
        self.dt = 1.0 / SIM_RATE
        self._run: dict | None = None

    def _reach(self):
        """The arm's reach bound (``((x, y, z), radius)``), or None for the iCub's."""
        return getattr(getattr(self.b, "arm", self.b), "reach", None)

    def _start(self, path, label: str, surface_z) -> np.ndarray:
        if self._run is not None:
            raise HilaRuntimeError("a stream is already running: finish it before beginning another")
        return _checked(path, label, surface_z, self._reach())

    def _need(self) -> dict:
        if self._run is None:
            raise HilaRuntimeError("no stream is running: begin one first")
        return self._run

    def _tail(self, run, index: int, tail, surface_z) -> tuple[np.ndarray, int]:
        """``tail`` checked, and the first waypoint not yet passed (``index`` must not be before it)."""
        tail = _checked(tail, run["label"], surface_z, self._reach())
        passed = self._index(run)
        if not passed <= int(index) <= len(run["path"]):
            raise InputError(f"a stream's tail can be replaced from a waypoint not yet passed ({passed} to "
                             f"{len(run['path'])}), got {index}")
        return tail, passed

    def stop(self) -> np.ndarray:
        return np.zeros((0, 3)) if self._run is None else self._close(self._run)


class ArmStream(_Stream):
    """The ``streaming`` capability of :class:`~.backend.PyBulletBackend` (module docstring)."""

    # -- the protocol -------------------------------------------------------------------------
    def begin(self, path, *, pen_down: bool = False, label: str = "") -> float:
        b = self.b
        planned = self._start(path, label, b.arm.surface_z)
        if b.view is not None:
            b.view.planned(planned)
        dense, origin, arc, qs = b.arm.plan(planned, label)
        speed = DRAW_SPEED if pen_down else TRAVEL_SPEED
        profile = trapezoid_profile(arc[-1], speed, ACCELERATION, self.dt)
        self._run = {"path": planned, "dense": dense, "origin": np.asarray(origin), "arc": arc, "arcs": arc.tolist(), "qs": qs,
                     "profile": profile, "k": 0, "previous": 0.0, "s": 0.0, "v": 0.0, "speed": speed,
                     "pen_down": bool(pen_down), "label": label, "executed": [], "joints": [], "reference": [],
                     "on_paper": [], "steps": 0, "clock": 0.0, "aimed": None}
        b.arm.pace_from_now()
        return len(profile) * self.dt

    def advance(self, seconds: float, each_step=None) -> StreamProgress:
        run = self._need()
        n = max(0, int(round(float(seconds) / self.dt)))
        for _ in range(n):
            if run["k"] >= len(run["profile"]):
                break
            s, v = run["profile"][run["k"]]
            run["k"] += 1
            self._step(run, s, v, each_step)
        return self._progress(run)

    def replace(self, index: int, tail) -> None:
        run = self._need()
        tail, passed = self._tail(run, index, tail, self.b.arm.surface_z)

        arc, dense, qs = run["arc"], run["dense"], run["qs"]
        s = run["s"]
        i = self._segment(run, s)
        self._solve(run, i + 1)
        frac = (s - arc[i]) / max(arc[i + 1] - arc[i], 1e-12)
        here = dense[i] + frac * (dense[i + 1] - dense[i])
        q_here = qs[i] + frac * (qs[i + 1] - qs[i])
        kept = run["path"][passed:index]
        new_dense, new_origin, new_arc = densify(np.vstack([here, kept, tail]), WAYPOINT_SPACING)
        run["path"] = np.vstack([run["path"][:index], tail])
        run["dense"] = np.vstack([dense[: i + 1], new_dense])
        run["origin"] = np.concatenate([run["origin"][: i + 1], [passed], passed + np.asarray(new_origin[1:])])
        run["arc"] = np.concatenate([arc[: i + 1], s + new_arc])
        run["arcs"], run["aimed"] = run["arc"].tolist(), None  # the joints aimed at last step lay on the old tail
        unsolved = np.full((len(new_dense) - 1, qs.shape[1]), np.nan)
        run["qs"] = np.vstack([qs[: i + 1], q_here, unsolved])
        run["profile"] = profile_from(s, run["v"], float(run["arc"][-1] - s), run["speed"], ACCELERATION, self.dt)
        run["k"] = 0
        if self.b.view is not None:
            self.b.view.planned(run["path"])

    def finish(self, each_step=None) -> np.ndarray:
        run = self._need()
        try:
            while run["k"] < len(run["profile"]):
                s, v = run["profile"][run["k"]]
                run["k"] += 1
                self._step(run, s, v, each_step)
            final_q, final = self._solve(run, len(run["dense"]) - 1), run["dense"][-1]
            zero = np.zeros(len(final_q))
            for _ in range(SETTLE_STEPS):  # as Arm.move settles
                if run["executed"] and np.linalg.norm(run["executed"][-1] - final) < SETTLED:
                    break
                self._control(run, final_q, zero, final, each_step)
        except BaseException:
            self.stop()
            raise
        return self._close(run)

    # -- inside -------------------------------------------------------------------------------
    def _progress(self, run) -> StreamProgress:
        return StreamProgress(run["steps"] * self.dt, self._index(run), run["k"] >= len(run["profile"]))

    @staticmethod
    def _segment(run, s: float) -> int:
        arcs = run["arcs"]  # the arc lengths as floats: bisect_right is searchsorted(side="right")
        return max(0, min(bisect_right(arcs, s) - 1, len(arcs) - 2))

    def _index(self, run) -> int:
        """The first waypoint of the path not yet passed (``len(path)`` at its end)."""
        if len(run["arc"]) < 2 or run["s"] >= run["arc"][-1] - 1e-12:
            return len(run["path"])
        return int(run["origin"][self._segment(run, run["s"]) + 1])

    def _solve(self, run, j: int) -> np.ndarray:
        """The joint angles at dense point ``j``, solved now if they were not (from the first
        unsolved point up to ``j``, each warm-started from the one before)."""
        qs = run["qs"]
        if not math.isnan(qs[j, 0]):
            return qs[j]
        first = j
        while math.isnan(qs[first - 1, 0]):
            first -= 1
        clock = time.perf_counter()
        for m in range(first, j + 1):
            k = int(run["origin"][m])
            try:
                qs[m] = self.b.arm.solve_at(run["dense"][m], qs[m - 1], k, len(run["path"]), run["label"])
            finally:
                self.b.stats["ik_solves"] += 1
                self.b.stats["ik_seconds"] += time.perf_counter() - clock
                clock = time.perf_counter()
        return qs[j]

    def _step(self, run, s: float, v: float, each_step) -> None:
        arcs, dense, qs = run["arcs"], run["dense"], run["qs"]
        i = self._segment(run, s)
        self._solve(run, i + 1)
        ds = arcs[i + 1] - arcs[i]
        frac = (s - arcs[i]) / max(ds, 1e-12)
        q_here = qs[i] + frac * (qs[i + 1] - qs[i])
        point = dense[i] + frac * (dense[i + 1] - dense[i])
        slope = (qs[i + 1] - qs[i]) / ds if ds > 0 else np.zeros(qs.shape[1])
        # aim at the previous sample's joints with this sample's velocity (as Arm._execute does):
        # the joints this sample's point had at the last step, unless the tail was replaced since
        aimed = run["aimed"]
        if aimed is not None and aimed[0] == run["previous"]:
            q_target = aimed[1]
        else:
            p = self._segment(run, run["previous"])
            self._solve(run, p + 1)
            pfrac = (run["previous"] - arcs[p]) / max(arcs[p + 1] - arcs[p], 1e-12)
            q_target = qs[p] + pfrac * (qs[p + 1] - qs[p])
        run["previous"], run["s"], run["v"], run["aimed"] = s, s, v, (s, q_here)
        self._control(run, q_target, slope * v, point, each_step)

    def _control(self, run, q_target, qd_target, point, each_step) -> None:
        clock = time.perf_counter()
        q, tip = self.b.arm.control_step(q_target, qd_target)
        self.b.stats["steps"] += 1
        self.b.stats["step_seconds"] += time.perf_counter() - clock
        run["reference"].append(point)
        run["joints"].append(q)
        run["executed"].append(tip)
        surface = self.b.ink.surface  # the paper where it lies now: its ink moves with it
        run["on_paper"].append(surface.to_local(tip))  # (right, far); the height is the tip's
        run["steps"] += 1
        if each_step is not None:
            each_step(run["steps"] * self.dt)

    def _close(self, run) -> np.ndarray:
        self._run = None
        b = self.b
        executed = np.array(run["executed"]).reshape(-1, 3)
        trace = Trace(run["label"], run["pen_down"], run["path"], executed,
                      np.array(run["joints"]).reshape(-1, b.arm.chain.dof), np.array(run["reference"]).reshape(-1, 3))
        if run["pen_down"] and len(executed):
            local = np.array(run["on_paper"])
            surface = b.ink.surface
            trace.inked = b.ink.ink_trace(np.column_stack([surface.to_world(local[:, 0], local[:, 1])[:, :2],
                                                           executed[:, 2]]))
        b.traces.append(trace)
        if b.view is not None:
            b.view.show_eye(b.eyes.camera_image("left").rgb)
        return executed


class DryStream(_Stream):
    """The ``streaming`` capability of :class:`~.dry.DryBackend` (module docstring)."""

    def begin(self, path, *, pen_down: bool = False, label: str = "") -> float:
        planned = self._start(path, label, self.b.surface_z)
        self._run = {"path": planned, "followed": [], "pen_down": bool(pen_down), "label": label, "steps": 0,
                     "speed": DRAW_SPEED if pen_down else TRAVEL_SPEED}
        self._lay(self._run, self.b.hand_position(), planned, 0)
        self._pass(self._run, 0)
        return math.ceil(self._run["arc"][-1] / (self._run["speed"] * self.dt) - 1e-9) * self.dt

    def _pass(self, run, before: int) -> None:
        """Add the waypoints passed since waypoint ``before`` to the followed polyline."""
        run["followed"].extend(run["points"][1 + before - run["first"]: 1 + self._index(run) - run["first"]])

    def _lay(self, run, here: np.ndarray, ahead: np.ndarray, first: int) -> None:
        """The polyline still to follow: from ``here`` through ``ahead`` (waypoints ``first`` on)."""
        points = np.vstack([here, ahead])
        run["points"], run["first"] = points, first
        run["arc"] = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
        run["s"] = 0.0

    def _index(self, run) -> int:
        passed = int(np.searchsorted(run["arc"][1:], run["s"] + 1e-12, side="right"))
        return run["first"] + passed

    def _here(self, run) -> np.ndarray:
        arc, pts, s = run["arc"], run["points"], run["s"]
        i = max(0, min(int(np.searchsorted(arc, s, side="right")) - 1, len(arc) - 2)) if len(arc) > 1 else 0
        if len(arc) < 2:
            return pts[0].copy()
        frac = (s - arc[i]) / max(arc[i + 1] - arc[i], 1e-12)
        return pts[i] + min(frac, 1.0) * (pts[i + 1] - pts[i])

    def advance(self, seconds: float, each_step=None) -> StreamProgress:
        run = self._need()
        for _ in range(max(0, int(round(float(seconds) / self.dt)))):
            if run["s"] >= run["arc"][-1]:
                break
            self._step(run, each_step)
        return StreamProgress(run["steps"] * self.dt, self._index(run), run["s"] >= run["arc"][-1])

    def _step(self, run, each_step) -> None:
        before = self._index(run)
        s = run["s"] + run["speed"] * self.dt
        run["s"] = run["arc"][-1] if s > run["arc"][-1] - 1e-12 else s  # the last step lands on the end
        self._pass(run, before)
        self.b._hand = self._here(run)
        run["steps"] += 1
        if each_step is not None:
            each_step(run["steps"] * self.dt)

    def replace(self, index: int, tail) -> None:
        run = self._need()
        tail, passed = self._tail(run, index, tail, self.b.surface_z)
        here = self._here(run)
        if not run["followed"] or np.linalg.norm(run["followed"][-1] - here) > 0:
            run["followed"].append(here)  # where the hand was when the tail changed
        kept = run["path"][passed:index]
        run["path"] = np.vstack([run["path"][:index], tail])
        self._lay(run, here, np.vstack([kept, tail]), passed)
        first = len(run["followed"])
        self._pass(run, passed)
        if len(run["followed"]) > first and np.array_equal(run["followed"][first], here):
            del run["followed"][first]  # the new tail begins where the hand is: once is enough

    def finish(self, each_step=None) -> np.ndarray:
        run = self._need()
        try:
            while run["s"] < run["arc"][-1]:
                self._step(run, each_step)
        except BaseException:
            self.stop()
            raise
        return self._close(run)

    def _close(self, run) -> np.ndarray:
        self._run = None
        executed = np.array(run["followed"], dtype=float).reshape(-1, 3)
        if not len(executed):
            executed = self.b.hand_position()[None]
        self.b.moves.append((run["label"], executed.copy(), run["pen_down"]))
        self.b._hand = executed[-1].copy()
        return executed
