"""The paper on the robot's table: ink where the pen touches it, and a camera above it.

:class:`Paper` implements :class:`hila_lang.plugins.protocols.Ink`: a
:class:`~hila_lang.sim.surface.Surface` shown as a textured quad whose texture (a
:class:`~hila_lang.sim.canvas.Canvas`, starting from what is printed on the surface) takes the
ink.  The pen leaves ink where it is down and its tip is within 0.5 mm of the surface (or
below): the robot has no collision shapes, so contact is decided geometrically.  The texture is
uploaded once per stroke.  :class:`TopView` implements :class:`~hila_lang.plugins.protocols.Overview`.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from ..sim.camera import Camera, CameraImage
from ..sim.canvas import Canvas
from ..sim.surface import CONTACT_TOLERANCE
from ..core.validation import check_path


class Paper:
    """``surface`` in ``sim``, taking ink (see the module docstring)."""

    def __init__(self, sim, surface) -> None:
        self.sim = sim
        self.surface = surface
        self.canvas = Canvas(surface)
        # the robot's sheet faces away from the diffuse light (ambient only): the eye-camera
        # board reading was measured on it so
        self.body = sim.add_surface(surface, self.canvas.image, lit=False)

    def touching(self, points: np.ndarray) -> np.ndarray:
        """Boolean (N,): which points (N, 3) are on the paper (tip at or below its surface + tol)."""
        return self.surface.touching(points)

    def ink_trace(self, executed: np.ndarray, color="robot") -> int:
        """Ink the parts of a pen trace (N, 3) that touch the paper; returns how many points did."""
        inked = self.canvas.ink_touching(executed, self.surface.z, CONTACT_TOLERANCE, color)
        if inked:
            self.sim.set_texture(self.body, self.canvas.image)
        return inked

    def ink_polyline(self, points: np.ndarray, color="opponent") -> None:
        """Draw a stroke through ``points`` (N, 3) (or (N, 2)) on the paper without the robot.

        ``color`` is an RGB triple or a name in :data:`hila_lang.sim.canvas.INK_RGB`.
        """
        self.canvas.draw_polyline(check_path(points, "points"), color=color)
        self.sim.set_texture(self.body, self.canvas.image)

    def ink_image(self) -> np.ndarray:
        """A copy of the paper texture (H, W, 3) uint8 RGB; row 0 = far edge."""
        return self.canvas.image.copy()

    def move_to(self, surface) -> None:
        """Put the sheet (and its ink) at ``surface``'s pose (the same size), e.g. nudged mid-game."""
        if tuple(surface.size) != tuple(self.surface.size) or surface.z != self.surface.z:
            raise InputError(f"a moved sheet keeps its size {self.surface.size} and stays on the table "
                             f"(z = {self.surface.z}), got {surface.size} at z = {surface.z}")
        self.surface = surface
        self.canvas.surface = surface
        self.sim.set_pose(self.body, surface.world_T_surface())


class TopView:
    """A pinhole camera straight above the paper's centre, for reports (never for the robot).

    ``aside``: a context manager factory that moves the robot's arm out of the picture and puts
    it back after (:meth:`top_view_image`'s ``arm_aside``); None when there is no arm to move.
    """

    def __init__(self, paper: Paper, render, aside=None) -> None:
        self.paper, self._render, self._aside = paper, render, aside

    def top_view_image(self, size_px: int = 480, *, height: float = 1.0, arm_aside: bool = False) -> CameraImage:
        """A square image ``height`` metres above the paper's centre looking straight down: image
        up is the paper's far side, image right the robot's right.  The whole sheet is in view.
        ``arm_aside``: taken with the arm at its rest posture, by the robot's side (a report's
        picture of the board: a game ends with the hand over it), and put back after."""
        if isinstance(size_px, bool) or not isinstance(size_px, (int, np.integer)) or not 16 <= size_px <= 4096:
            raise InputError(f"size_px must be an integer in 16..4096, got {size_px!r}")
        surface = self.paper.surface
        right, far = surface.axes()
        pose = np.eye(4)
        pose[:3, :3] = np.column_stack([right, -far, [0.0, 0.0, -1.0]])
        pose[:3, 3] = surface.to_world(0.0, 0.0) + np.array([0.0, 0.0, height])
        extent = float(np.hypot(*surface.size)) * 1.05
        f = size_px * height / extent
        K = np.array([[f, 0.0, (size_px - 1) / 2], [0.0, f, (size_px - 1) / 2], [0.0, 0.0, 1.0]])
        camera = Camera(K, pose, size_px, size_px)
        if arm_aside and self._aside is not None:
            with self._aside():
                return CameraImage(self._render(camera), K, pose, size_px, size_px)
        return CameraImage(self._render(camera), K, pose, size_px, size_px)
