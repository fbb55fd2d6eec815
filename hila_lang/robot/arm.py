"""The arm controller: IK along a path, then the 240 Hz position-control loop.

:meth:`Arm.move` prefixes the path with the current pen-tip position, densifies it to waypoints
at most 2 mm apart, and solves every waypoint by IK (:mod:`.ik`), warm-started from the
previous one, over the arm's chain within *comfort limits* (a margin inside the URDF limits,
and the spec's comfort ranges: the iCub's torso kept near upright).  Only when every waypoint
is solved does the arm move: joint targets are interpolated along the path's arc length with a trapezoidal speed profile (drawing
5 cm/s with the pen down, 15 cm/s with it up), sent to PyBullet's position controllers with
realistic force limits at 240 Hz, with the matching joint velocities as feed forward.  The pen
tip is recorded every step and joint limits are checked every step.  A target more than 2 mm
below the paper inside the table is refused like any unreachable target.
"""

from __future__ import annotations

import math
import time
from bisect import bisect_right
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import HilaRuntimeError
from . import ik
from .reach import check_planned, unreachable
from .trajectory import densify, trapezoid_profile

#: simulation rate, Hz
SIM_RATE = 240.0
#: pen speeds, m/s
DRAW_SPEED = 0.05
TRAVEL_SPEED = 0.15
#: Cartesian acceleration of the speed profile, m/s^2
ACCELERATION = 0.5
#: maximum spacing of IK waypoints along a path, metres
WAYPOINT_SPACING = 0.002
#: an IK solution is accepted within these residuals (metres, radians)
IK_ACCEPT_ERROR = 1e-4
IK_ACCEPT_TILT = 0.01
#: margin kept inside the URDF limits by the IK, radians
LIMIT_MARGIN = 0.02
#: joint-limit check during execution: allowed excess over the URDF limits, radians
LIMIT_CHECK_TOLERANCE = 1e-3
#: position-controller gains
POSITION_GAIN = 0.3
VELOCITY_GAIN = 1.0
#: after a path the arm holds its last target until the tip is this near it, metres, for at most
#: SETTLE_STEPS control steps (0.25 s)
SETTLED = 5e-5
SETTLE_STEPS = int(0.25 * SIM_RATE)
#: physics solver iterations per step (PyBullet's default 50 costs 60 % more time for a
#: tracking gain of 0.002 mm)
SOLVER_ITERATIONS = 20


def accept(result: ik.IKResult) -> ik.IKResult:
    """``result`` with ``converged`` judged by the arm's own thresholds (:data:`IK_ACCEPT_ERROR`,
    :data:`IK_ACCEPT_TILT`), looser than the solver's stopping tolerances."""
    converged = result.error <= IK_ACCEPT_ERROR and result.tilt <= IK_ACCEPT_TILT
    if converged == result.converged:
        return result
    return ik.IKResult(result.q, result.position, result.error, result.tilt, result.iterations, converged)


def raise_if_unreachable(result: ik.IKResult, point, k: int, total: int, label: str) -> None:
    """An :class:`UnreachableError` for waypoint ``k`` of ``total`` (``point``) when ``result`` did
    not converge: how close the pen gets, and its tilt."""
    if result.converged:
        return
    tilt = f", pen tilted {math.degrees(result.tilt):.1f} deg" if result.tilt > IK_ACCEPT_TILT else ""
    distance = np.linalg.norm(result.position - np.asarray(point, dtype=float))
    raise unreachable(point, f"the pen gets no closer than {distance * 1000:.1f} mm, to "
                             f"{_fmt(result.position)}{tilt}", distance, label,
                      where=f" (waypoint {k + 1} of {total})")


def solve_along(solve, tip, q_start: np.ndarray, planned: np.ndarray, label: str = ""):
    """IK along ``planned`` (T, 3) from the joint angles ``q_start`` (n,): the path prefixed with the
    tip at ``q_start``, densified to :data:`WAYPOINT_SPACING`, every point solved warm-started from
    the one before.  ``solve(target, q0) -> IKResult`` (accepted or not), ``tip(q) -> (3,)``.

    Returns ``(dense (M, 3), origin (M,), arc (M,) metres, qs (M, n))``: ``origin[i]`` is the
    index of the waypoint of ``planned`` that ``dense[i]`` leads to.  Raises
    :class:`UnreachableError` naming the waypoint on the way to which the IK fails, and how close
    it got.
    """
    dense, origin_index, arc = densify(np.vstack([tip(q_start), planned]), WAYPOINT_SPACING)
    qs = np.empty((len(dense), len(q_start)))
    qs[0] = q_start
    for i in range(1, len(dense)):
        result = solve(dense[i], qs[i - 1])
        if not result.converged:
            # dense[i] lies on the way to waypoint k: report how near to *it* the pen gets
            k = int(origin_index[i])
            last = tip(qs[i - 1])
            if np.linalg.norm(last - planned[k]) < np.linalg.norm(result.position - planned[k]):
                result = ik.IKResult(qs[i - 1], last, result.error, result.tilt, result.iterations, False)
            raise_if_unreachable(result, planned[k], k, len(planned), label)
        qs[i] = result.q
    return dense, origin_index, arc, qs


@dataclass
class Trace:
    """One executed move.

    Attributes
    ----------
    label : str
        The FSM state (or caller's label) that asked for it.
    pen_down : bool
    planned : ndarray, shape (T, 3)
        The path as given, world frame, metres.
    executed : ndarray, shape (T', 3)
        The pen tip at every simulation step (240 Hz), world frame, metres.
    joints : ndarray, shape (T', n)
        The arm's joint angles at every step, radians, chain order.
    reference : ndarray, shape (T', 3)
        The point of the (densified) path the controller was aiming at at every step; the
        tracking error is ``executed - reference``.
    inked : int
        Number of executed samples that left ink.
    """

    label: str
    pen_down: bool
    planned: np.ndarray
    executed: np.ndarray
    joints: np.ndarray = field(repr=False)
    reference: np.ndarray = field(repr=False)
    inked: int = 0


def _fmt(point) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in np.asarray(point, dtype=float)) + ")"


class Arm:
    """The arm of ``body`` holding a pen over a table whose paper is at ``surface_z``; its weights,
    comfort ranges, seed and rest postures and reach come from the body's spec
    (:class:`~.spec.RobotSpec`).

    ``stats`` (a dict) gains ``ik_solves``, ``ik_seconds``, ``steps`` and ``step_seconds``.
    ``realtime``: pace the control loop for a window a person watches: 0 (or False) not at all,
    1 (or True) at its simulated speed, N at N times it (``--speed N``).
    """

    def __init__(self, body, surface_z: float, stats: dict, *, realtime: float = 0.0) -> None:
        self.body = body
        self.chain = body.arm_chain
        self.surface_z = float(surface_z)
        self.stats = stats
        self.realtime = realtime
        spec = body.spec
        lo, hi = spec.ik_limits(LIMIT_MARGIN)
        self.ik_lower, self.ik_upper = lo, hi
        #: called with the pen tip (3,) after every simulation step of a move (a window draws it)
        self.observer = None
        self._pace = [time.perf_counter(), 0]
        self.weights = spec.joint_weights()
        self.seed_posture = spec.posture("seed")
        self.rest_posture = np.clip(spec.posture("rest"), lo, hi)
        self.ready_posture = self.rest_posture
        self.reach = spec.reach()
        self.tip_link = spec.tip_link()
        #: the limits :meth:`control_step` checks every step (the URDF's with the tolerance)
        self._checked = (self.chain.lower - LIMIT_CHECK_TOLERANCE, self.chain.upper + LIMIT_CHECK_TOLERANCE)

    def ready_at(self, point: np.ndarray) -> bool:
        """Find the ready posture: the pen vertical at ``point`` (3,); False when out of reach
        (the ready posture is then the rest posture)."""
        ready = ik.solve(self.chain, point, self.seed_posture, lower=self.ik_lower, upper=self.ik_upper, weights=self.weights)
        self.ready_posture = ready.q if ready.converged else self.rest_posture
        return bool(ready.converged)

    def joint_positions(self) -> np.ndarray:
        """The arm's joint angles (n,), radians, chain order."""
        return self.body.arm_angles()

    def hand_position(self) -> np.ndarray:
        """The pen tip, shape (3,), world frame, metres."""
        return self.chain.tip_position(self.joint_positions())

    def _solve(self, target: np.ndarray, q0: np.ndarray) -> ik.IKResult:
        return accept(ik.solve(self.chain, target, q0, lower=self.ik_lower, upper=self.ik_upper, weights=self.weights))

    def _check_above_table(self, point: np.ndarray, k: int, total: int, label: str) -> None:
        check_planned(np.asarray(point, dtype=float)[None], self.surface_z, label, self.reach)

    def _raise_if_unreachable(self, result: ik.IKResult, point, k: int, total: int, label: str) -> None:
        raise_if_unreachable(result, point, k, total, label)

    def solve_at(self, target: np.ndarray, q0: np.ndarray, k: int = 0, total: int = 1, label: str = "") -> np.ndarray:
        """The joint angles (n,) that put the pen vertically at ``target`` (3,), warm-started from
        ``q0``; :class:`UnreachableError` names it as waypoint ``k`` of ``total`` when none does."""
        result = self._solve(np.asarray(target, dtype=float), q0)
        self._raise_if_unreachable(result, target, k, total, label)
        return result.q

    def reset_hand(self, target: np.ndarray) -> np.ndarray:
        """Put the pen tip at ``target`` (3,) at once (no motion, no trace); returns the angles (n,).

        Raises :class:`UnreachableError` when the point cannot be reached.
        """
        self._check_above_table(target, 0, 1, "reset_hand")
        result = self._solve(target, self.joint_positions())
        if not result.converged:
            result = min((result, self._solve(target, self.ready_posture)), key=lambda r: r.error)
        self._raise_if_unreachable(result, target, 0, 1, "reset_hand")
        self.body.set_arm(result.q)
        return result.q

    def plan(self, planned: np.ndarray, label: str = "") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """IK along ``planned`` (T, 3) (checked) from where the pen is, before anything moves.

        Returns the densified points (M, 3) (the pen first), for each the index of the waypoint
        of ``planned`` it leads to (M,), their arc lengths (M,), metres, and the joint angles
        solved at each (M, n).  Raises :class:`UnreachableError` naming the waypoint.
        """
        check_planned(planned, self.surface_z, label, self.reach)  # the reach bound and the paper, as the dry back end checks
        clock = time.perf_counter()
        dense, origin_index, arc, qs = solve_along(self._solve, self.chain.tip_position, self.joint_positions(), planned, label)
        self.stats["ik_solves"] += len(dense) - 1
        self.stats["ik_seconds"] += time.perf_counter() - clock
        return dense, origin_index, arc, qs

    def move(self, planned: np.ndarray, *, pen_down: bool = False, label: str = "") -> Trace:
        """Follow ``planned`` (T, 3) (checked) from where the pen is; the executed move.

        Raises :class:`UnreachableError` (the arm does not move) when a waypoint cannot be
        reached, :class:`HilaRuntimeError` if a joint leaves its limits during execution.
        """
        dense, _, arc, qs = self.plan(planned, label)
        clock = time.perf_counter()
        executed, joints, reference = self._execute(qs, dense, arc, DRAW_SPEED if pen_down else TRAVEL_SPEED)
        self.stats["steps"] += len(executed)
        self.stats["step_seconds"] += time.perf_counter() - clock
        return Trace(label, bool(pen_down), planned, executed, joints, reference)

    def pace_from_now(self) -> None:
        """Start pacing the control steps that follow (``realtime``: a window watches)."""
        self._pace = [time.perf_counter(), 0]

    def control_step(self, q_target: np.ndarray, qd_target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One control step: the motors aim at ``q_target`` (n,) with the feed-forward velocity
        ``qd_target`` (n,), the simulation steps once; returns the joint angles (n,) and the
        pen tip (3,) after it.  Joint limits are checked (HilaRuntimeError), the ``observer``
        told, and with a window the step is paced (:meth:`pace_from_now`)."""
        pb, c = self.body.sim.pb, self.body.sim.client
        self.body.command(q_target, qd_target, POSITION_GAIN, VELOCITY_GAIN)
        pb.stepSimulation(physicsClientId=c)
        if self.realtime:  # a window shows the motion at real speed, or --speed N times it
            self._pace[1] += 1
            ahead = self._pace[1] / SIM_RATE / float(self.realtime) - (time.perf_counter() - self._pace[0])
            if ahead > 0:
                time.sleep(ahead)
        q = self.joint_positions()
        lower, upper = self._checked
        if ((q < lower) | (q > upper)).any():
            bad = int(np.argmax(np.maximum(lower - q, q - upper)))
            raise HilaRuntimeError(
                f"joint {self.chain.names[bad]} left its limits during a move "
                f"({q[bad]:.3f} rad, limits {self.chain.lower[bad]:.3f}..{self.chain.upper[bad]:.3f})"
            )
        tip = self.body.link_position(self.tip_link)
        if self.observer is not None:
            self.observer(tip)
        return q, tip

    def _execute(self, qs: np.ndarray, dense: np.ndarray, arc: np.ndarray, speed: float):
        """Run the joint path ``qs`` (M, n) through ``dense`` (M, 3) at arc lengths ``arc`` (M,)."""
        dt = 1.0 / SIM_RATE
        times = trapezoid_profile(arc[-1], speed, ACCELERATION, dt)
        executed, joints, reference = [], [], []
        final = dense[-1]
        slopes = np.zeros_like(qs)
        if len(arc) > 1:
            ds = np.diff(arc)
            slopes[:-1] = np.diff(qs, axis=0) / np.where(ds > 0, ds, 1.0)[:, None]
            slopes[-1] = slopes[-2]
        self.pace_from_now()

        def step(q_target, qd_target, point):
            reference.append(point)
            q, tip = self.control_step(q_target, qd_target)
            joints.append(q)
            executed.append(tip)

        arcs = arc.tolist()  # floats: bisect_right is searchsorted(side="right")

        def along(s):
            i = min(bisect_right(arcs, s) - 1, len(arcs) - 2)
            frac = (s - arcs[i]) / max(arcs[i + 1] - arcs[i], 1e-12)
            return i, qs[i] + frac * (qs[i + 1] - qs[i]), dense[i] + frac * (dense[i + 1] - dense[i])

        # PyBullet's position motor ends a step at (target + dt * target velocity): aim at the
        # previous sample's position with this sample's velocity to be at this sample's point
        q_previous = along(0.0)[1] if len(arc) > 1 else None
        for s, v in times:
            if len(arc) > 1:
                i, q_here, point = along(s)
                step(q_previous, slopes[i] * v, point)
                q_previous = q_here  # the next step aims at this sample's joints
            else:
                step(qs[0], np.zeros(self.chain.dof), dense[0])
        # settle: hold the last target until the tip is within 0.05 mm (at most 0.25 s)
        for _ in range(SETTLE_STEPS):
            if executed and np.linalg.norm(executed[-1] - final) < SETTLED:
                break
            step(qs[-1], np.zeros(self.chain.dof), final)
        return (
            np.array(executed).reshape(-1, 3),
            np.array(joints).reshape(-1, self.chain.dof),
            np.array(reference).reshape(-1, 3),
        )
