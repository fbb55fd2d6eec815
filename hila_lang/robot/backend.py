"""The PyBullet back end: a thin façade over the scene, the robot's arm, its eyes and the paper.

:class:`PyBulletBackend` implements :class:`hila_lang.plugins.protocols.Backend`.  One instance
owns one :class:`~hila_lang.sim.scene.SimScene` (a PyBullet client, ``DIRECT`` by default) with

- the robot of the run's spec (``--robot``, :mod:`.spec`; default the iCub fixed at its waist
  facing +x) (:class:`~hila_lang.robot.body.Body`),
- a table and the paper the world asks for (:class:`~hila_lang.robot.paper.Paper`, the ``ink``
  capability), with a camera above it (``overview``),
- the arm controller (:class:`~hila_lang.robot.arm.Arm`: IK along a path, the 240 Hz loop),
- the eye cameras (the ``eyes`` capability: fish-eye lenses, the robot's own calibration,
  optional sensor noise): the iCub's in its head (:class:`~hila_lang.robot.eyes.Eyes`, poses
  from the joint angles) or a stereo rig on a stand (:class:`~hila_lang.robot.rig.RigEyes`),
- the scene's light (:class:`~hila_lang.sim.scene.Lights`, the ``lighting`` capability: a
  world may change it during a run),
- the ``streaming`` capability (:class:`~hila_lang.robot.streaming.ArmStream`: a path whose tail
  changes while the arm moves, retargeted inside the 240 Hz loop; the ``track`` clause),
- snapshots for the REPL's ``back`` (:class:`SimSnapshots`: PyBullet's ``saveState`` /
  ``restoreState`` plus what PyBullet does not save: the ink, the paper's pose, the held head
  joints, the gaze target, the light, the eyes' noise generator, the list of executed moves).

:meth:`PyBulletBackend.move` asks the arm to follow a path and inks where the pen touched.

Frames: world frame, metres, z up (hila's table, :mod:`.workspace`); the robot faces +x.
"""

from __future__ import annotations

import time
from contextlib import contextmanager

import numpy as np

from ..core.bounded import BoundedLog
from ..core.errors import InputError
from ..core.validation import check_path
from ..sim.camera import RenderStyle
from ..sim.scene import check_point, Lights, SimScene
from ..sim.surface import Surface
from . import model
from .arm import Arm, SIM_RATE, SOLVER_ITERATIONS, Trace
from .body import Body
from .paper import Paper, TopView
from .rig import RigEyes
from .window import robot_points, Window
from .workspace import PAPER_THICKNESS, READY_HEIGHT, TABLE_FRONT_X, TABLE_SIZE, TABLE_TOP_Z

#: moves kept in :attr:`PyBulletBackend.traces` (a 4 s move at 240 Hz is about 100 kB)
KEEP_TRACES = 1000

#: lighting of the robot's scene (its eye images)
EYE_LIGHT = RenderStyle()

__all__ = ["PyBulletBackend", "Trace", "make_backend"]


def make_backend(scene, options, settings) -> "PyBulletBackend":
    """Plug-in factory: the world's ``scene.surface`` (default the robot's sheet,
    :meth:`.spec.RobotSpec.default_surface`), the robot (``options.robot``, a
    :class:`~.spec.RobotSpec`; None: the iCub), ``options.gui`` and its pace (``--speed N``), and
    the eyes' sensor noise (``--set eyes.noise=SIGMA``, seeded by ``options.seed``)."""
    surface = None if scene is None else scene.surface
    return PyBulletBackend(surface, gui=options.gui, eye_noise=float(settings.get("eyes.noise") or 0.0),
                           seed=int(options.seed), speed=float(settings.get("speed") or 1.0),
                           robot=getattr(options, "robot", None))


class PyBulletBackend:
    """A robot drawing on a sheet of paper in PyBullet (see the module docstring).

    Parameters
    ----------
    surface : Surface, optional
        The paper (its pose, size and what is printed on it); default: a blank A4 sheet
        (:func:`hila_lang.robot.workspace.default_surface`).  The table top is the paper's
        surface minus the paper's thickness.
    gui : bool
        Open PyBullet's window (needs a display; motion then runs at real speed); headless
        ``DIRECT`` (as fast as it goes) otherwise.
    arm : {"auto", "ready", "rest"}
        Starting posture: "ready" holds the pen 0.10 m above the paper's centre, "rest" keeps
        the hand by the robot's side, out of the cameras' view (for watching a demonstration);
        "auto" is "rest" for a paper on a table lower than the robot's (the demonstrator's) or
        out of reach, else "ready".
    eye_noise : float
        Standard deviation of the eye cameras' sensor noise, grey levels (0: none).
    seed : int
        Seed of the sensor noise.
    robot : RobotSpec, optional
        The robot (:mod:`.spec`); default the iCub.

    Attributes
    ----------
    sim : SimScene
    body : Body
    arm : Arm
    eyes : Eyes or RigEyes or None
        None for a robot whose spec gives it no eyes.
    ink : Paper
    overview : TopView
    lighting : Lights
    snapshots : SimSnapshots
    streaming : ArmStream
    view : Window or None
        The window (``gui``): framed, paths drawn, the state written, the left eye's image.
    traces : BoundedLog of Trace
        Every executed move; the newest :data:`KEEP_TRACES` kept.
    stats : dict
        Counters for benchmarks: IK solves and their wall time, simulation steps and the wall
        time of the control loop, renders and their time.
    """

    name = "pybullet"

    def __init__(self, surface: Surface | None = None, *, gui: bool = False, arm: str = "auto",
                 eye_noise: float = 0.0, seed: int = 0, speed: float = 1.0, robot=None) -> None:
        if robot is None:
            # lazy: only this branch needs it
            from .model import spec as icub

            robot = icub()
        self.robot = robot
        self.surface = surface if surface is not None else robot.default_surface()
        if not isinstance(self.surface, Surface):
            raise InputError(f"surface must be a Surface, got {type(self.surface).__name__}")
        if arm not in ("auto", "ready", "rest"):
            raise InputError(f"arm must be 'auto', 'ready' or 'rest', got {arm!r}")
        self.traces: BoundedLog = BoundedLog(KEEP_TRACES)  # the newest kept: memory stays flat
        self.stats = dict.fromkeys(("ik_solves", "ik_seconds", "steps", "step_seconds", "renders", "render_seconds"), 0)
        self.sim = SimScene(gui=gui, time_step=1.0 / SIM_RATE, solver_iterations=SOLVER_ITERATIONS, style=EYE_LIGHT)
        try:
            if gui:  # framed from the first frame: before the robot loads and the eyes calibrate
                # lazy: only this branch needs it
                from .window import frame, robot_points

                frame(self.sim, self.surface, robot_points(self.surface, robot), drawing=False)  # drawn again once the window is made
            self.body = Body(self.sim, robot)
            self.sim.cull(self.body.id)  # its links out of view are not drawn (the same images, faster)
            self._build_table(self.surface.z - PAPER_THICKNESS)
            self.ink = Paper(self.sim, self.surface)
            self.overview = TopView(self.ink, self._render, self._arm_aside)
            # with a window the motion is paced: real time, or --speed N times it
            self.arm = Arm(self.body, self.surface.z, self.stats, realtime=float(speed) if gui else 0.0)
            centre = self.surface.to_world(0.0, 0.0)
            reachable = self.arm.ready_at(centre + np.array([0.0, 0.0, READY_HEIGHT]))
            low_table = self.surface.z < TABLE_TOP_Z - 0.05
            rest = arm == "rest" or (arm == "auto" and (low_table or not reachable))
            self.body.set_arm(self.arm.rest_posture if rest else self.arm.ready_posture)
            self.eyes = self._make_eyes(centre, eye_noise, seed)
            self.lighting = Lights(self.sim)
            self.snapshots = SimSnapshots(self)
            # lazy: only this branch needs it
            from .streaming import ArmStream

            self.streaming = ArmStream(self)
            self.view = self._open_window() if gui else None
        except BaseException:
            self.close()
            raise

    def _make_eyes(self, centre, noise: float, seed: int):
        """The robot's eyes: in its head (the iCub), on a stand (a rig), or none."""
        if self.robot.eyes == "head":
            # lazy: only this branch needs it
            from .eyes import Eyes

            return Eyes(self.body, centre, self._render, noise=noise, seed=seed)
        if self.robot.eyes is None:
            return None

        return RigEyes(self.body, self.robot.eyes, centre, self._render, self.sim, noise=noise, seed=seed)

    def _open_window(self):
        """The ``view``: PyBullet's window framed on the robot and the paper (:mod:`.window`)."""
        window = Window(self.sim, self.surface, robot_points(self.surface, self.robot))  # framed as when the window opened
        self.arm.observer = window.executed_point
        return window

    @contextmanager
    def _arm_aside(self):
        """The arm at its rest posture (by the robot's side, out of the paper's view) for a
        picture from outside the robot; the simulator's state (joint angles and velocities) is
        put back after, so the run goes on as if nothing happened."""
        pb, c = self.sim.pb, self.sim.client
        saved = pb.saveState(physicsClientId=c)
        try:
            for index, value in zip(self.body.arm_joints, self.arm.rest_posture):
                pb.resetJointState(self.body.id, index, float(value), 0.0, physicsClientId=c)
            yield
        finally:
            pb.restoreState(stateId=saved, physicsClientId=c)
            pb.removeState(saved, physicsClientId=c)

    def _render(self, camera, *, shadow: bool = False) -> np.ndarray:
        """An image of ``camera`` in the scene, counted in :attr:`stats`."""
        clock = time.perf_counter()
        rgb = self.sim.render(camera, shadow=shadow)
        self.stats["renders"] += 1
        self.stats["render_seconds"] += time.perf_counter() - clock
        return rgb

    def _build_table(self, top: float) -> None:
        depth, width, thick = TABLE_SIZE
        center = [TABLE_FRONT_X + depth / 2, -0.05, top - thick / 2]
        self.table = self.sim.add_box([depth / 2, width / 2, thick / 2], center, [0.55, 0.40, 0.25, 1], collision=True)
        leg_h = max(top - thick, 0.02)
        for dx in (-1, 1):
            for dy in (-1, 1):
                pos = [center[0] + dx * (depth / 2 - 0.04), center[1] + dy * (width / 2 - 0.04), leg_h / 2]
                self.sim.add_box([0.02, 0.02, leg_h / 2], pos, [0.35, 0.25, 0.15, 1])
        self.sim.add_box([2, 2, 0.005], [0, 0, -0.005], [0.75, 0.75, 0.78, 1])
        base = self.robot.base_position
        if self.robot.pedestal and base[2] > 0.02:  # an arm on a stand: a grey column under its base
            self.sim.add_box([0.09, 0.09, base[2] / 2], [base[0], base[1], base[2] / 2], [0.42, 0.42, 0.45, 1])

    # -- Backend --------------------------------------------------------------------------------
    def hand_position(self) -> np.ndarray:
        """The pen tip, shape (3,), world frame, metres."""
        return self.arm.hand_position()

    def reset_hand(self, point: np.ndarray) -> np.ndarray:
        """Put the pen tip at ``point`` (3,) at once (no motion, no ink, no trace).

        Used to park the arm at a start position.  Returns the joint angles (n,).
        Raises :class:`UnreachableError` when the point cannot be reached.
        """
        return self.arm.reset_hand(check_point(point))

    def move(self, path: np.ndarray, *, pen_down: bool = False, label: str = "") -> np.ndarray:
        """Follow ``path`` (T, 3) from where the pen is; return the executed pen-tip trace (T', 3).

        See :mod:`.arm` for timing and control and :mod:`.paper` for ink.  Raises
        :class:`UnreachableError` (the arm does not move) when a waypoint cannot be reached,
        :class:`InputError` for a malformed path and :class:`HilaRuntimeError` if a joint
        leaves its limits during execution.
        """
        planned = check_path(path, "path")
        if planned.shape[1] != 3:
            raise InputError(f"expected a path of shape (T, 3) with T >= 1, got {planned.shape}")
        if self.view is not None:
            self.view.planned(planned)
        trace = self.arm.move(planned, pen_down=pen_down, label=label)
        trace.inked = self.ink.ink_trace(trace.executed) if pen_down else 0
        self.traces.append(trace)
        if self.view is not None and self.eyes is not None:
            self.view.show_eye(self.eyes.camera_image("left").rgb)
        return trace.executed

    # -- lifetime ---------------------------------------------------------------------------------
    def close(self) -> None:
        """Disconnect the PyBullet client and delete temporary textures (idempotent)."""
        sim = self.__dict__.get("sim")
        if sim is not None:
            sim.close()

    def __enter__(self) -> "PyBulletBackend":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class SimSnapshots:
    """The ``snapshots`` capability of :class:`PyBulletBackend`.

    PyBullet's ``saveState`` keeps the bodies' poses and joint states in memory (no file); the
    ink texture, the paper's pose, the head's held angles, the gaze target, the light, the eyes'
    noise generator and the executed moves are copied beside it.  On restore the motors are told to hold the restored posture,
    and the ink is uploaded again.
    """

    def __init__(self, backend: PyBulletBackend) -> None:
        self.b = backend

    def save(self) -> dict:
        b = self.b
        pb, c = b.sim.pb, b.sim.client
        return {"state": pb.saveState(physicsClientId=c), "ink": b.ink.canvas.image.copy(),
                "strokes": b.ink.canvas.strokes, "surface": b.ink.surface, "held": dict(b.body.held),
                "gaze": None if b.eyes is None else b.eyes.target.copy(), "style": b.sim.style,
                "noise": None if b.eyes is None else b.eyes._rng.bit_generator.state, "traces": len(b.traces)}

    def restore(self, saved: dict) -> None:
        b = self.b
        pb, c = b.sim.pb, b.sim.client
        pb.restoreState(stateId=saved["state"], physicsClientId=c)
        b.body.held.clear()
        b.body.held.update(saved["held"])
        b.body.hold_head()
        b.body.command(b.body.arm_angles(), np.zeros(len(b.body.arm_joints)))
        if b.eyes is not None:
            b.eyes.target = saved["gaze"].copy()
            b.eyes._rng.bit_generator.state = saved["noise"]
        b.sim.style = saved["style"]
        if saved["surface"] is not b.ink.surface:
            b.ink.move_to(saved["surface"])
        b.ink.canvas.image[...] = saved["ink"]
        b.ink.canvas.strokes = saved["strokes"]
        b.sim.set_texture(b.ink.body, b.ink.canvas.image)
        del b.traces[saved["traces"]:]

    def discard(self, saved: dict) -> None:
        sim = self.b.sim
        if sim.client >= 0:
            sim.pb.removeState(saved["state"], physicsClientId=sim.client)
