"""Forward kinematics and damped-least-squares IK for a robot's arm (pure numpy).

The chain is read from the robot's URDF (:mod:`hila_lang.robot.spec`; the iCub's is generated,
:mod:`hila_lang.robot.model`): the joints from the
root link to the pen tip, with their fixed origins, axes and limits.  Forward kinematics and the
geometric Jacobian are computed here from those joint frames and axes; PyBullet's
``calculateJacobian`` disagreed with finite differences on this model and its IK treats limits
as soft (docs/design.md §5), so neither is used.

Task: put the pen tip at a point and keep the pen vertical (its axis, +z of the tip frame,
pointing down -z world); rotation about the pen axis is free.  That is 5 constraints for 10
joints (the iCub's torso + right arm; the Panda's and KUKA's 7).  Each iteration takes a
damped least-squares step ``dq = J^T (J J^T + l^2 I)^-1 e`` (damping ``l`` = 0.01, step at most 0.3 rad), clamps to the joint limits and drops joints that
sit at a limit and are pushed further out.

Frames and units: world frame, metres, radians.  ``q`` is ordered as the chain (root to tip).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from ..core.rotation import from_rpy, pose

#: weight of the pen-axis error against the position error, metres per radian
ORIENTATION_WEIGHT = 0.1


_EYE3 = np.eye(3)


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (..., 3, 3) of vectors (..., 3): ``_skew(a) @ b == a x b``."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of vectors (..., 3), the same arithmetic (equal results) without its axis
    handling: a third to a half of its time on the IK's small arrays (20-25 vs 50-65 us, load 10)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


@dataclass(frozen=True)
class KinematicChain:
    """A serial chain of revolute joints between fixed transforms.

    Attributes
    ----------
    names : tuple of str
        The movable joints, root to tip (n of them).
    origins : ndarray, shape (n, 4, 4)
        ``origins[i]`` is the fixed transform from joint ``i-1``'s rotated frame (or the world
        for ``i = 0``) to joint ``i``'s frame, all fixed joints between them folded in.
    axes : ndarray, shape (n, 3)
        Each joint's unit axis in its own frame.
    tip : ndarray, shape (4, 4)
        Fixed transform from the last joint's rotated frame to the tip frame.
    lower, upper : ndarray, shape (n,)
        Joint limits, radians.
    """

    names: tuple[str, ...]
    origins: np.ndarray
    axes: np.ndarray
    tip: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def from_urdf(cls, urdf_text: str, tip_link: str, world_T_root: np.ndarray, base_link: str = "root_link") -> "KinematicChain":
        """Read the chain ``base_link`` -> ``tip_link`` from URDF text.

        ``world_T_root`` (4, 4) places the base link in the world.  Only revolute and fixed
        joints may lie on the path; a continuous joint gets the limits +-2 pi.
        """
        robot = ET.fromstring(urdf_text)
        by_child = {j.find("child").get("link"): j for j in robot.findall("joint")}
        path = []
        link = tip_link
        while link != base_link:
            if link not in by_child:
                raise ValueError(f"link {link!r} is not below {base_link!r} in the URDF")
            joint = by_child[link]
            path.append(joint)
            link = joint.find("parent").get("link")
        path.reverse()
        names, origins, axes, lower, upper = [], [], [], [], []
        pending = np.asarray(world_T_root, dtype=float).copy()
        for joint in path:
            origin = joint.find("origin")
            xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
            pending = pending @ pose(from_rpy(rpy), xyz)
            kind = joint.get("type")
            if kind == "fixed":
                continue
            if kind not in ("revolute", "continuous"):
                raise ValueError(f"joint {joint.get('name')!r} is {kind}; only revolute, continuous and fixed are supported")
            axis_element = joint.find("axis")  # URDF's default axis is (1, 0, 0)
            axis = np.array([float(v) for v in (axis_element.get("xyz") if axis_element is not None else "1 0 0").split()])
            names.append(joint.get("name"))
            origins.append(pending)
            axes.append(axis / np.linalg.norm(axis))
            if kind == "continuous":  # no limits: a whole turn each way (hila_lang.robot.urdf)
                lower.append(-2 * math.pi)
                upper.append(2 * math.pi)
            else:
                limit = joint.find("limit")
                lower.append(float(limit.get("lower")))
                upper.append(float(limit.get("upper")))
            pending = np.eye(4)
        return cls(tuple(names), np.array(origins), np.array(axes), pending, np.array(lower), np.array(upper))

    @property
    def dof(self) -> int:
        return len(self.names)

    def __post_init__(self) -> None:
        # Rodrigues: joint i turned by q is origins[i] @ (I + sin q K + (1 - cos q) K^2), K the
        # cross-product matrix of its axis; its three constant parts are kept, so a posture's
        # frames are one vectorised sum and a 3x3 product per joint (the Jacobian in half the
        # time of building each joint's 4x4 rotation: 209 vs 390 us at load 8)
        rot = self.origins[:, :3, :3]
        k = _skew(self.axes)
        consts = {"_fixed": rot, "_sin": rot @ k, "_cos": rot @ k @ k, "_offset": self.origins[:, :3, 3],
                  "_origin_axes": np.einsum("nij,nj->ni", rot, self.axes) if self.dof else np.zeros((0, 3))}
        # (n, 3, 2): each joint's offset and its axis in its origin's frame, side by side, so
        # :meth:`forward` turns both with one stacked product
        consts["_offset_axes"] = np.stack([consts["_offset"], consts["_origin_axes"]], axis=-1)
        for name, value in consts.items():
            object.__setattr__(self, name, value)

    def _turned(self, qs: np.ndarray) -> np.ndarray:
        """Each joint's fixed rotation times its turn, (..., n, 3, 3), for angles ``qs`` (..., n)."""
        s, c = np.sin(qs)[..., None, None], np.cos(qs)[..., None, None]
        return self._fixed + s * self._sin + (1.0 - c) * self._cos

    def forward(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Forward kinematics.

        Parameters
        ----------
        q : ndarray, shape (n,)
            Joint angles, radians.

        Returns
        -------
        world_T_tip : ndarray, shape (4, 4)
        joint_positions : ndarray, shape (n, 3)
            Each joint's origin, world frame, metres.
        joint_axes : ndarray, shape (n, 3)
            Each joint's unit axis, world frame.
        """
        turned = self._turned(np.asarray(q, dtype=float).reshape(self.dof))
        n = self.dof
        # the rotation up to each joint's origin: the running products turned[0] @ ... @ turned[i],
        # by a prefix scan (4 stacked products for 10 joints instead of 10 single ones, 19 vs 36 us;
        # the products grouped differently: equal to round-off, 2e-16)
        before = np.empty((n + 1, 3, 3))
        before[0] = _EYE3
        before[1:] = turned
        step = 1
        while step < n:
            before[1 + step:] = before[1:-step] @ before[1 + step:]
            step *= 2
        rotation = before[-1]
        if not n:
            world_T_tip = np.eye(4)
            world_T_tip[:3, :3] = self.tip[:3, :3]
            world_T_tip[:3, 3] = self.tip[:3, 3]
            return world_T_tip, np.zeros((0, 3)), np.zeros((0, 3))
        # each joint's offset and axis turned by the rotation before it: one product for both
        both = np.matmul(before[:-1], self._offset_axes)
        positions = np.cumsum(both[:, :, 0], axis=0)
        world_axes = both[:, :, 1].copy()
        world_T_tip = np.eye(4)
        world_T_tip[:3, :3] = rotation @ self.tip[:3, :3]
        world_T_tip[:3, 3] = rotation @ self.tip[:3, 3] + positions[-1]
        return world_T_tip, positions, world_axes

    def tip_position(self, q: np.ndarray) -> np.ndarray:
        """Tip position (3,), world frame, metres."""
        return self.forward(q)[0][:3, 3]

    def tip_positions(self, qs: np.ndarray) -> np.ndarray:
        """Tip positions (K, 3) at each row of ``qs`` (K, n): :meth:`tip_position` for many postures
        at once (one matrix product per joint over all of them; a trajectory's check samples
        thousands)."""
        qs = np.asarray(qs, dtype=float).reshape(-1, self.dof)
        turned = self._turned(qs)
        rot = np.broadcast_to(np.eye(3), (len(qs), 3, 3))
        point = np.zeros((len(qs), 3))
        for i in range(self.dof):
            point = point + rot @ self._offset[i]
            rot = rot @ turned[:, i]
        return point + rot @ self.tip[:3, 3]

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Geometric Jacobian of the tip, shape (6, n): rows 0-2 linear, rows 3-5 angular.

        Returns the Jacobian and the tip pose (4, 4).
        """
        pose, positions, world_axes = self.forward(q)
        a, b = world_axes.T, (pose[:3, 3] - positions).T
        jac = np.empty((6, self.dof))  # rows 0-2: the axes crossed with the arms (as _cross does)
        np.subtract(a[1] * b[2], a[2] * b[1], out=jac[0])
        np.subtract(a[2] * b[0], a[0] * b[2], out=jac[1])
        np.subtract(a[0] * b[1], a[1] * b[0], out=jac[2])
        jac[3:] = a
        return jac, pose


@dataclass(frozen=True)
class IKResult:
    """Outcome of one IK solve.

    ``q`` (n,) radians, ``position`` (3,) the tip reached, ``error`` metres from the target,
    ``tilt`` radians between the pen axis and the wanted one, ``iterations``, ``converged``.
    """

    q: np.ndarray
    position: np.ndarray
    error: float
    tilt: float
    iterations: int
    converged: bool


def solve(
    chain: KinematicChain,
    target: np.ndarray,
    q0: np.ndarray,
    *,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    pen_axis=(0.0, 0.0, -1.0),
    tolerance: float = 1e-5,
    tilt_tolerance: float = 1e-3,
    max_iterations: int = 200,
    damping: float = 0.01,
    max_step: float = 0.3,
    weights: np.ndarray | None = None,
) -> IKResult:
    """Damped least-squares IK: tip at ``target`` (3,), tip +z along ``pen_axis``.

    Parameters
    ----------
    chain : KinematicChain
    target : ndarray, shape (3,)
        Wanted tip position, world frame, metres.
    q0 : ndarray, shape (n,)
        Start (warm start), radians; clamped into the limits first.
    lower, upper : ndarray, shape (n,), optional
        Limits to respect (default: the chain's URDF limits).  Never exceeded.
    pen_axis : array-like, shape (3,)
        Wanted direction of the tip frame's +z, world frame (``None``: position only).
    tolerance : float
        Position residual to stop at, metres.
    tilt_tolerance : float
        Pen-axis residual to stop at, radians.
    weights : ndarray, shape (n,), optional
        Relative willingness of each joint to move (weighted least norm: a joint with weight
        0.3 moves less than one with 1); 0 freezes a joint.  Default all ones.

    Returns
    -------
    IKResult
        The best pose found; ``converged`` says whether both residuals are within tolerance.
    """
    lo = chain.lower if lower is None else np.asarray(lower, dtype=float)
    hi = chain.upper if upper is None else np.asarray(upper, dtype=float)
    target = np.asarray(target, dtype=float)
    want = None if pen_axis is None else np.asarray(pen_axis, dtype=float) / np.linalg.norm(pen_axis)
    q = np.clip(np.asarray(q0, dtype=float), lo, hi)
    w = np.ones(chain.dof) if weights is None else np.asarray(weights, dtype=float)
    rows = 3 if want is None else 6
    ridge = damping**2 * np.eye(rows)
    e = np.empty(rows)
    best = None
    for iteration in range(max_iterations + 1):
        jac, pose = chain.jacobian(q)
        tip = pose[:3, 3]
        pos_err = target - tip
        err = math.sqrt(float(pos_err @ pos_err))  # np.linalg.norm's own arithmetic, without its overhead
        e[:3] = pos_err
        if want is None:
            tilt, jac = 0.0, jac[:3]
        else:
            z0, z1, z2 = pose[0, 2], pose[1, 2], pose[2, 2]
            w0, w1, w2 = want
            # rotation that turns z towards want (|.| = sin angle), as _cross computes it
            r0, r1, r2 = z1 * w2 - z2 * w1, z2 * w0 - z0 * w2, z0 * w1 - z1 * w0
            tilt = math.atan2(math.sqrt(r0 * r0 + r1 * r1 + r2 * r2), z0 * w0 + z1 * w1 + z2 * w2)
            # angular rows projected on the plane normal to z: spinning about the pen is free
            z = pose[:3, 2]
            jac[3:] = ORIENTATION_WEIGHT * ((_EYE3 - np.outer(z, z)) @ jac[3:])
            e[3], e[4], e[5] = ORIENTATION_WEIGHT * r0, ORIENTATION_WEIGHT * r1, ORIENTATION_WEIGHT * r2
        if best is None or err + ORIENTATION_WEIGHT * tilt < best[0]:
            best = (err + ORIENTATION_WEIGHT * tilt, q, tip.copy(), err, tilt, iteration)
        if err <= tolerance and tilt <= tilt_tolerance:
            return IKResult(q, tip.copy(), err, tilt, iteration, True)
        if iteration == max_iterations:
            break
        free = w > 0
        for _ in range(2):  # drop joints pinned at a limit and pushed outwards, then re-solve
            wf = w * free
            dq = wf * (jac.T @ np.linalg.solve((jac * wf) @ jac.T + ridge, e))
            pinned = ((q <= lo + 1e-9) & (dq < 0)) | ((q >= hi - 1e-9) & (dq > 0))
            if not (pinned & free).any():
                break
            free &= ~pinned
        biggest = np.abs(dq).max()
        if biggest > max_step:
            dq *= max_step / biggest
        q = np.clip(q + dq, lo, hi)  # a new array: ``best`` keeps the old one
    _, q_best, pos_best, err_best, tilt_best, it = best
    return IKResult(q_best, pos_best, err_best, tilt_best, it, False)


def aim(
    chain: KinematicChain,
    q0: np.ndarray,
    target: np.ndarray,
    weights: np.ndarray,
    *,
    iterations: int = 50,
    tolerance: float = 1e-4,
) -> tuple[np.ndarray, float]:
    """Turn the tip frame's +z towards ``target`` (3,) (a look-at), moving joints with weight > 0.

    Weighted damped least squares on the angle between +z and the direction to the target;
    joints are clamped to the chain's limits, and (as in :func:`solve`) a joint pinned at a
    limit and pushed further out is dropped from the step, so the others make up for it.
    Returns ``(q, angle)``: the joint angles (n,) and the remaining angle, radians (not zero
    when the limits forbid looking there).
    """
    lo, hi = chain.lower, chain.upper
    q = np.clip(np.asarray(q0, dtype=float), lo, hi)
    w = np.asarray(weights, dtype=float)
    target = np.asarray(target, dtype=float)
    angle = math.pi
    ridge = 1e-4 * np.eye(3)
    for _ in range(iterations):
        pose, _, world_axes = chain.forward(q)
        jac = np.ascontiguousarray(world_axes.T)  # the Jacobian's angular rows: the turn is all an aim needs
        z = pose[:3, 2]
        d = target - pose[:3, 3]
        d /= math.sqrt(float(d @ d))  # np.linalg.norm's own arithmetic, without its overhead
        e = _cross(z, d)
        angle = math.atan2(math.sqrt(float(e @ e)), float(z @ d))
        if angle <= tolerance:
            break
        free = w > 0
        for _ in range(2):  # drop joints pinned at a limit and pushed outwards, then re-solve
            wf = w * free
            dq = wf * (jac.T @ np.linalg.solve((jac * wf) @ jac.T + ridge, e))
            pinned = ((q <= lo + 1e-9) & (dq < 0)) | ((q >= hi - 1e-9) & (dq > 0))
            if not (pinned & free).any():
                break
            free &= ~pinned
        q = np.clip(q + np.clip(dq, -0.3, 0.3), lo, hi)
    return q, angle
