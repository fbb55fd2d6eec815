"""The PyBullet iCub back end: IK, position-controlled execution, ink, eye cameras.

:class:`PyBulletBackend` implements :class:`hila_lang.interfaces.Backend`.  One instance owns
one PyBullet client (``DIRECT`` by default) with the iCub (:mod:`.model`) fixed at its waist
facing +x, a table, and a sheet of paper with the grid printed on it (:mod:`.scene`,
:mod:`.ink`).

Moving (:meth:`PyBulletBackend.move`): the path is prefixed with the current pen-tip position,
densified to waypoints at most 2 mm apart, and every waypoint is solved by IK (:mod:`.ik`),
warm-started from the previous one, over torso + right arm within *comfort limits* (a margin
inside the URDF limits, the torso kept near upright).  Only when every waypoint is solved does
the arm move: joint targets are interpolated along the path's arc length with a trapezoidal speed
profile (drawing 5 cm/s with the pen down, 15 cm/s with it up), sent to PyBullet's position
controllers with realistic force limits at 240 Hz, with the matching joint velocities as feed
forward.  The pen tip is recorded every step and joint limits are checked every step.

Ink: where the pen is down and its tip is within 0.5 mm of the paper (or below), the executed
trace is rasterised into the paper's texture, which is uploaded once per stroke.  The robot has
no collision shapes: contact is decided geometrically, and a target more than 2 mm below the
paper inside the table is refused like any unreachable target.

Frames: world frame, metres, z up; the root is at (0, 0, 0.62) and the robot faces +x.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import HilaRuntimeError, InputError, UnreachableError
from ..validation import check_int, check_path
from . import cameras, ik, model
from .console import import_pybullet, quiet_c_output
from .ink import InkCanvas
from .scene import PAPER_THICKNESS, TABLE_FRONT_X, TABLE_TOP_Z, SceneSpec
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
#: the pen touches the paper when its tip is at most this far above the surface, metres
CONTACT_TOLERANCE = 0.0005
#: an IK solution is accepted within these residuals (metres, radians)
IK_ACCEPT_ERROR = 1e-4
IK_ACCEPT_TILT = 0.01
#: margin kept inside the URDF limits by the IK, radians
LIMIT_MARGIN = 0.02
#: joint-limit check during execution: allowed excess over the URDF limits, radians
LIMIT_CHECK_TOLERANCE = 1e-3
#: torso comfort range for the IK, radians: (pitch, roll, yaw) lower and upper
TORSO_COMFORT = ((-0.10, -0.35, -0.60), (0.60, 0.35, 0.60))
#: relative IK weight of torso joints (they move less than the arm)
TORSO_WEIGHT = 0.3
#: position-controller gains
POSITION_GAIN = 0.3
VELOCITY_GAIN = 1.0
#: seed posture of torso + right arm for the first IK (hand in front, palm down), radians
SEED_POSTURE = np.array([0.10, 0.20, 0.0, -0.55, 0.60, 0.55, 1.30, 0.50, -0.10, 0.0])
#: rest posture of torso + right arm (hand by the side, out of the cameras' way), radians
REST_POSTURE = np.array([0.0, 0.0, 0.0, -0.30, 0.45, 0.0, 0.80, 0.0, 0.0, 0.0])
#: physics solver iterations per step (PyBullet's default 50 costs 60 % more time for a
#: tracking gain of 0.002 mm)
SOLVER_ITERATIONS = 20
#: the hand's ready point above the grid centre, metres
READY_HEIGHT = 0.10
#: table size (depth along x, width along y, thickness), metres
TABLE_SIZE = (0.60, 1.00, 0.03)


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
    joints : ndarray, shape (T', 10)
        Torso + right-arm joint angles at every step, radians, order ``model.ARM_CHAIN``.
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


def make_backend(world, options) -> "PyBulletBackend":
    """Build the back end for ``world`` (uses ``world.scene`` when it has one) and CLI ``options``.

    ``options`` needs ``.gui`` (bool) and ``.seed`` (int); missing attributes mean the defaults.
    """
    scene = getattr(world, "scene", None) or SceneSpec.game()
    return PyBulletBackend(scene, gui=bool(getattr(options, "gui", False)), seed=int(getattr(options, "seed", 0) or 0))


class PyBulletBackend:
    """The iCub drawing on a sheet of paper in PyBullet (see the module docstring).

    Parameters
    ----------
    scene : SceneSpec, optional
        Where the paper and grid are (default :meth:`SceneSpec.game`).  The table top is the
        paper's surface minus the paper's thickness.
    gui : bool
        Open PyBullet's window (needs a display; motion then runs at real speed); headless
        ``DIRECT`` (as fast as it goes) otherwise.
    seed : int
        Seed of :attr:`rng` (random start positions, :meth:`random_start_point`).
    arm : {"auto", "ready", "rest"}
        Starting posture: "ready" holds the pen 0.10 m above the grid centre, "rest" keeps the
        hand by the robot's side, out of the cameras' view (for watching a demonstration);
        "auto" is "rest" for a scene on a table lower than the game table (the demonstrator's)
        or out of reach, else "ready".
    """

    name = "pybullet"

    def __init__(self, scene: SceneSpec | None = None, *, gui: bool = False, seed: int = 0, arm: str = "auto") -> None:
        self.scene = scene or SceneSpec.game()
        if not isinstance(self.scene, SceneSpec):
            raise InputError(f"scene must be a SceneSpec, got {type(self.scene).__name__}")
        if arm not in ("auto", "ready", "rest"):
            raise InputError(f"arm must be 'auto', 'ready' or 'rest', got {arm!r}")
        self._arm_mode = arm
        self._gui = bool(gui)
        self.rng = np.random.default_rng(check_int(seed, "seed"))
        self.traces: list[Trace] = []
        #: counters for benchmarks: IK solves and their wall time, simulation steps and the wall
        #: time of the control loop (stepping, control, recording), renders and their time
        self.stats = dict.fromkeys(("ik_solves", "ik_seconds", "steps", "step_seconds", "renders", "render_seconds"), 0)
        self._pb = import_pybullet()
        self._client = -1
        self._uploads = 0
        self._tmpdir = tempfile.mkdtemp(prefix="hila-robot-")
        try:
            self._connect(gui)
            self._build()
        except BaseException:
            self.close()
            raise

    # -- construction ---------------------------------------------------------------------------
    def _connect(self, gui: bool) -> None:
        pb = self._pb
        if gui:
            if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
                raise InputError(
                    "--gui needs a display, and none is available (DISPLAY is not set)",
                    hint="run without --gui (headless), or with a display or xvfb-run",
                )
            with quiet_c_output():
                self._client = pb.connect(pb.GUI)
        else:
            with quiet_c_output():
                self._client = pb.connect(pb.DIRECT)
        if self._client < 0:
            raise HilaRuntimeError("cannot start the PyBullet simulation" + (" window" if gui else ""))
        pb.setTimeStep(1.0 / SIM_RATE, physicsClientId=self._client)
        pb.setGravity(0, 0, -9.81, physicsClientId=self._client)
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=self._client)

    def _build(self) -> None:
        pb, c = self._pb, self._client
        path = model.urdf_path()
        text = path.read_text()
        orientation = pb.getQuaternionFromEuler([0, 0, model.ROOT_YAW])
        with quiet_c_output():
            self.robot = pb.loadURDF(
                str(path), model.ROOT_POSITION, orientation, useFixedBase=True,
                flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=c,
            )
        world_T_root = ik.transform(ik.rpy_to_matrix((0, 0, model.ROOT_YAW)), model.ROOT_POSITION)
        self.chain = ik.KinematicChain.from_urdf(text, model.PEN_TIP_LINK, world_T_root)
        self._gaze_chain = ik.KinematicChain.from_urdf(text, "eyes_tilt_link", world_T_root)
        if self.chain.names != model.ARM_CHAIN:
            raise HilaRuntimeError(f"unexpected arm chain in the iCub model: {self.chain.names}")
        self._joint = {}
        self._link = {}
        for i in range(pb.getNumJoints(self.robot, physicsClientId=c)):
            info = pb.getJointInfo(self.robot, i, physicsClientId=c)
            self._joint[info[1].decode()] = i
            self._link[info[12].decode()] = i
        self._arm = [self._joint[n] for n in model.ARM_CHAIN]
        self._forces = [model.FORCE_LIMITS[n] for n in model.ARM_CHAIN]
        lo, hi = self.chain.lower + LIMIT_MARGIN, self.chain.upper - LIMIT_MARGIN
        lo[:3] = np.maximum(lo[:3], TORSO_COMFORT[0])
        hi[:3] = np.minimum(hi[:3], TORSO_COMFORT[1])
        self.ik_lower, self.ik_upper = lo, hi
        self._weights = np.array([TORSO_WEIGHT] * 3 + [1.0] * 7)
        self._held = {}
        for name, index in self._joint.items():
            if name in model.ARM_CHAIN:
                continue
            info = pb.getJointInfo(self.robot, index, physicsClientId=c)
            if info[2] == pb.JOINT_REVOLUTE:
                self._held[name] = 0.0  # neck and eyes; legs and left arm are frozen in the URDF
        for name, value in self._held.items():
            pb.resetJointState(self.robot, self._joint[name], value, physicsClientId=c)
        self._build_table_and_paper()
        # the ready posture: hand above the grid centre, pen vertical; rest when not reachable
        above = self.scene.grid_to_world(0.0, 0.0) + np.array([0.0, 0.0, READY_HEIGHT])
        ready = ik.solve(self.chain, above, SEED_POSTURE, lower=lo, upper=hi, weights=self._weights)
        self.rest_posture = np.clip(REST_POSTURE, lo, hi)
        self.ready_posture = ready.q if ready.converged else self.rest_posture
        low_table = self.scene.surface_z < TABLE_TOP_Z - 0.05
        rest = self._arm_mode == "rest" or (self._arm_mode == "auto" and (low_table or not ready.converged))
        self._set_arm(self.rest_posture if rest else self.ready_posture)
        self._gaze_target = self.scene.grid_to_world(0.0, 0.0)
        self.look_at(self._gaze_target)

    def _build_table_and_paper(self) -> None:
        pb, c = self._pb, self._client
        top = self.scene.surface_z - PAPER_THICKNESS
        depth, width, thick = TABLE_SIZE
        center = [TABLE_FRONT_X + depth / 2, -0.05, top - thick / 2]
        half = [depth / 2, width / 2, thick / 2]
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=[0.55, 0.40, 0.25, 1], physicsClientId=c)
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=c)
        self.table = pb.createMultiBody(0, col, vis, center, physicsClientId=c)
        leg_h = max(top - thick, 0.02)
        leg_half = [0.02, 0.02, leg_h / 2]
        leg_vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=leg_half, rgbaColor=[0.35, 0.25, 0.15, 1], physicsClientId=c)
        for dx in (-1, 1):
            for dy in (-1, 1):
                pos = [center[0] + dx * (depth / 2 - 0.04), center[1] + dy * (width / 2 - 0.04), leg_h / 2]
                pb.createMultiBody(0, -1, leg_vis, pos, physicsClientId=c)
        floor = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[2, 2, 0.005], rgbaColor=[0.75, 0.75, 0.78, 1], physicsClientId=c)
        pb.createMultiBody(0, -1, floor, [0, 0, -0.005], physicsClientId=c)
        # the paper: a textured quad on the table, the texture's first row along the far edge
        self.canvas = InkCanvas(self.scene)
        corners = self.scene.paper_corners()  # tl, tr, br, bl
        corners[:, 2] = self.scene.surface_z
        self.paper = self._textured_quad(corners, self.canvas.image)

    def _textured_quad(self, corners: np.ndarray, image: np.ndarray) -> int:
        """A visual-only body: quad through ``corners`` (4, 3) tl, tr, br, bl with ``image`` on it."""
        pb, c = self._pb, self._client
        normal = np.cross(corners[1] - corners[0], corners[3] - corners[0])
        normal = (normal / np.linalg.norm(normal)).tolist()
        vis = pb.createVisualShape(
            pb.GEOM_MESH,
            vertices=corners.tolist(),
            indices=[0, 2, 1, 0, 3, 2, 0, 1, 2, 0, 2, 3],
            uvs=[[0, 1], [1, 1], [1, 0], [0, 0]],  # PyBullet's v runs up the image
            normals=[normal] * 4,
            physicsClientId=c,
        )
        body = pb.createMultiBody(0, -1, vis, [0, 0, 0], physicsClientId=c)
        self._upload_texture(body, image)
        return body

    def _upload_texture(self, body: int, image: np.ndarray) -> None:
        import cv2

        pb, c = self._pb, self._client
        # PyBullet caches textures by file name: every upload needs a new one
        self._uploads += 1
        png = os.path.join(self._tmpdir, f"texture_{body}_{self._uploads}.png")
        if not cv2.imwrite(png, np.ascontiguousarray(image[:, :, ::-1])):
            raise HilaRuntimeError(f"cannot write a texture to {png}")
        with quiet_c_output():
            texture = pb.loadTexture(png, physicsClientId=c)
        pb.changeVisualShape(body, -1, textureUniqueId=texture, rgbaColor=[1, 1, 1, 1], physicsClientId=c)

    # -- state ----------------------------------------------------------------------------------
    @property
    def client(self) -> int:
        """The PyBullet physics client id."""
        return self._client

    def joint_positions(self) -> np.ndarray:
        """Torso + right-arm joint angles (10,), radians, order ``model.ARM_CHAIN``."""
        states = self._pb.getJointStates(self.robot, self._arm, physicsClientId=self._client)
        return np.array([s[0] for s in states])

    def _tip_now(self) -> np.ndarray:
        # PyBullet's own forward kinematics (agrees with self.chain to 1e-8 m, 25x faster)
        state = self._pb.getLinkState(
            self.robot, self._link[model.PEN_TIP_LINK], computeForwardKinematics=True, physicsClientId=self._client
        )
        return np.array(state[4])

    def hand_position(self) -> np.ndarray:
        """The pen tip, shape (3,), world frame, metres."""
        return self.chain.tip_position(self.joint_positions())

    def _set_arm(self, q: np.ndarray) -> None:
        """Teleport torso + arm to ``q`` and make the controllers hold it (and every held joint)."""
        pb, c = self._pb, self._client
        for index, value in zip(self._arm, q):
            pb.resetJointState(self.robot, index, float(value), 0.0, physicsClientId=c)
        self._command(q, np.zeros(len(q)))
        self._hold_head()

    def _hold_head(self) -> None:
        """Position-control the neck and eyes at their held angles."""
        held = [self._joint[n] for n in self._held]
        self._pb.setJointMotorControlArray(
            self.robot, held, self._pb.POSITION_CONTROL, targetPositions=list(self._held.values()),
            forces=[model.HOLD_FORCE] * len(held), physicsClientId=self._client,
        )

    def _command(self, q: np.ndarray, qd: np.ndarray) -> None:
        pb = self._pb
        pb.setJointMotorControlArray(
            self.robot, self._arm, pb.POSITION_CONTROL,
            targetPositions=q.tolist(), targetVelocities=qd.tolist(), forces=self._forces,
            positionGains=[POSITION_GAIN] * len(q), velocityGains=[VELOCITY_GAIN] * len(q),
            physicsClientId=self._client,
        )

    # -- moving ---------------------------------------------------------------------------------
    def reset_hand(self, point: np.ndarray) -> np.ndarray:
        """Put the pen tip at ``point`` (3,) at once (no motion, no ink, no trace).

        Used to park the arm at a start position.  Returns the joint angles (10,).
        Raises :class:`UnreachableError` when the point cannot be reached.
        """
        target = _check_point(point, "point")
        self._check_above_table(target, 0, 1, "reset_hand")
        result = self._solve(target, self.joint_positions())
        if not result.converged:
            result = min((result, self._solve(target, self.ready_posture)), key=lambda r: r.error)
        self._raise_if_unreachable(result, target, 0, 1, "reset_hand")
        self._set_arm(result.q)
        return result.q

    def random_start_point(self, height=(0.08, 0.15)) -> np.ndarray:
        """A random point (3,) above the grid (within the grid's square, ``height`` metres above
        the paper), drawn from :attr:`rng`: where Experiment B parks the arm."""
        half = self.scene.grid_size / 2
        right, far = self.rng.uniform(-half, half, size=2)
        return self.scene.grid_to_world(right, far) + np.array([0.0, 0.0, self.rng.uniform(*height)])

    def move(self, path: np.ndarray, *, pen_down: bool = False, label: str = "") -> np.ndarray:
        """Follow ``path`` (T, 3) from where the pen is; return the executed pen-tip trace (T', 3).

        See the module docstring for timing, control and ink.  Raises
        :class:`UnreachableError` (the arm does not move) when a waypoint cannot be reached,
        :class:`InputError` for a malformed path and :class:`HilaRuntimeError` if a joint
        leaves its limits during execution.
        """
        planned = _check_path(path)
        for k, point in enumerate(planned):
            self._check_above_table(point, k, len(planned), label)
        q_start = self.joint_positions()
        start = self.chain.tip_position(q_start)
        points = np.vstack([start, planned])
        dense, origin_index, arc = densify(points, WAYPOINT_SPACING)
        qs = np.empty((len(dense), self.chain.dof))
        qs[0] = q_start
        clock = time.perf_counter()
        for i in range(1, len(dense)):
            result = self._solve(dense[i], qs[i - 1])
            if not result.converged:
                # dense[i] lies on the way to waypoint k: report how near to *it* the pen gets
                k = int(origin_index[i])
                last = self.chain.tip_position(qs[i - 1])
                if np.linalg.norm(last - planned[k]) < np.linalg.norm(result.position - planned[k]):
                    result = ik.IKResult(qs[i - 1], last, result.error, result.tilt, result.iterations, False)
                self._raise_if_unreachable(result, planned[k], k, len(planned), label)
            qs[i] = result.q
        self.stats["ik_solves"] += len(dense) - 1
        self.stats["ik_seconds"] += time.perf_counter() - clock
        speed = DRAW_SPEED if pen_down else TRAVEL_SPEED
        clock = time.perf_counter()
        executed, joints, reference = self._execute(qs, dense, arc, speed)
        self.stats["steps"] += len(executed)
        self.stats["step_seconds"] += time.perf_counter() - clock
        inked = self._ink(executed) if pen_down else 0
        self.traces.append(Trace(label, bool(pen_down), planned, executed, joints, reference, inked))
        return executed

    def _solve(self, target: np.ndarray, q0: np.ndarray) -> ik.IKResult:
        result = ik.solve(
            self.chain, target, q0, lower=self.ik_lower, upper=self.ik_upper, weights=self._weights,
        )
        converged = result.error <= IK_ACCEPT_ERROR and result.tilt <= IK_ACCEPT_TILT
        if converged != result.converged:
            result = ik.IKResult(result.q, result.position, result.error, result.tilt, result.iterations, converged)
        return result

    def _check_above_table(self, point: np.ndarray, k: int, total: int, label: str) -> None:
        on_table = TABLE_FRONT_X <= point[0] <= TABLE_FRONT_X + TABLE_SIZE[0]
        if on_table and point[2] < self.scene.surface_z - 0.002:
            raise UnreachableError(
                f"cannot reach {_fmt(point)} m (waypoint {k + 1} of {total}): it is "
                f"{(self.scene.surface_z - point[2]) * 1000:.1f} mm below the paper; the arm did not move",
                state=label or None,
            )

    def _raise_if_unreachable(self, result: ik.IKResult, point, k: int, total: int, label: str) -> None:
        if result.converged:
            return
        tilt = f", pen tilted {math.degrees(result.tilt):.1f} deg" if result.tilt > IK_ACCEPT_TILT else ""
        distance = np.linalg.norm(result.position - np.asarray(point, dtype=float))
        raise UnreachableError(
            f"cannot reach {_fmt(point)} m (waypoint {k + 1} of {total}): the pen gets no closer "
            f"than {distance * 1000:.1f} mm, to {_fmt(result.position)}{tilt}; the arm did not move",
            state=label or None,
            hint="targets must be above the table, in front of the robot (x 0.20-0.45 m, "
            "y -0.30-0.10 m works at table height)",
        )

    def _execute(self, qs: np.ndarray, dense: np.ndarray, arc: np.ndarray, speed: float):
        """Run the joint path ``qs`` (M, 10) through ``dense`` (M, 3) at arc lengths ``arc`` (M,)."""
        pb, c = self._pb, self._client
        dt = 1.0 / SIM_RATE
        times = trapezoid_profile(arc[-1], speed, ACCELERATION, dt)
        executed, joints, reference = [], [], []
        final = dense[-1]
        slopes = np.zeros_like(qs)
        if len(arc) > 1:
            ds = np.diff(arc)
            slopes[:-1] = np.diff(qs, axis=0) / np.where(ds > 0, ds, 1.0)[:, None]
            slopes[-1] = slopes[-2]
        lower, upper = self.chain.lower - LIMIT_CHECK_TOLERANCE, self.chain.upper + LIMIT_CHECK_TOLERANCE

        started = time.perf_counter()

        def step(q_target, qd_target, point):
            reference.append(point)
            self._command(q_target, qd_target)
            pb.stepSimulation(physicsClientId=c)
            if self._gui:  # a window shows the motion at its real speed
                ahead = len(reference) * dt - (time.perf_counter() - started)
                if ahead > 0:
                    time.sleep(ahead)
            q = self.joint_positions()
            if np.any(q < lower) or np.any(q > upper):
                bad = int(np.argmax(np.maximum(lower - q, q - upper)))
                raise HilaRuntimeError(
                    f"joint {model.ARM_CHAIN[bad]} left its limits during a move "
                    f"({q[bad]:.3f} rad, limits {self.chain.lower[bad]:.3f}..{self.chain.upper[bad]:.3f})"
                )
            joints.append(q)
            executed.append(self._tip_now())

        def along(s):
            i = min(int(np.searchsorted(arc, s, side="right")) - 1, len(arc) - 2)
            frac = (s - arc[i]) / max(arc[i + 1] - arc[i], 1e-12)
            return i, qs[i] + frac * (qs[i + 1] - qs[i]), dense[i] + frac * (dense[i + 1] - dense[i])

        # PyBullet's position motor ends a step at (target + dt * target velocity): aim at the
        # previous sample's position with this sample's velocity to be at this sample's point
        previous = 0.0
        for s, v in times:
            if len(arc) > 1:
                i, _, point = along(s)
                _, q_target, _ = along(previous)
                step(q_target, slopes[i] * v, point)
            else:
                step(qs[0], np.zeros(self.chain.dof), dense[0])
            previous = s
        # settle: hold the last target until the tip is within 0.05 mm (at most 0.25 s)
        for _ in range(int(0.25 * SIM_RATE)):
            if executed and np.linalg.norm(executed[-1] - final) < 5e-5:
                break
            step(qs[-1], np.zeros(self.chain.dof), final)
        return (
            np.array(executed).reshape(-1, 3),
            np.array(joints).reshape(-1, self.chain.dof),
            np.array(reference).reshape(-1, 3),
        )

    # -- ink --------------------------------------------------------------------------------------
    def _touching(self, points: np.ndarray) -> np.ndarray:
        """Boolean (N,): which points (N, 3) are on the paper (tip at or below its surface + tol)."""
        grid = self.scene.world_to_grid(points)
        across, depth = self.scene.paper_size
        inside = (np.abs(grid[:, 0]) <= across / 2) & (np.abs(grid[:, 1]) <= depth / 2)
        return inside & (points[:, 2] <= self.scene.surface_z + CONTACT_TOLERANCE)

    def _ink(self, executed: np.ndarray, color="robot") -> int:
        touching = self._touching(executed)
        if not touching.any():
            return 0
        edges = np.flatnonzero(np.diff(np.concatenate([[0], touching.astype(int), [0]])))
        for start, stop in zip(edges[::2], edges[1::2]):
            self.canvas.draw_polyline(executed[start:stop], color=color)
        self._upload_texture(self.paper, self.canvas.image)
        return int(touching.sum())

    def ink_polyline(self, points: np.ndarray, color="opponent") -> None:
        """Draw a stroke through ``points`` (N, 3) (or (N, 2)) on the paper without the robot.

        For the opponent's crosses.  ``color`` is an RGB triple or a name in
        :data:`hila_lang.robot.ink.INK_RGB`.  The texture is uploaded once.
        """
        self.canvas.draw_polyline(check_path(points, "points"), color=color)
        self._upload_texture(self.paper, self.canvas.image)

    def ink_image(self) -> np.ndarray:
        """A copy of the paper texture (H, W, 3) uint8 RGB; row 0 = far edge (see :mod:`.ink`)."""
        return self.canvas.image.copy()

    # -- cameras ----------------------------------------------------------------------------------
    def look_at(self, point: np.ndarray) -> float:
        """Aim the head (neck pitch/yaw, then eyes tilt) at ``point`` (3,); returns the angle
        (radians) still missing when the joints' limits stop it.  Cameras keep looking there.

        The aim starts from the head straight ahead (whatever it looked at before) and is set
        exactly, so the head's angles depend only on the torso and ``point``."""
        pb, c = self._pb, self._client
        target = _check_point(point, "point")
        names = self._gaze_chain.names
        q0 = np.array([
            pb.getJointState(self.robot, self._joint[n], physicsClientId=c)[0] if n in model.ARM_CHAIN else 0.0
            for n in names
        ])
        weights = np.array([{"neck_pitch": 1.0, "neck_yaw": 1.0, model.EYES_TILT_JOINT: 0.3}.get(n, 0.0) for n in names])
        q, angle = ik.aim(self._gaze_chain, q0, target, weights)
        for name, value in zip(names, q):
            if name in self._held:
                self._held[name] = float(value)
                pb.resetJointState(self.robot, self._joint[name], float(value), 0.0, physicsClientId=c)
        self._hold_head()
        self._gaze_target = target
        return angle

    def camera_pose(self, eye: str = "left") -> np.ndarray:
        """``world_T_camera`` (4, 4) of an eye camera (OpenCV convention, see :mod:`.cameras`)."""
        if eye not in model.EYE_LINKS:
            raise InputError(f"eye must be 'left' or 'right', got {eye!r}")
        state = self._pb.getLinkState(
            self.robot, self._link[model.EYE_LINKS[eye]], computeForwardKinematics=True, physicsClientId=self._client
        )
        pose = np.eye(4)
        pose[:3, :3] = np.array(self._pb.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        pose[:3, 3] = state[4]
        return pose

    def camera_image(self, eye: str = "left", *, shadow: bool = False) -> cameras.CameraImage:
        """The ``eye`` camera's image (240, 320, 3) with its intrinsics and pose.

        The head first re-aims at the gaze target (the grid centre unless :meth:`look_at` was
        called), since the torso may have moved.
        """
        if eye not in model.EYE_LINKS:
            raise InputError(f"eye must be 'left' or 'right', got {eye!r}")
        self.look_at(self._gaze_target)
        return self._render(cameras.ICUB_EYE_K, self.camera_pose(eye), cameras.EYE_WIDTH, cameras.EYE_HEIGHT, shadow)

    def _render(self, K, pose, width, height, shadow=False) -> cameras.CameraImage:
        clock = time.perf_counter()
        image = cameras.render(self._client, K, pose, width, height, shadow=shadow)
        self.stats["renders"] += 1
        self.stats["render_seconds"] += time.perf_counter() - clock
        return image

    def top_view_image(self, size_px: int = 480, *, height: float = 1.0) -> cameras.CameraImage:
        """A square image from a pinhole camera ``height`` metres above the grid centre looking
        straight down: image up is the board's far side, image right the robot's right (the
        board as the robot sees it, cell 1 top-left).  The whole sheet is in view."""
        if isinstance(size_px, bool) or not isinstance(size_px, (int, np.integer)) or not 16 <= size_px <= 4096:
            raise InputError(f"size_px must be an integer in 16..4096, got {size_px!r}")
        right, far = self.scene.axes()
        pose = np.eye(4)
        pose[:3, :3] = np.column_stack([right, -far, [0.0, 0.0, -1.0]])
        pose[:3, 3] = self.scene.grid_to_world(0.0, 0.0) + np.array([0.0, 0.0, height])
        extent = float(np.hypot(*self.scene.paper_size)) * 1.05
        f = size_px * height / extent
        K = np.array([[f, 0.0, (size_px - 1) / 2], [0.0, f, (size_px - 1) / 2], [0.0, 0.0, 1.0]])
        return self._render(K, pose, size_px, size_px)

    # -- visual helpers -------------------------------------------------------------------------
    def add_marker(self, radius: float = 0.01, rgba=(1.0, 0.1, 0.1, 1.0)) -> int:
        """A visual-only sphere (no physics), e.g. a demonstrator's hand marker; returns a handle."""
        if not (isinstance(radius, (int, float)) and radius > 0):
            raise InputError(f"radius must be a positive number of metres, got {radius!r}")
        pb, c = self._pb, self._client
        vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=float(radius), rgbaColor=list(rgba), physicsClientId=c)
        return pb.createMultiBody(0, -1, vis, [0, 0, -1], physicsClientId=c)

    def set_marker(self, handle: int, point: np.ndarray) -> None:
        """Move a marker (or any body from the helpers) to ``point`` (3,), world, metres."""
        target = _check_point(point, "point")
        self._pb.resetBasePositionAndOrientation(handle, target.tolist(), [0, 0, 0, 1], physicsClientId=self._client)

    def show_points(self, points: np.ndarray, rgba=(0.1, 0.8, 0.1, 1.0), radius: float = 0.002) -> list[int]:
        """Small visual spheres at ``points`` (N, 3); returns their handles (see :meth:`remove`)."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
            raise InputError(f"expected points of shape (N, 3), finite, got {pts.shape}")
        handles = []
        for point in pts:
            handle = self.add_marker(radius, rgba)
            self.set_marker(handle, point)
            handles.append(handle)
        return handles

    def show_texture_quad(self, image: np.ndarray, world_T_quad: np.ndarray, size) -> int:
        """A visual-only quad carrying ``image`` (H, W, 3) uint8 RGB, e.g. a calibration chessboard.

        The quad is centred on ``world_T_quad``'s origin (4, 4) in its x-y plane, ``size`` =
        (width along x, height along y) metres; the image's columns run along +x and its rows
        along -y (upright when seen from +z with +y up).  Returns a handle for :meth:`remove`.
        """
        img = np.asarray(image)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise InputError(f"expected an RGB uint8 image (H, W, 3), got {img.dtype} {img.shape}")
        pose = np.asarray(world_T_quad, dtype=float)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise InputError(f"expected world_T_quad of shape (4, 4), got {pose.shape}")
        w, h = (float(v) for v in size)
        local = np.array([[-w / 2, h / 2, 0], [w / 2, h / 2, 0], [w / 2, -h / 2, 0], [-w / 2, -h / 2, 0]])
        corners = local @ pose[:3, :3].T + pose[:3, 3]
        return self._textured_quad(corners, img)

    def remove(self, handle: int) -> None:
        """Remove a body made by a helper (marker, points, quad)."""
        self._pb.removeBody(handle, physicsClientId=self._client)

    # -- lifetime ---------------------------------------------------------------------------------
    def close(self) -> None:
        """Disconnect the PyBullet client and delete temporary textures (idempotent)."""
        if self._client >= 0:
            try:
                self._pb.disconnect(physicsClientId=self._client)
            except Exception:  # already gone  # noqa: BLE001
                pass
            self._client = -1
        if self._tmpdir:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = ""

    def __enter__(self) -> "PyBulletBackend":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:  # pragma: no cover - best effort
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass


# -- helpers --------------------------------------------------------------------------------------
def _fmt(point) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in np.asarray(point, dtype=float)) + ")"


def _check_point(point, what: str) -> np.ndarray:
    try:
        arr = np.asarray(point, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {what} of shape (3,), got {point!r}") from None
    if arr.shape != (3,):
        raise InputError(f"expected {what} of shape (3,), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{what} must be finite, got {arr}")
    return arr


def _check_path(path) -> np.ndarray:
    try:
        arr = np.asarray(path, dtype=float)
    except (TypeError, ValueError):
        raise InputError("expected a path of shape (T, 3) of numbers") from None
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 1:
        raise InputError(f"expected a path of shape (T, 3) with T >= 1, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("the path contains NaN or infinite values")
    return arr
