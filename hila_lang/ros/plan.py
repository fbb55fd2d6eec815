"""A move for an arm driven by joint trajectories: IK along the path, time-parametrised under the
speed and acceleration caps, and checked whole before anything is sent (pure numpy, no ROS).

:func:`plan_move` turns a Cartesian path (T, 3) into a :class:`JointPlan` from the arm's
*measured* joint angles:

1. the path is prefixed with where the tool is now (a straight bridge to its first point, at most
   ``gap`` long) and densified, every point solved by IK warm-started from the one before
   (:func:`hila_lang.robot.arm.solve_along`, as the PyBullet arm solves it);
2. the points are timed along their arc length with a trapezoidal speed profile at the pen's
   speed (:data:`~hila_lang.robot.arm.DRAW_SPEED` down, :data:`~hila_lang.robot.arm.TRAVEL_SPEED`
   up, at most ``speed``) and :data:`~hila_lang.robot.arm.ACCELERATION`; then, if a joint would
   turn faster than its cap (speed or acceleration), the whole timing is stretched until none does;
3. the result is checked whole (:func:`check_plan`), sampled between its points through the
   same cubic interpolation a trajectory controller uses: every tool point in the workspace box,
   every joint within its URDF limits and speed cap, the tool no faster than ``speed``.

Every refusal is located (the waypoint, or the time into the move and the joint) and ends with
"the arm did not move": nothing is sent.  A waypoint the arm cannot reach or outside the box is an
:class:`~hila_lang.core.errors.UnreachableError`, which the engine retells as the program's target.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import HilaRuntimeError, InputError
from ..core.validation import check_path
from ..robot.arm import ACCELERATION, DRAW_SPEED, TRAVEL_SPEED, solve_along
from ..robot.reach import out_of_reach, unreachable
from ..robot.trajectory import trapezoid_times

#: how finely a planned trajectory is sampled by :func:`check_plan`: samples per segment between
#: two knots (2 mm apart: 13 ms at 0.15 m/s)
CHECK_SAMPLES = 4
#: a sampled tool speed may exceed the cap by this fraction (rounding: :func:`plan_move` stretches
#: the timing until the sampled speed is within the pen's speed)
SPEED_SLACK = 0.001
#: segments shorter than this are dropped before timing (two equal points), metres
MIN_SEGMENT = 1e-9


def _fmt(p) -> str:
    return "(" + ", ".join(f"{float(v):.3f}" for v in p) + ")"


@dataclass(frozen=True)
class Workspace:
    """An axis-aligned box the tool must stay in, world frame, metres: ``lower`` and ``upper`` (3,)."""

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]

    @classmethod
    def parse(cls, text: str) -> "Workspace":
        """``XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX`` (metres); a ValueError saying what it expected."""
        parts = text.replace("(", "").replace(")", "").split(",")
        try:
            values = [float(v) for v in parts]
        except ValueError:
            values = []
        if len(values) != 6 or not all(np.isfinite(values)):
            raise ValueError(f"expected XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX (six finite numbers, metres), got {text!r}")
        lower, upper = values[0::2], values[1::2]
        for axis, lo, hi in zip("xyz", lower, upper):
            if not lo < hi:
                raise ValueError(f"expected {axis.upper()}MIN < {axis.upper()}MAX, got {lo:g} and {hi:g}")
        return cls(tuple(lower), tuple(upper))

    def text(self) -> str:
        return ",".join(f"{v:g}" for pair in zip(self.lower, self.upper) for v in pair)

    def outside(self, points: np.ndarray) -> tuple[int, float, str] | None:
        """The first of ``points`` (N, 3) farthest outside the box: (index, metres out, which side),
        or None when all are inside."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        below = np.asarray(self.lower) - points
        above = points - np.asarray(self.upper)
        out = np.maximum(below, above).max(axis=1)
        k = int(np.argmax(out))
        if out[k] <= 0:
            return None
        axis = int(np.argmax(np.maximum(below[k], above[k])))
        side = (f"below {'xyz'[axis]} = {self.lower[axis]:.3f}" if below[k, axis] >= above[k, axis]
                else f"beyond {'xyz'[axis]} = {self.upper[axis]:.3f}")
        return k, float(out[k]), side


def _boxed(exc: UnreachableError, workspace: Workspace) -> UnreachableError:
    exc.hint = f"the box is ros.workspace={workspace.text()} (XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX); --set it to the arm's"
    return exc


def hermite(times: np.ndarray, positions: np.ndarray, velocities: np.ndarray, t) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Hermite interpolation of knots at ``times`` (M,) with ``positions`` and ``velocities``
    (M, n), as a joint trajectory controller interpolates between points that carry velocities.

    ``t``: a time or times (K,), seconds; before the first knot the first is held, after the last
    the last (at rest).  Returns positions and velocities, (n,) or (K, n).
    """
    times = np.asarray(times, dtype=float)
    scalar = np.ndim(t) == 0
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if len(times) == 1:
        q = np.repeat(positions[:1], len(t), axis=0)
        return (q[0], np.zeros_like(q[0])) if scalar else (q, np.zeros_like(q))
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    h = times[i + 1] - times[i]
    s = np.clip((t - times[i]) / h, 0.0, 1.0)[:, None]
    h = h[:, None]
    p0, p1, v0, v1 = positions[i], positions[i + 1], velocities[i] * h, velocities[i + 1] * h
    s2, s3 = s * s, s * s * s
    q = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * v0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * v1
    qd = ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * v0 + (-6 * s2 + 6 * s) * p1 + (3 * s2 - 2 * s) * v1) / h
    ended = (t >= times[-1])[:, None]
    qd = np.where(ended | (t < times[0])[:, None], 0.0, qd)
    return (q[0], qd[0]) if scalar else (q, qd)


@dataclass(frozen=True)
class JointPlan:
    """A timed joint trajectory for one move, and what it was made from.

    Attributes
    ----------
    label : str
        The FSM state that asked for it.
    joints : tuple of str
        The arm's joint names (the kinematic description's).
    planned : ndarray (T, 3)
        The path as given, world frame, metres.
    tips : ndarray (M, 3)
        The densified path the tool follows: where the tool is now, then ``planned``.
    origin : ndarray (M,)
        For each of ``tips``, the index of the waypoint of ``planned`` it leads to.
    times : ndarray (M,)
        Seconds from the start; ``times[0] = 0`` at the measured posture.
    positions, velocities : ndarray (M, n)
        Radians and rad/s at ``times``.
    stretch : float
        How much the timing at the pen's speed was stretched for the joints' caps (1: not at all).
    """

    label: str
    joints: tuple
    planned: np.ndarray
    tips: np.ndarray
    origin: np.ndarray
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    stretch: float = 1.0

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @property
    def end(self) -> np.ndarray:
        """Where the tool should end (3,)."""
        return self.tips[-1]

    def sample(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities at time(s) ``t`` (:func:`hermite`)."""
        return hermite(self.times, self.positions, self.velocities, t)

    def where(self, t: float) -> str:
        """``1.23 s into the move (of 2.30 s), on the way to waypoint k of T (x, y, z)``."""
        i = int(np.clip(np.searchsorted(self.times, t), 0, len(self.times) - 1))
        k = int(self.origin[i])
        return (f"{t:.2f} s into the move (of {self.duration:.2f} s), on the way to waypoint {k + 1} of "
                f"{len(self.planned)} {_fmt(self.planned[k])}")

    def summary(self) -> str:
        """What the move will do, in a few lines (``--confirm``)."""
        length = np.linalg.norm(np.diff(self.tips, axis=0), axis=1).sum()
        lo, hi = self.tips.min(axis=0), self.tips.max(axis=0)
        fastest = np.abs(self.velocities).max(axis=0)
        j = int(np.argmax(fastest))
        return "\n".join([
            f"move {self.label or '(unnamed)'}: {len(self.planned)} waypoints, {length * 1000:.0f} mm in "
            f"{self.duration:.2f} s ({len(self.times)} trajectory points)",
            f"  from {_fmt(self.tips[0])} (where the tool is) to {_fmt(self.end)}",
            f"  inside x {lo[0]:.3f}..{hi[0]:.3f}, y {lo[1]:.3f}..{hi[1]:.3f}, z {lo[2]:.3f}..{hi[2]:.3f} m",
            f"  fastest joint {self.joints[j]} at {fastest[j]:.2f} rad/s"
            + (f"; timing stretched x{self.stretch:.2f} for the joints' caps" if self.stretch > 1.0 else ""),
        ])


def plan_move(arm, q_start, path, *, pen_down: bool = False, speed: float = TRAVEL_SPEED,
              workspace: Workspace | None = None, gap: float = 0.15, label: str = "") -> JointPlan:
    """The checked :class:`JointPlan` of the tool along ``path`` (T, 3) from joint angles ``q_start`` (n,).

    ``arm`` is a :class:`~hila_lang.robot.kinematic_arm.KinematicArm`; ``speed`` caps the tool's
    speed (m/s); ``gap`` bounds the distance from the tool to the path's first point (metres).
    Raises :class:`UnreachableError` for a waypoint out of reach or outside ``workspace``,
    :class:`HilaRuntimeError` for any other refusal, :class:`InputError` for a malformed path.
    """
    planned = check_path(path, "path")
    if planned.shape[1] != 3:
        raise InputError(f"expected a path of shape (T, 3) with T >= 1, got {planned.shape}")
    q_start = np.asarray(q_start, dtype=float).reshape(-1)
    where = f" in {label}" if label else ""
    off = np.maximum(arm.lower - q_start, q_start - arm.upper)
    if np.any(off > 1e-3):
        j = int(np.argmax(off))
        raise HilaRuntimeError(f"refused{where}: the arm reports {arm.joints[j]} at {q_start[j]:.3f} rad, outside its "
                               f"limits {arm.lower[j]:.3f}..{arm.upper[j]:.3f} in the robot's description; the arm "
                               "did not move", hint="is the description the arm's? (joint names, zero positions)")
    here = arm.tip(q_start)
    bridge = float(np.linalg.norm(planned[0] - here))
    if bridge > gap:
        raise HilaRuntimeError(f"refused{where}: the path starts {bridge * 1000:.0f} mm from where the tool is "
                               f"{_fmt(here)} (measured), more than ros.gap = {gap * 1000:.0f} mm; the arm did not move",
                               hint="start the path at the hand (bind its start ICP to the hand), or raise --set ros.gap")
    for k, point in enumerate(planned):
        why = out_of_reach(point, *arm.reach)
        if why:
            raise unreachable(point, why, float(np.linalg.norm(point - arm.reach[0]) - arm.reach[1]), label,
                              where=f" (waypoint {k + 1} of {len(planned)})")
    if workspace is not None:
        out = workspace.outside(planned)
        if out is not None:
            k, far, side = out
            raise _boxed(unreachable(planned[k], f"it is {far * 1000:.1f} mm outside the workspace box ({side})", far,
                                     label, where=f" (waypoint {k + 1} of {len(planned)})"), workspace)
    tips, origin, arc, qs = solve_along(arm.solve, arm.tip, q_start, planned, label)
    keep = np.concatenate([[True], np.diff(arc) > MIN_SEGMENT])
    tips, origin, arc, qs = tips[keep], origin[keep], arc[keep], qs[keep]
    pen_speed = min(DRAW_SPEED if pen_down else TRAVEL_SPEED, speed)
    times, stretch, velocities = time_joint_path(arc, qs, pen_speed, ACCELERATION, arm.velocity, arm.acceleration)
    # the cubic between two knots where the path turns a corner runs a little faster than the knots
    # (up to 7 % on the shipped programs): stretch the timing by what the sampled tool speed exceeds
    over = _tool_speeds(arm, times, qs, velocities)[1].max() / pen_speed if len(times) > 1 else 1.0
    if over > 1.0:
        times, velocities, stretch = times * over, velocities / over, stretch * over
    plan = JointPlan(label, tuple(arm.joints), planned, tips, origin, times, qs, velocities, stretch)
    check_plan(arm, plan, speed=speed, workspace=workspace)
    return plan


def time_joint_path(arc: np.ndarray, qs: np.ndarray, speed: float, accel: float, velocity_cap: np.ndarray,
                    acceleration_cap: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Times (M,) for the joint path ``qs`` (M, n) at arc lengths ``arc`` (M,): a trapezoidal profile
    at ``speed`` m/s and ``accel`` m/s^2 along the arc, stretched uniformly by the least factor that
    keeps every joint within ``velocity_cap`` and ``acceleration_cap`` (n,).  Returns the times,
    the stretch (>= 1) and the joint velocities (M, n) at the times (zero at both ends)."""
    if len(arc) < 2:
        return np.zeros(len(arc)), 1.0, np.zeros_like(qs)
    times, v = trapezoid_times(arc, speed, accel)
    velocities = np.gradient(qs, arc, axis=0) * v[:, None]
    accelerations = np.gradient(velocities, times, axis=0)
    ratio_v = float(np.max(np.abs(velocities) / velocity_cap))
    ratio_a = float(np.max(np.abs(accelerations) / acceleration_cap))
    stretch = max(1.0, ratio_v, float(np.sqrt(ratio_a)))
    return times * stretch, stretch, velocities / stretch


def sample_times(times: np.ndarray) -> np.ndarray:
    """Where a trajectory with knots at ``times`` (M,) is checked: every knot and
    :data:`CHECK_SAMPLES` - 1 points evenly between each two (so a uniform stretch of the timing
    stretches the samples with it)."""
    steps = np.arange(CHECK_SAMPLES) / CHECK_SAMPLES
    return np.append((times[:-1, None] + np.diff(times)[:, None] * steps).ravel(), times[-1])


def _tool_speeds(arm, times, positions, velocities, sampled=None) -> tuple[np.ndarray, np.ndarray]:
    """The tool's points (K, 3) at :func:`sample_times` along the interpolated trajectory and
    its speed between them (K - 1,), m/s; ``sampled`` = (t, q) when already sampled."""
    if sampled is None:
        t = sample_times(times)
        q, _ = hermite(times, positions, velocities, t)
    else:
        t, q = sampled
    tips = arm.tips(q)
    return tips, np.linalg.norm(np.diff(tips, axis=0), axis=1) / np.maximum(np.diff(t), 1e-9)


def check_plan(arm, plan: JointPlan, *, speed: float, workspace: Workspace | None) -> None:
    """Refuse ``plan`` unless, sampled at :func:`sample_times`, every joint stays within its
    limits and speed cap, the tool within ``workspace`` and no faster than ``speed`` (+ :data:`SPEED_SLACK`)."""
    if len(plan.times) < 2:
        return
    where = f" in {plan.label}" if plan.label else ""
    t = sample_times(plan.times)
    q, qd = plan.sample(t)
    off = np.maximum(arm.lower - q, q - arm.upper)
    if np.any(off > 0):
        i, j = np.unravel_index(int(np.argmax(off)), off.shape)
        raise HilaRuntimeError(f"refused{where}: {arm.joints[j]} would reach {q[i, j]:.3f} rad, outside its limits "
                               f"{arm.lower[j]:.3f}..{arm.upper[j]:.3f}, {plan.where(t[i])}; the arm did not move")
    fast = np.abs(qd) / arm.velocity
    if fast.max() > 1.0 + 1e-6:
        i, j = np.unravel_index(int(np.argmax(fast)), fast.shape)
        raise HilaRuntimeError(f"refused{where}: {arm.joints[j]} would turn at {abs(qd[i, j]):.2f} rad/s, over its cap "
                               f"{arm.velocity[j]:.2f} rad/s, {plan.where(t[i])}; the arm did not move")
    tips, tool_speed = _tool_speeds(arm, plan.times, plan.positions, plan.velocities, (t, q))
    if workspace is not None:
        out = workspace.outside(tips)
        if out is not None:
            i, far, side = out
            raise _boxed(unreachable(tips[i], f"the tool would pass {far * 1000:.1f} mm outside the workspace box "
                                              f"({side}), {plan.where(t[i])}", far, plan.label), workspace)
    i = int(np.argmax(tool_speed))
    if tool_speed[i] > speed * (1.0 + SPEED_SLACK):
        raise HilaRuntimeError(f"refused{where}: the tool would move at {tool_speed[i]:.3f} m/s, over the cap "
                               f"ros.speed = {speed:.3f} m/s, {plan.where(t[i])}; the arm did not move")


def off_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """How far each of ``points`` (N, 3) is from the polyline ``path`` (M, 3), metres (N,)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    path = np.asarray(path, dtype=float).reshape(-1, 3)
    if len(path) == 1:
        return np.linalg.norm(points - path[0], axis=1)
    a, b = path[:-1], path[1:]
    ab = b - a
    length2 = np.maximum((ab * ab).sum(axis=1), 1e-18)
    out = np.empty(len(points))
    for start in range(0, len(points), 256):  # (256, M) at a time: memory stays small
        p = points[start:start + 256, None, :]
        s = np.clip(((p - a) * ab).sum(axis=2) / length2, 0.0, 1.0)
        out[start:start + 256] = np.linalg.norm(p - (a + s[..., None] * ab), axis=2).min(axis=1)
    return out


def hausdorff(executed: np.ndarray, planned: np.ndarray) -> float:
    """The larger of: the farthest executed point from the planned polyline, the farthest planned
    point from the executed one (metres) -- how far the arm's path and the plan are apart."""
    return float(max(off_path(executed, planned).max(), off_path(planned, executed).max()))
