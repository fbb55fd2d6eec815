"""The one PyBullet scene: a client, boxes, textured surfaces, markers, rendering.

:class:`SimScene` owns one PyBullet client (``DIRECT`` by default, ``GUI`` on request) and the
temporary folder its textures are written to.  The robot back end (:mod:`hila_lang.robot.backend`)
puts the iCub, a table and the paper in one; a world's simulated recording (the tic-tac-toe
demonstration) and perception's chessboard views use one without a robot.  Everything is in the
world frame, metres; poses cross into PyBullet as (position, quaternion xyzw) here and nowhere
else (:mod:`hila_lang.core.rotation`).

Textured quads: ``createVisualShape`` with vertices and uvs + ``loadTexture`` +
``changeVisualShape`` (docs/design.md §5).  PyBullet caches textures by file name, so every
upload writes a new file, and each ``loadTexture`` leaks a little memory: upload once per
change (a stroke), not per simulation step.
"""

from __future__ import annotations

import os
import shutil
import tempfile

import numpy as np

from ..core.errors import HilaRuntimeError, InputError
from ..core.rotation import to_quat
from .camera import Camera, render, RenderStyle
from .client import import_pybullet, quiet_c_output
from .culling import Culler

#: where hidden bodies wait, metres
HIDDEN = (0.0, 0.0, -10.0)
#: the window's size in pixels (``gui``)
WINDOW = (1280, 800)


def _pb_pose(world_T_body) -> tuple[list[float], list[float]]:
    T = np.asarray(world_T_body, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"expected a pose of shape (4, 4), finite, got {T.shape}")
    return T[:3, 3].tolist(), to_quat(T[:3, :3]).tolist()


def check_point(point, what: str = "point") -> np.ndarray:
    """``point`` as a finite (3,) array (the scene and the robot's aim), else an InputError naming ``what``."""
    try:
        arr = np.asarray(point, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {what} of shape (3,), got {point!r}") from None
    if arr.shape != (3,):
        raise InputError(f"expected {what} of shape (3,), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{what} must be finite, got {arr}")
    return arr


class Lights:
    """The light of a :class:`SimScene`, which a world may change during a run (implements
    :class:`hila_lang.plugins.protocols.Lighting`): a level that scales the ambient, diffuse and
    specular light the scene was built with, and where the light comes from."""

    def __init__(self, sim: "SimScene") -> None:
        self.sim = sim
        self.built = sim.style

    def set_light(self, level: float, direction=None) -> None:
        """Light at ``level`` times the built one (1: as built), from ``direction`` (3,) (a vector
        towards the light, world frame; None: unchanged)."""
        if isinstance(level, bool) or not isinstance(level, (int, float, np.floating)) or not 0 < level <= 3:
            raise InputError(f"light level must be a number in (0, 3], got {level!r}")
        b = self.built
        light = b.light_direction if direction is None else tuple(float(v) for v in check_point(direction, "light direction"))
        self.sim.style = RenderStyle(**{**b.__dict__, "ambient": b.ambient * level, "diffuse": b.diffuse * level,
                                        "specular": b.specular * level, "light_direction": light})


class SimScene:
    """A PyBullet client holding a scene; close it when done (or use ``with``).

    Parameters
    ----------
    gui : bool
        Open PyBullet's window (needs a display) instead of ``DIRECT``.
    time_step : float, optional
        Physics step, seconds, with gravity on (a robot); None: no physics set up.
    solver_iterations : int, optional
        Physics solver iterations per step.
    style : RenderStyle
        Lighting and clipping of :meth:`render`.
    """

    def __init__(self, *, gui: bool = False, time_step: float | None = None,
                 solver_iterations: int | None = None, style: RenderStyle = RenderStyle()) -> None:
        self.pb = import_pybullet()
        self.style = style
        self.client = -1
        self._uploads = 0
        self.gui = bool(gui)
        #: the bodies whose links :meth:`render` leaves out when the camera cannot see them
        #: (:meth:`cull`); None until a body is added
        self.culler: Culler | None = None
        self._tmpdir = tempfile.mkdtemp(prefix="hila-scene-")
        try:
            self._connect(gui)
            if time_step is not None:
                self.pb.setTimeStep(time_step, physicsClientId=self.client)
                self.pb.setGravity(0, 0, -9.81, physicsClientId=self.client)
            if solver_iterations is not None:
                self.pb.setPhysicsEngineParameter(numSolverIterations=solver_iterations, physicsClientId=self.client)
        except BaseException:
            self.close()
            raise

    def _connect(self, gui: bool) -> None:
        pb = self.pb
        if gui and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise InputError("--gui needs a display, and none is available (DISPLAY is not set)",
                             hint="run without --gui (headless), or with a display or xvfb-run")
        with quiet_c_output():
            self.client = pb.connect(pb.GUI, options=f"--width={WINDOW[0]} --height={WINDOW[1]}") if gui \
                else pb.connect(pb.DIRECT)
        if self.client < 0:
            raise HilaRuntimeError("cannot start the PyBullet simulation" + (" window" if gui else ""))

    # -- bodies -----------------------------------------------------------------------------------
    def add_box(self, half_extents, position, rgba, *, collision: bool = False) -> int:
        """A fixed box (visual, and a collision shape when ``collision``); returns its body id."""
        pb, c = self.pb, self.client
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=list(half_extents), rgbaColor=list(rgba), physicsClientId=c)
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=list(half_extents), physicsClientId=c) if collision else -1
        return pb.createMultiBody(0, col, vis, list(position), physicsClientId=c)

    def add_quad(self, image: np.ndarray, world_T_quad: np.ndarray, size, *, lit: bool = True) -> int:
        """A visual-only rectangle showing ``image`` (H, W, 3) uint8 RGB; returns its body id.

        The quad lies in the x-y plane of ``world_T_quad`` (4, 4), centred on its origin, with
        extent ``size`` = (along x, along y) metres; the image's first row is at +y, its first
        column at -x, and it is seen from both sides.  ``lit``: its normal is +z, so the diffuse
        light falls on it; False turns the normal away, leaving ambient light only (the robot's
        paper is rendered so: the eye-camera board reading was measured on it).
        """
        img = np.asarray(image)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise InputError(f"expected an RGB uint8 image (H, W, 3), got {img.dtype} {img.shape}")
        w, h = (float(v) for v in size)
        pb, c = self.pb, self.client
        verts = [[-w / 2, h / 2, 0], [w / 2, h / 2, 0], [w / 2, -h / 2, 0], [-w / 2, -h / 2, 0]]
        vis = pb.createVisualShape(
            pb.GEOM_MESH, vertices=verts, indices=[0, 3, 2, 0, 2, 1, 0, 2, 3, 0, 1, 2],
            uvs=[[0, 1], [1, 1], [1, 0], [0, 0]],  # the renderer samples textures bottom-up
            normals=[[0, 0, 1 if lit else -1]] * 4, physicsClientId=c)
        position, quat = _pb_pose(world_T_quad)
        body = pb.createMultiBody(baseVisualShapeIndex=vis, basePosition=position, baseOrientation=quat,
                                  physicsClientId=c)
        self.set_texture(body, img)
        return body

    def add_mesh(self, image: np.ndarray, vertices, uvs, indices, *, lit: bool = True) -> int:
        """A visual-only triangle mesh showing ``image`` (H, W, 3) uint8 RGB (a bent sheet,
        :meth:`hila_lang.sim.sheet.Sheet.mesh`); returns its body id.

        ``vertices`` (N, 3) are world points, ``uvs`` (N, 2) texture coordinates (u along the
        image's columns, v along its rows from row 0), ``indices`` the triangles' vertex indices.
        ``lit`` as :meth:`add_quad` (False: ambient light only).
        """
        img = np.asarray(image)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise InputError(f"expected an RGB uint8 image (H, W, 3), got {img.dtype} {img.shape}")
        pb, c = self.pb, self.client
        uvs = np.asarray(uvs, dtype=float)
        vis = pb.createVisualShape(
            pb.GEOM_MESH, vertices=np.asarray(vertices, dtype=float).tolist(),
            indices=[int(i) for i in indices],
            uvs=np.column_stack([uvs[:, 0], 1.0 - uvs[:, 1]]).tolist(),  # the renderer samples bottom-up
            normals=[[0, 0, 1 if lit else -1]] * len(uvs), physicsClientId=c)
        body = pb.createMultiBody(baseVisualShapeIndex=vis, basePosition=[0, 0, 0], physicsClientId=c)
        self.set_texture(body, img)
        return body

    def add_surface(self, surface, image: np.ndarray | None = None, *, lit: bool = True) -> int:
        """A :class:`~hila_lang.sim.surface.Surface` as a textured quad (``image``, else its
        texture, else blank); move it with :meth:`set_pose` and ``surface.world_T_surface()``."""
        if image is None:
            # lazy: only this branch needs it
            from .canvas import Canvas

            image = Canvas(surface).image
        return self.add_quad(image, surface.world_T_surface(), surface.size, lit=lit)

    def set_texture(self, body: int, image: np.ndarray) -> None:
        """Show ``image`` (H, W, 3) uint8 RGB on ``body`` (a quad)."""
        # lazy: loads cv2, which importing this module does not
        import cv2

        pb, c = self.pb, self.client
        self._uploads += 1
        png = os.path.join(self._tmpdir, f"texture_{body}_{self._uploads}.png")
        if not cv2.imwrite(png, np.ascontiguousarray(np.asarray(image)[:, :, ::-1])):
            raise HilaRuntimeError(f"cannot write a texture to {png}")
        with quiet_c_output():
            texture = pb.loadTexture(png, physicsClientId=c)
        pb.changeVisualShape(body, -1, textureUniqueId=texture, rgbaColor=[1, 1, 1, 1], physicsClientId=c)

    def add_sphere(self, radius: float, rgba, position=HIDDEN) -> int:
        """A visual-only sphere (a marker), hidden until moved; returns its body id."""
        if not (isinstance(radius, (int, float)) and not isinstance(radius, bool) and radius > 0):
            raise InputError(f"radius must be a positive number of metres, got {radius!r}")
        pb, c = self.pb, self.client
        vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=float(radius), rgbaColor=list(rgba), physicsClientId=c)
        return pb.createMultiBody(0, -1, vis, list(position), physicsClientId=c)

    def set_position(self, body: int, point) -> None:
        """Move ``body`` to ``point`` (3,), world, metres (orientation reset)."""
        target = check_point(point)
        self.pb.resetBasePositionAndOrientation(body, target.tolist(), [0, 0, 0, 1], physicsClientId=self.client)

    def set_pose(self, body: int, world_T_body: np.ndarray) -> None:
        """Move ``body`` to the pose (4, 4) (a surface that moves during a run)."""
        position, quat = _pb_pose(world_T_body)
        self.pb.resetBasePositionAndOrientation(body, position, quat, physicsClientId=self.client)

    def hide(self, body: int) -> None:
        self.set_position(body, HIDDEN)

    def remove(self, body: int) -> None:
        self.pb.removeBody(body, physicsClientId=self.client)

    # -- seeing -----------------------------------------------------------------------------------
    def cull(self, body: int) -> int:
        """Leave ``body``'s links out of an image when the camera cannot see them
        (:mod:`.culling`: the same image, fewer triangles); returns how many links may be left
        out.  Not with a window (its own renderer would flicker) nor for images with shadows
        (what is out of view may cast one into it)."""
        if self.gui:
            return 0
        if self.culler is None:
            self.culler = Culler(self.pb, self.client)
        return self.culler.add(body)

    def render(self, camera: Camera, *, shadow: bool | None = None) -> np.ndarray:
        """An ideal pinhole RGB image (height, width, 3) uint8 of ``camera`` (tiny renderer)."""
        style = self.style if shadow is None or shadow == self.style.shadow else \
            RenderStyle(**{**self.style.__dict__, "shadow": bool(shadow)})
        if self.culler is None or style.shadow:
            return render(self.pb, self.client, camera, style)
        with self.culler.hidden(camera, style.near):
            return render(self.pb, self.client, camera, style)

    # -- lifetime ---------------------------------------------------------------------------------
    def close(self) -> None:
        """Disconnect the client and delete the temporary textures (idempotent)."""
        if self.client >= 0:
            try:
                with quiet_c_output():  # a window's threads say goodbye on C stdout (17 lines)
                    self.pb.disconnect(physicsClientId=self.client)
            except Exception:  # already gone  # noqa: BLE001
                pass
            self.client = -1
        if self._tmpdir:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = ""

    def __enter__(self) -> "SimScene":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:  # pragma: no cover - best effort
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass
