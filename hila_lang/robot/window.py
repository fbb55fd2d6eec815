"""The PyBullet window of a run with ``--gui``: framed on the robot and the paper, the paths drawn
as they happen, the current FSM state written in the view, and the left eye's image beside it.

:class:`Window` implements :class:`hila_lang.plugins.protocols.View` (the back end's ``view``
capability; None without a window):

- PyBullet's side panels and camera previews are turned off and the camera looks at the robot
  and the paper from the front right, close enough that they fill most of the window -- from
  the first frame: :func:`frame` runs right after the window opens, before the robot is loaded
  (the eyes' first calibration alone takes about 25 s), on the robot's nominal outline
  (:func:`robot_points`), and the window keeps that framing;
- :meth:`planned` draws a path the arm is about to follow (blue), :meth:`executed_point` extends
  the pen's trace as the simulation steps (red points, drawn in batches: :data:`TRACE_BATCH`);
- :meth:`show_state` writes the state's name and its program line above the scene;
- :meth:`show_eye` puts the left eye's latest image on a screen that stands behind the robot, in
  the window's top right, facing the window -- out of the eyes' own view (they look down at the
  paper in front of them).

Only the window draws: debug lines and text are not seen by any camera image, and the screen is
outside every camera the robot or a report uses, so a run with ``--gui`` decides and records
exactly what the same run headless does.
"""

from __future__ import annotations

import numpy as np

from .workspace import ready_point

#: the camera: (distance, yaw, pitch) in PyBullet's convention (metres, degrees), looking at the
#: middle of the robot and the paper from the front left, above the table
CAMERA = (0.5, 45.0, -28.0)
#: where things sit in the window, as (right, up) in -1..1 across the view (0, 0: its middle)
STATE_AT = (-0.96, 0.90)
SCREEN_AT = (0.62, 0.52)
#: the eye screen stands this much further from the camera than the target (behind the robot)
SCREEN_DEPTH = 0.45
#: its size, metres (320 x 240 pixels)
SCREEN_SIZE = (0.44, 0.33)
#: a point of the executed trace every so many simulation steps (240 Hz: 60 points a second)
TRACE_EVERY = 4
#: the trace's points go to the window in batches of this many (one debug item each).  Adding a
#: debug item waits for the window's next frame: 0.13 s each under Xvfb's software renderer on
#: this 2-core machine (load ~5), whether it is one line or a batch of points
#: (``pybullet.addUserDebugPoints``).  One line every 8 steps -- as the window drew first --
#: cost ~4 s of waiting per simulated second, which no ``--speed`` could make up; a batch every
#: 64 steps costs ~0.5 s, and the planned path is one batch, not a line per waypoint.
TRACE_BATCH = 16
#: spacing of the planned path's points as drawn, metres (dense enough to read as a line)
PLANNED_SPACING = 0.002
PLANNED_RGB = (0.15, 0.35, 0.95)
EXECUTED_RGB = (0.9, 0.1, 0.1)


#: the left eye in the robot's held posture, world frame, metres (measured: PyBullet 3.2.7,
#: icub-models 3.2.0, the head held as the back end holds it)
HEAD = (0.1264, 0.1004, 0.8947)


#: an arm without a head is framed from its base to this far above it, metres
ARM_HEIGHT = 0.8


def robot_points(surface, spec=None) -> np.ndarray:
    """What the window frames of the robot (3, 3): the iCub's waist, above its head and the pen's
    ready point; another arm's (``spec``, :mod:`.spec`) base, above it and the ready point."""
    if spec is None or spec.eyes == "head":
        return np.array([[0.0, 0.0, 0.45], np.add(HEAD, [0.0, 0.0, 0.08]), ready_point(surface)])
    base = np.asarray(spec.base_position, dtype=float)
    return np.array([base, base + [0.0, 0.0, ARM_HEIGHT], ready_point(surface)])


def frame(sim, surface, robot: np.ndarray | None = None, *, drawing: bool = True) -> np.ndarray:
    """Turn PyBullet's panels off and point the window's camera at the robot and the paper; the
    camera's target (3,).  Safe to call before anything is loaded, and again.

    ``drawing=False`` also stops the window drawing until a later call with ``drawing=True``:
    while the robot loads and its eyes calibrate (a minute under a software renderer) the window
    showed the half-loaded robot from wandering viewpoints (seen under Xvfb); the eyes' images
    come from the tiny renderer, which this does not touch."""
    pb, c = sim.pb, sim.client
    for flag in (pb.COV_ENABLE_GUI, pb.COV_ENABLE_RGB_BUFFER_PREVIEW, pb.COV_ENABLE_DEPTH_BUFFER_PREVIEW,
                 pb.COV_ENABLE_SEGMENTATION_MARK_PREVIEW):
        pb.configureDebugVisualizer(flag, 0, physicsClientId=c)
    pb.configureDebugVisualizer(pb.COV_ENABLE_RENDERING, int(drawing), physicsClientId=c)
    points = np.vstack([robot_points(surface) if robot is None else robot, surface.corners()])
    target = (points.min(0) + points.max(0)) / 2
    distance, yaw, pitch = CAMERA
    pb.resetDebugVisualizerCamera(distance, yaw, pitch, target.tolist(), physicsClientId=c)
    return target


class Window:
    """The ``view`` of a :class:`~hila_lang.robot.backend.PyBulletBackend` opened with ``gui``."""

    def __init__(self, sim, surface, robot: np.ndarray | None = None) -> None:
        """``robot``: points of the robot to frame (N, 3); None: its nominal outline, as
        :func:`frame` framed the window when it opened (the view does not move)."""
        self.sim = sim
        pb, c = sim.pb, sim.client
        self.target = frame(sim, surface, robot)
        distance, yaw, pitch = CAMERA
        # the window applies the camera later: the view matrix from the same yaw/pitch convention,
        # the projection (fixed by the window's size) from the window
        view = pb.computeViewMatrixFromYawPitchRoll(self.target.tolist(), distance, yaw, pitch, 0.0, 2,
                                                    physicsClientId=c)
        self._camera(view, pb.getDebugVisualizerCamera(physicsClientId=c)[3])
        pose = np.eye(4)
        pose[:3, :3] = np.column_stack([self.right, self.up, -self.forward])  # facing the camera
        pose[:3, 3] = self.at(*SCREEN_AT, distance + SCREEN_DEPTH)
        self.screen = sim.add_quad(np.full((240, 320, 3), 60, np.uint8), pose, SCREEN_SIZE)
        label = pose[:3, 3] + self.up * (SCREEN_SIZE[1] / 2 + 0.02) - self.right * SCREEN_SIZE[0] / 2
        pb.addUserDebugText("left eye", label.tolist(), [0.1, 0.1, 0.1], 1.1, physicsClientId=c)
        self._text = -1
        self._trace: list[list[float]] = []
        self._steps = 0

    def _camera(self, view, projection) -> None:
        """The window camera's position and axes (world), and its view's half-extents per metre
        of depth, from OpenGL's view and projection matrices (column-major, 16 numbers)."""
        view = np.array(view, dtype=float).reshape(4, 4).T  # world -> camera
        proj = np.array(projection, dtype=float).reshape(4, 4).T
        rot = view[:3, :3]
        self.right, self.up, self.forward = rot[0], rot[1], -rot[2]
        self.position = -rot.T @ view[:3, 3]
        self.half = (1.0 / proj[0, 0], 1.0 / proj[1, 1])

    def at(self, right: float, up: float, depth: float) -> np.ndarray:
        """The world point seen at (``right``, ``up``) in -1..1 across the view, ``depth`` metres
        in front of the camera."""
        return (self.position + self.forward * depth + self.right * (right * self.half[0] * depth)
                + self.up * (up * self.half[1] * depth))

    def show_state(self, name: str, where: str) -> None:
        """Write the current state (``name``) and its program line (``where``) in the view (the
        trace of the move before it drawn whole first)."""
        self.flush()
        pb, c = self.sim.pb, self.sim.client
        text = f"{name}   {where}" if where else name
        spot = self.at(*STATE_AT, 0.3).tolist()
        size = 1.3
        self._text = pb.addUserDebugText(text, spot, [0.0, 0.0, 0.0], size, replaceItemUniqueId=self._text,
                                         physicsClientId=c) if self._text >= 0 else \
            pb.addUserDebugText(text, spot, [0.0, 0.0, 0.0], size, physicsClientId=c)

    def _points(self, points, rgb, size: float) -> None:
        """Draw ``points`` (N, 3) as one debug item (one wait for the window's frame)."""
        if len(points):
            self.sim.pb.addUserDebugPoints([list(map(float, p)) for p in points], [list(rgb)] * len(points), size,
                                           physicsClientId=self.sim.client)

    def flush(self) -> None:
        """Draw the executed trace's points not yet drawn."""
        self._points(self._trace, EXECUTED_RGB, 3.0)
        self._trace = []

    def planned(self, path: np.ndarray) -> None:
        """Draw a planned path (T, 3), as points :data:`PLANNED_SPACING` apart, in one batch;
        the executed trace starts anew."""
        self.flush()
        path = np.asarray(path, dtype=float)
        dense = [path[:1]]
        for a, b in zip(path[:-1], path[1:]):
            n = int(min(np.ceil(np.linalg.norm(b - a) / PLANNED_SPACING), 200))
            dense.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / max(n, 1)))
        self._points(np.vstack(dense), PLANNED_RGB, 2.0)
        self._steps = 0

    def executed_point(self, point: np.ndarray) -> None:
        """The pen tip now (3,): extend the executed trace (a point every :data:`TRACE_EVERY`
        steps, drawn :data:`TRACE_BATCH` at a time)."""
        if self._steps % TRACE_EVERY == 0:
            self._trace.append(list(map(float, point)))
            if len(self._trace) >= TRACE_BATCH:
                self.flush()
        self._steps += 1

    def show_eye(self, rgb: np.ndarray) -> None:
        """Show the left eye's image (240, 320, 3) on the screen behind the robot."""
        self.sim.set_texture(self.screen, np.ascontiguousarray(rgb))
