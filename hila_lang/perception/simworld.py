"""A minimal PyBullet world for perception: table, paper with a drawn board, a hand marker.

The robot back end (:mod:`hila_lang.robot.backend`) renders the full iCub scene; perception
only needs what its eye cameras look at while a *human* demonstrates: the demonstrator's low
table, the A4 sheet with its grid (and any circles and crosses on it), a coloured hand marker,
and, for calibration, a chessboard card.  This module builds those against raw PyBullet in its
own ``DIRECT`` client, so recording and calibration do not pay for loading the iCub.

Textured quads are made with ``createVisualShape`` (vertices + uvs) + ``loadTexture`` +
``changeVisualShape`` (DESIGN.md section 4); each ``loadTexture`` leaks a little memory, so a
texture is loaded once per object.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from ..errors import InputError
from ..robot.scene import SceneSpec
from .camera import Camera, gl_projection_matrix, gl_view_matrix

#: colour of the demonstrator's hand marker (RGBA, 0..1): saturated green (nothing else in the scene is green)
MARKER_RGBA = (0.05, 0.8, 0.1, 1.0)
#: radius of the hand marker, metres
MARKER_RADIUS = 0.012
#: the marker's centre sits this far above the pen tip (it is on the back of the pen), metres
MARKER_OFFSET = np.array([0.0, 0.0, MARKER_RADIUS + 0.004])
#: table colour (RGBA)
TABLE_RGBA = (0.45, 0.33, 0.22, 1.0)


def paper_texture(spec: SceneSpec, marks=None, *, grid: bool = True, seed: int = 0) -> np.ndarray:
    """The sheet as the game draws it (:class:`hila_lang.robot.ink.InkCanvas`), RGB (H, W, 3) uint8.

    ``marks`` is a sequence of 9 strings in {"", "O", "X"} for cells 1..9: circles in the
    robot's ink, crosses (:func:`hila_lang.games.marks.cross_strokes`) in the opponent's, both
    a little irregular (seeded) like hand-drawn ones.  Row 0 is the sheet's far edge.
    """
    from ..games.marks import cross_strokes
    from ..robot.ink import InkCanvas
    from ..robot.scene import cell_center

    canvas = InkCanvas(spec, draw_grid=grid)
    rng = np.random.default_rng(seed)
    cell = spec.grid_size / 3
    for i, mark in enumerate(list(marks or [])):
        if mark == "O":
            centre = spec.world_to_grid(cell_center(spec, i + 1)) + rng.normal(scale=0.04 * cell, size=2)
            a = rng.uniform(0, 2 * np.pi) + np.linspace(0, 2 * np.pi * rng.uniform(0.97, 1.06), 60)
            r = cell * rng.uniform(0.28, 0.34) * (1 + 0.06 * np.sin(2 * a + rng.uniform(0, 6)))
            pts = spec.grid_to_world(centre[0] + r * np.cos(a), centre[1] + r * np.sin(a))
            canvas.draw_polyline(pts, color="robot")
        elif mark == "X":
            for stroke in cross_strokes(spec, i + 1, rng):
                canvas.draw_polyline(stroke, color="opponent")
        elif mark:
            raise InputError(f"mark must be '', 'O' or 'X', got {mark!r}")
    return canvas.image.copy()


def chessboard_texture(cols: int, rows: int, square_px: int = 40, border: int = 1) -> np.ndarray:
    """A chessboard of ``cols`` x ``rows`` squares with a white border of ``border`` squares, RGB."""
    sq = np.indices((rows, cols)).sum(axis=0) % 2
    board = np.where(sq == 0, 20, 235).astype(np.uint8)
    board = np.kron(board, np.ones((square_px, square_px), np.uint8))
    board = np.pad(board, border * square_px, constant_values=235)
    return np.repeat(board[:, :, None], 3, axis=2)


class SimWorld:
    """A PyBullet ``DIRECT`` client holding the perception scene; close it when done.

    Parameters
    ----------
    spec : SceneSpec
        Where the table, sheet and grid are (default: the demonstration scene).
    marks : sequence of 9 str, optional
        Circles ("O") and crosses ("X") already on the sheet, cells 1..9.
    marker : bool
        Add the hand marker (hidden far away until :meth:`set_marker`).
    """

    def __init__(self, spec: SceneSpec | None = None, marks=None, *, marker: bool = True,
                 table: bool = True, paper: bool = True, seed: int = 0) -> None:
        from ..robot.console import import_pybullet

        p = import_pybullet()
        self._p = p
        self.client = p.connect(p.DIRECT)
        self.spec = spec or SceneSpec.demonstration()
        self._tmp = tempfile.TemporaryDirectory(prefix="hila_perception_")
        self._bodies: dict[str, int] = {}
        #: body id of the sheet (None without paper)
        self.paper = None
        s = self.spec
        if table:
            half = (0.6, 0.6, 0.02)
            vs = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=TABLE_RGBA, physicsClientId=self.client)
            top = s.surface_z - 0.001
            self._bodies["table"] = p.createMultiBody(
                baseVisualShapeIndex=vs, basePosition=(s.grid_center[0] + 0.15, s.grid_center[1], top - half[2]),
                physicsClientId=self.client)
        if paper:
            tex = paper_texture(s, marks, seed=seed)
            T = np.eye(4)
            right, far = s.axes()
            T[:3, 0], T[:3, 1], T[:3, 2] = right, far, np.cross(right, far)
            T[:3, 3] = (s.grid_center[0], s.grid_center[1], s.surface_z)
            self.paper = self._bodies["paper"] = self.add_texture_quad(tex, T, s.paper_size)
        self.marker = None
        if marker:
            vs = p.createVisualShape(p.GEOM_SPHERE, radius=MARKER_RADIUS, rgbaColor=MARKER_RGBA,
                                     physicsClientId=self.client)
            self.marker = p.createMultiBody(baseVisualShapeIndex=vs, basePosition=(0, 0, -10),
                                            physicsClientId=self.client)

    # -- objects ---------------------------------------------------------------------------------
    def add_texture_quad(self, image: np.ndarray, world_T_quad: np.ndarray, size) -> int:
        """A flat rectangle showing ``image`` (H, W, 3) uint8; returns the body id.

        The quad lies in the x-y plane of ``world_T_quad`` (4, 4), centred on its origin, with
        extent ``size`` = (along x, along y) metres; the image's first row is at +y, its first
        column at -x, and it faces +z.
        """
        import cv2

        p = self._p
        path = os.path.join(self._tmp.name, f"tex{len(self._bodies)}_{id(image)}.png")
        cv2.imwrite(path, cv2.cvtColor(np.ascontiguousarray(image), cv2.COLOR_RGB2BGR))
        hx, hy = size[0] / 2, size[1] / 2
        verts = [[-hx, hy, 0], [hx, hy, 0], [hx, -hy, 0], [-hx, -hy, 0]]
        uvs = [[0, 1], [1, 1], [1, 0], [0, 0]]  # the renderer samples textures bottom-up
        idx = [0, 3, 2, 0, 2, 1, 0, 2, 3, 0, 1, 2]  # both faces
        vs = p.createVisualShape(p.GEOM_MESH, vertices=verts, indices=idx, uvs=uvs,
                                 normals=[[0, 0, 1]] * 4, physicsClientId=self.client)
        pos, quat = _pose_to_pb(world_T_quad)
        body = p.createMultiBody(baseVisualShapeIndex=vs, basePosition=pos, baseOrientation=quat,
                                 physicsClientId=self.client)
        tid = p.loadTexture(path, physicsClientId=self.client)
        p.changeVisualShape(body, -1, textureUniqueId=tid, rgbaColor=[1, 1, 1, 1], physicsClientId=self.client)
        self._bodies[f"quad{body}"] = body
        return body

    def set_pose(self, body: int, world_T_body: np.ndarray) -> None:
        """Move ``body`` to the pose (4, 4)."""
        pos, quat = _pose_to_pb(world_T_body)
        self._p.resetBasePositionAndOrientation(body, pos, quat, physicsClientId=self.client)

    def set_marker(self, point) -> None:
        """Put the hand marker's centre at ``point`` (3,), world, metres."""
        self._p.resetBasePositionAndOrientation(self.marker, [float(v) for v in point], (0, 0, 0, 1),
                                                physicsClientId=self.client)

    def hide(self, body: int) -> None:
        """Move ``body`` far below the floor."""
        self._p.resetBasePositionAndOrientation(body, (0, 0, -20), (0, 0, 0, 1), physicsClientId=self.client)

    # -- rendering -------------------------------------------------------------------------------
    def render(self, camera: Camera) -> np.ndarray:
        """An ideal pinhole RGB image (height, width, 3) uint8 of ``camera`` (tiny renderer, no shadows)."""
        p = self._p
        _, _, rgba, _, _ = p.getCameraImage(
            camera.width, camera.height,
            viewMatrix=gl_view_matrix(camera.world_T_camera),
            projectionMatrix=gl_projection_matrix(camera.K, camera.width, camera.height),
            renderer=p.ER_TINY_RENDERER, shadow=0, lightDirection=[0.3, 0.2, 1.0],
            lightAmbientCoeff=0.75, lightDiffuseCoeff=0.3, lightSpecularCoeff=0.0,
            flags=p.ER_NO_SEGMENTATION_MASK, physicsClientId=self.client)
        img = np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)
        return np.ascontiguousarray(img[:, :, :3])

    def close(self) -> None:
        """Disconnect the client and delete the temporary textures."""
        if self.client is not None:
            try:
                self._p.disconnect(self.client)
            finally:
                self.client = None
                self._tmp.cleanup()

    def __enter__(self) -> "SimWorld":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _pose_to_pb(T: np.ndarray) -> tuple[list[float], list[float]]:
    """(position, quaternion xyzw) of a pose (4, 4) for PyBullet."""
    from scipy.spatial.transform import Rotation

    T = np.asarray(T, dtype=float)
    return T[:3, 3].tolist(), Rotation.from_matrix(T[:3, :3]).as_quat().tolist()
