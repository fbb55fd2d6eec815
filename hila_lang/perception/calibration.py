"""Camera calibration from chessboard images (OpenCV), and the simulated chessboard session.

:func:`calibrate` takes images of a chessboard (``pattern`` inner corners, ``square`` metres)
and returns the intrinsics ``K`` and distortion ``dist`` (k1, k2, p1, p2; k3 fixed at 0) with the
RMS reprojection error in pixels.  :func:`chessboard_views` shows a printed chessboard card to a
simulated (distorted) eye camera at seeded poses that cover the image, corners included, where
the distortion is strongest.  :class:`Calibration` saves to and loads from YAML.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.fileio import dump_yaml, load_yaml
from ..core.rotation import from_euler
from ..sim.camera import Camera, look_at, project, STUDIO
from ..sim.scene import SimScene
from .distortion import distort_points, DistortedCamera

#: default chessboard: inner corners (columns, rows) and square side, metres; one odd and one
#: even count make the corner order unambiguous (the same in the left and right images)
PATTERN = (9, 6)
SQUARE = 0.025
#: the larger card shown to both eyes at once, 0.5-0.8 m away, for the eyes' relative pose
STEREO_SQUARE = 0.04


@dataclass
class Calibration:
    """One camera's calibrated intrinsics.

    Attributes
    ----------
    K : ndarray, shape (3, 3)
        Intrinsics, pixels.
    dist : ndarray, shape (5,)
        OpenCV distortion coefficients (k1, k2, p1, p2, k3).
    rms : float
        RMS reprojection error over all chessboard corners, pixels.
    width, height : int
        Image size the calibration is valid for.
    n_views : int
        Chessboard images used.
    """

    K: np.ndarray
    dist: np.ndarray
    rms: float
    width: int
    height: int
    n_views: int

    def to_dict(self) -> dict:
        """Plain data for YAML."""
        return {"K": self.K.tolist(), "dist": self.dist.tolist(), "rms_px": float(self.rms),
                "width": self.width, "height": self.height, "n_views": self.n_views}

    @classmethod
    def from_dict(cls, data: dict, where: str = "calibration") -> "Calibration":
        """Inverse of :meth:`to_dict`; :class:`InputError` naming the missing or bad field."""
        try:
            K = np.asarray(data["K"], dtype=float)
            dist = np.asarray(data["dist"], dtype=float).ravel()
            out = cls(K, dist, float(data.get("rms_px", float("nan"))), int(data["width"]),
                      int(data["height"]), int(data.get("n_views", 0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{where}: expected fields K (3x3), dist, width, height; problem: {exc}") from None
        if K.shape != (3, 3) or not np.isfinite(K).all() or dist.size not in (4, 5, 8) or not np.isfinite(dist).all():
            raise InputError(f"{where}: expected K of shape (3, 3) and 4, 5 or 8 distortion coefficients, "
                             f"got K {K.shape}, dist {dist.size}")
        return out


def find_corners(image: np.ndarray, pattern=PATTERN) -> np.ndarray | None:
    """Sub-pixel chessboard corners (N, 2) in ``image`` (H, W[, 3]) uint8, or None if not found."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    ok, corners = cv2.findChessboardCorners(gray, tuple(pattern),
                                            flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not ok:
        return None
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    corners = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), crit)
    return corners.reshape(-1, 2).astype(float)


def board_points(pattern=PATTERN, square: float = SQUARE) -> np.ndarray:
    """The chessboard's inner corners in its own frame (N, 3), metres, z = 0, OpenCV order."""
    cols, rows = pattern
    g = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    return np.column_stack([g, np.zeros(len(g))])


def calibrate(images, pattern=PATTERN, square: float = SQUARE, names=None, min_views: int = 5) -> Calibration:
    """Calibrate one camera from chessboard images.

    Parameters
    ----------
    images : sequence of ndarray (H, W, 3) or (H, W), uint8
        All the same size.
    pattern : (int, int)
        Inner corners (columns, rows).
    square : float
        Side of a square, metres.
    names : sequence of str, optional
        Names of the images (file names) for error messages.
    min_views : int
        Fewer images with a chessboard found is an error.

    Raises
    ------
    InputError
        No images, images of different sizes, or the chessboard found in fewer than
        ``min_views`` images (the message names the images where it was not found).

    Notes
    -----
    Views whose RMS reprojection error exceeds 3 times the median (and 0.25 px) are dropped and
    the camera recalibrated without them; ``n_views`` counts the views used.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    images = list(images)
    names = list(names) if names is not None else [f"image {i}" for i in range(len(images))]
    if not images:
        raise InputError("no chessboard images to calibrate from")
    sizes = {im.shape[:2] for im in images}
    if len(sizes) != 1:
        raise InputError(f"chessboard images differ in size: {sorted(sizes)}")
    h, w = images[0].shape[:2]
    obj, img, missing = [], [], []
    for name, im in zip(names, images):
        c = find_corners(im, pattern)
        if c is None:
            missing.append(name)
            continue
        obj.append(board_points(pattern, square).astype(np.float32))
        img.append(c.astype(np.float32).reshape(-1, 1, 2))
    if len(obj) < min_views:
        raise InputError(
            f"no {pattern[0]}x{pattern[1]} chessboard found in {len(missing)} of {len(images)} images "
            f"({_list(missing)}); calibration needs at least {min_views} views with the whole board visible")
    flags = cv2.CALIB_FIX_K3
    rms, K, dist, _, _, _, _, per_view = cv2.calibrateCameraExtended(obj, img, (w, h), None, None, flags=flags)
    # a view whose corners fit much worse than the others (a misdetected corner) is dropped
    per_view = per_view.ravel()
    keep = per_view <= max(3.0 * float(np.median(per_view)), 0.25)
    if not keep.all() and keep.sum() >= min_views:
        obj = [o for o, k in zip(obj, keep) if k]
        img = [i for i, k in zip(img, keep) if k]
        rms, K, dist, _, _ = cv2.calibrateCamera(obj, img, (w, h), None, None, flags=flags)
    return Calibration(np.asarray(K, float), np.asarray(dist, float).ravel()[:5], float(rms), w, h, len(obj))


def _list(names, n: int = 8) -> str:
    names = list(names)
    head = ", ".join(str(x) for x in names[:n])
    return head + (f", ... ({len(names) - n} more)" if len(names) > n else "")


def chessboard_poses(camera: Camera, dist, n: int, pattern=PATTERN, square: float = SQUARE,
                     seed: int = 0) -> list[np.ndarray]:
    """``n`` seeded poses (4, 4), world frame, of a chessboard card held in front of ``camera``.

    The card's centre is put along rays spread over the image (corners too), 0.25-0.5 m away,
    tilted up to 45 degrees; a pose is kept only if every inner corner lands inside the distorted
    image with a 6 px margin.
    """
    rng = np.random.default_rng(seed)
    cols, rows = pattern
    local = board_points(pattern, square) - [(cols - 1) * square / 2, (rows - 1) * square / 2, 0]
    Kinv = np.linalg.inv(camera.K)
    poses: list[np.ndarray] = []
    tries = 0
    while len(poses) < n and tries < 2000:
        tries += 1
        k = len(poses)
        # spread targets over a 3x3 grid of image regions, then the centre
        gx, gy = [(-1, -1), (1, -1), (-1, 1), (1, 1), (0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)][k % 9]
        u = camera.width / 2 + gx * camera.width * rng.uniform(0.18, 0.3)
        v = camera.height / 2 + gy * camera.height * rng.uniform(0.18, 0.3)
        depth = rng.uniform(0.25, 0.5)
        centre_cam = Kinv @ [u, v, 1.0] * depth
        tilt = from_euler("xyz", [rng.uniform(-45, 45), rng.uniform(-45, 45), rng.uniform(-20, 20)], degrees=True)
        # card frame: facing the camera (its +z towards the camera: rotate 180 deg about x)
        R = tilt @ from_euler("x", 180, degrees=True)
        cam_T_card = np.eye(4)
        cam_T_card[:3, :3], cam_T_card[:3, 3] = R, centre_cam
        world_T_card = camera.world_T_camera @ cam_T_card
        pts = (local @ world_T_card[:3, :3].T) + world_T_card[:3, 3]
        uv = distort_points(project(pts, camera.K, camera.world_T_camera), camera.K, dist)
        m = 6
        if (uv[:, 0].min() < m or uv[:, 1].min() < m or uv[:, 0].max() > camera.width - 1 - m
                or uv[:, 1].max() > camera.height - 1 - m):
            continue
        poses.append(world_T_card)
    return poses


def chessboard_views(dcam: DistortedCamera, n: int = 14, pattern=PATTERN, square: float = SQUARE,
                     seed: int = 0) -> list[np.ndarray]:
    """Rendered, distorted images (H, W, 3) uint8 of a chessboard card at ``n`` seeded poses."""
    cols, rows = pattern
    sq_px = 48
    tex = chessboard_texture(cols + 1, rows + 1, sq_px, border=1)
    size = ((cols + 3) * square, (rows + 3) * square)
    images = []
    with SimScene(style=STUDIO) as sim:
        # the texture's first row is the card's +y edge; OpenCV's corner order is irrelevant here
        body = sim.add_quad(tex, np.eye(4), size)
        for pose in chessboard_poses(dcam.camera, dcam.dist, n, pattern, square, seed):
            sim.set_pose(body, pose)
            images.append(dcam.distort(sim.render(dcam.render_camera)))
    return images


def chessboard_texture(cols: int, rows: int, square_px: int = 40, border: int = 1) -> np.ndarray:
    """A chessboard of ``cols`` x ``rows`` squares with a white border of ``border`` squares, RGB."""
    sq = np.indices((rows, cols)).sum(axis=0) % 2
    board = np.where(sq == 0, 20, 235).astype(np.uint8)
    board = np.kron(board, np.ones((square_px, square_px), np.uint8))
    board = np.pad(board, border * square_px, constant_values=235)
    return np.repeat(board[:, :, None], 3, axis=2)


def stereo_poses(rig, n: int, pattern=PATTERN, square: float = STEREO_SQUARE, seed: int = 0,
                 dist=None) -> list[np.ndarray]:
    """``n`` seeded card poses (4, 4), world, seen whole by both eyes of ``rig`` (a StereoRig).

    The card is held around the point both eyes fixate (their optical axes' closest approach;
    0.5 m ahead when the eyes look in parallel, as the robot's do), up to 0.12 m off it sideways
    and 0.15 m nearer or farther, facing the eyes within 30 degrees.
    """
    rng = np.random.default_rng(seed)
    cols, rows = pattern
    local = board_points(pattern, square) - [(cols - 1) * square / 2, (rows - 1) * square / 2, 0]
    L, R = rig.left.world_T_camera, rig.right.world_T_camera
    eyes = (L[:3, 3] + R[:3, 3]) / 2
    fix = _closest_point(L[:3, 3], L[:3, 2], R[:3, 3], R[:3, 2])
    view = (fix - eyes) / np.linalg.norm(fix - eyes)
    poses: list[np.ndarray] = []
    tries = 0
    while len(poses) < n and tries < 3000:
        tries += 1
        centre = fix + rng.uniform(-0.15, 0.15) * view + rng.uniform(-0.12, 0.12, 3) * (1 - np.abs(view))
        face = look_at(centre, eyes)  # z towards the eyes
        tilt = from_euler("xyz", [rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-25, 25)], degrees=True)
        T = np.eye(4)
        T[:3, :3] = face[:3, :3] @ tilt @ np.diag([1.0, -1.0, -1.0])  # card +z faces the eyes
        T[:3, 3] = centre
        pts = local @ T[:3, :3].T + T[:3, 3]
        ok = True
        for cam in (rig.left, rig.right):
            uv = project(pts, cam.K, cam.world_T_camera)
            if dist is not None:
                uv = distort_points(uv, cam.K, dist)
            m = 6
            if (uv[:, 0].min() < m or uv[:, 1].min() < m or uv[:, 0].max() > cam.width - 1 - m
                    or uv[:, 1].max() > cam.height - 1 - m):
                ok = False
        if ok:
            poses.append(T)
    return poses


def _closest_point(p, d, q, e, parallel_distance: float = 0.5) -> np.ndarray:
    """Midpoint of the shortest segment between lines p + s d and q + t e (unit directions);
    for (nearly) parallel lines, ``parallel_distance`` ahead of the midpoint of p and q."""
    A = np.array([[d @ d, -d @ e], [d @ e, -e @ e]])
    b = np.array([(q - p) @ d, (q - p) @ e])
    if abs(np.linalg.det(A)) < 1e-6:
        ahead = (d + e) / np.linalg.norm(d + e)
        return (p + q) / 2 + parallel_distance * ahead
    s, t = np.linalg.solve(A, b)
    return (p + s * d + q + t * e) / 2


def stereo_views(left: DistortedCamera, right: DistortedCamera, rig, n: int = 16, pattern=PATTERN,
                 square: float = STEREO_SQUARE, seed: int = 0) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Left and right images of a chessboard card held where both eyes see it, ``n`` poses."""
    cols, rows = pattern
    tex = chessboard_texture(cols + 1, rows + 1, 48, border=1)
    size = ((cols + 3) * square, (rows + 3) * square)
    out_l, out_r = [], []
    with SimScene(style=STUDIO) as sim:
        body = sim.add_quad(tex, np.eye(4), size)
        for pose in stereo_poses(rig, n, pattern, square, seed, left.dist):
            sim.set_pose(body, pose)
            out_l.append(left.distort(sim.render(left.render_camera)))
            out_r.append(right.distort(sim.render(right.render_camera)))
    return out_l, out_r


@dataclass
class StereoCalibration:
    """The right eye's pose relative to the left one, from chessboard pairs.

    Attributes
    ----------
    right_T_left : ndarray, shape (4, 4)
        Maps left-camera coordinates to right-camera coordinates, metres.
    rms : float
        RMS reprojection error of the pairs, pixels.
    n_pairs : int
    """

    right_T_left: np.ndarray
    rms: float
    n_pairs: int


def calibrate_stereo(left_images, right_images, left: Calibration, right: Calibration, pattern=PATTERN,
                     square: float = STEREO_SQUARE, names=None, min_pairs: int = 3) -> StereoCalibration:
    """``cv2.stereoCalibrate`` with both eyes' intrinsics fixed: the eyes' relative pose.

    Raises
    ------
    InputError
        Different numbers of left and right images, or the board found in both images of fewer
        than ``min_pairs`` pairs.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    left_images, right_images = list(left_images), list(right_images)
    if len(left_images) != len(right_images):
        raise InputError(f"stereo chessboard images: {len(left_images)} left but {len(right_images)} right")
    names = list(names) if names is not None else [f"pair {i}" for i in range(len(left_images))]
    obj, pl, pr, missing = [], [], [], []
    for name, a, b in zip(names, left_images, right_images):
        ca, cb = find_corners(a, pattern), find_corners(b, pattern)
        if ca is None or cb is None:
            missing.append(name)
            continue
        obj.append(board_points(pattern, square).astype(np.float32))
        pl.append(ca.astype(np.float32).reshape(-1, 1, 2))
        pr.append(cb.astype(np.float32).reshape(-1, 1, 2))
    if len(obj) < min_pairs:
        raise InputError(f"no {pattern[0]}x{pattern[1]} chessboard found in both images of "
                         f"{len(missing)} of {len(names)} stereo pairs ({_list(missing)}); need {min_pairs}")
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-10)
    rms, _, _, _, _, R, T, _, _ = cv2.stereoCalibrate(
        obj, pl, pr, left.K, left.dist, right.K, right.dist, (left.width, left.height),
        criteria=crit, flags=cv2.CALIB_FIX_INTRINSIC)
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, np.asarray(T).ravel()
    return StereoCalibration(M, float(rms), len(obj))


def save_calibration(path: str | os.PathLike, calib: Calibration, header: str = "") -> Path:
    """Write ``calib`` as YAML, atomically."""
    return dump_yaml(path, calib.to_dict(), header=header or "hila camera calibration (OpenCV model)")


def load_calibration(path: str | os.PathLike) -> Calibration:
    """Read a calibration YAML written by :func:`save_calibration`."""
    data = load_yaml(path, "calibration file")
    if not isinstance(data, dict):
        raise InputError("calibration file: expected a mapping with K, dist, width, height", file=str(path))
    return Calibration.from_dict(data, where=str(path))
