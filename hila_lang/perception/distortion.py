"""Lens distortion of the simulated eye cameras: a radial (barrel, fish-eye like) model.

PyBullet renders ideal pinhole images; real iCub cameras have strong barrel distortion.  The
simulated camera applies OpenCV's radial model with known *true* coefficients

    x_d = x_u (1 + k1 r^2 + k2 r^4 + k3 r^6),    r^2 = x_u^2 + y_u^2

on normalised image coordinates (no tangential terms), so calibration can be checked against
the truth.  A camera image integrates light over each pixel: the ideal image is rendered at
``supersample`` times the resolution on a canvas large enough for the barrel's corners, warped
with ``cv2.remap`` and averaged down (``cv2.INTER_AREA``), which also gives the marker's edges
the partial-coverage values sub-pixel detection relies on.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..sim.camera import Camera

#: true distortion of the simulated iCub eye cameras: k1, k2, p1, p2, k3 (OpenCV order)
TRUE_DISTORTION = (-0.32, 0.12, 0.0, 0.0, 0.0)


@dataclass
class DistortedCamera:
    """A camera that renders through a radial lens distortion.

    Parameters
    ----------
    camera : Camera
        The true pinhole camera (its ``K`` is the true intrinsics, ``width`` x ``height`` the
        output image size).
    dist : sequence of 5 float
        OpenCV distortion coefficients (k1, k2, p1, p2, k3).
    supersample : int
        Render and warp at this many times the resolution, then average down.

    Attributes
    ----------
    render_camera : Camera
        The ideal camera to render (larger canvas, ``supersample`` x focal length).
    """

    camera: Camera
    dist: tuple = TRUE_DISTORTION
    supersample: int = 2
    render_camera: Camera = field(init=False)
    _maps: tuple = field(init=False, repr=False)
    _float_maps: tuple = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # lazy: loads cv2, which importing this module does not
        import cv2

        s = int(self.supersample)
        cam = self.camera
        W, H = cam.width * s, cam.height * s
        Ks = cam.with_size(W, H, float(s)).K
        u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
        pts = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 60, 1e-12)
        norm = cv2.undistortPoints(pts, Ks, np.asarray(self.dist, float), None, None, None, crit).reshape(-1, 2)
        ideal = norm * [Ks[0, 0], Ks[1, 1]] + [Ks[0, 2], Ks[1, 2]]
        # a canvas symmetric about the principal point that holds every ideal sample (+2 px)
        half_w = int(np.ceil(np.abs(ideal[:, 0] - Ks[0, 2]).max())) + 2
        half_h = int(np.ceil(np.abs(ideal[:, 1] - Ks[1, 2]).max())) + 2
        cw, ch = 2 * half_w + W % 2, 2 * half_h + H % 2
        self.render_camera = cam.with_size(cw, ch, float(s))
        Kr = self.render_camera.K
        ideal_r = ideal + [Kr[0, 2] - Ks[0, 2], Kr[1, 2] - Ks[1, 2]]
        mx = ideal_r[:, 0].reshape(H, W).astype(np.float32)
        my = ideal_r[:, 1].reshape(H, W).astype(np.float32)
        self._maps = cv2.convertMaps(mx, my, cv2.CV_16SC2)
        self._float_maps = (mx, my)

    def distort(self, ideal_rgb: np.ndarray) -> np.ndarray:
        """The camera's image (height, width, 3) uint8 from an ideal render of ``render_camera``."""
        # lazy: loads cv2, which importing this module does not
        import cv2

        big = cv2.remap(ideal_rgb, self._maps[0], self._maps[1], cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_REPLICATE)
        if self.supersample == 1:
            return big
        return cv2.resize(big, (self.camera.width, self.camera.height), interpolation=cv2.INTER_AREA)

    def window_source(self, window: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
        """The part ``(x0, y0, x1, y1)`` of :attr:`render_camera`'s canvas (end exclusive) that the
        image's pixels ``window = (u0, v0, u1, v1)`` (end exclusive) are made from, with a pixel
        to spare for the interpolation: render only that (:meth:`render_window`) for those pixels."""
        u0, v0, u1, v1 = (int(v) * self.supersample for v in window)
        mx, my = (m[v0:v1, u0:u1] for m in self._float_maps)
        canvas = self.render_camera
        x0, y0 = max(0, int(np.floor(mx.min())) - 1), max(0, int(np.floor(my.min())) - 1)
        x1, y1 = min(canvas.width, int(np.ceil(mx.max())) + 2), min(canvas.height, int(np.ceil(my.max())) + 2)
        return x0, y0, x1, y1

    def render_window(self, source: tuple[int, int, int, int]) -> Camera:
        """The ideal camera of the canvas part ``source`` (:meth:`window_source`): the same rays."""
        x0, y0, x1, y1 = source
        K = self.render_camera.K.copy()
        K[0, 2] -= x0
        K[1, 2] -= y0
        return Camera(K, self.render_camera.world_T_camera, x1 - x0, y1 - y0)

    def distort_window(self, ideal_part: np.ndarray, window: tuple[int, int, int, int],
                       source: tuple[int, int, int, int]) -> np.ndarray:
        """The image's pixels ``window`` (v1 - v0, u1 - u0, 3) uint8 from a render of
        :meth:`render_window` ``(source)``: the same values as ``distort(full)[v0:v1, u0:u1]``
        when the renders agree there (the maps are the full image's, shifted by whole pixels)."""
        # lazy: loads cv2, which importing this module does not
        import cv2

        s = self.supersample
        u0, v0, u1, v1 = (int(v) * s for v in window)
        mx, my = (m[v0:v1, u0:u1] - float(o) for m, o in zip(self._float_maps, source[:2]))
        maps = cv2.convertMaps(np.ascontiguousarray(mx), np.ascontiguousarray(my), cv2.CV_16SC2)
        part = cv2.remap(ideal_part, maps[0], maps[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        if s == 1:
            return part
        return cv2.resize(part, ((u1 - u0) // s, (v1 - v0) // s), interpolation=cv2.INTER_AREA)


def distort_points(uv: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    """Ideal pixels (N, 2) -> where the distorted camera sees them (N, 2)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    uv = np.atleast_2d(np.asarray(uv, dtype=float))
    norm = (uv - [K[0, 2], K[1, 2]]) / [K[0, 0], K[1, 1]]
    obj = np.column_stack([norm, np.ones(len(norm))]).reshape(-1, 1, 3)
    out, _ = cv2.projectPoints(obj, np.zeros(3), np.zeros(3), np.asarray(K, float), np.asarray(dist, float))
    return out.reshape(-1, 2)


def undistort_points(uv: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    """Distorted pixels (N, 2) -> ideal pixels (N, 2) of the same camera (iterative, exact)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    uv = np.atleast_2d(np.asarray(uv, dtype=float)).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 60, 1e-12)
    out = cv2.undistortPoints(uv, np.asarray(K, float), np.asarray(dist, float), None, None,
                                  np.asarray(K, float), crit)
    return out.reshape(-1, 2)


def undistort_image(image: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    """The ideal pinhole image (same K, same size) of a distorted ``image`` (cv2.undistort)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    return cv2.undistort(image, np.asarray(K, float), np.asarray(dist, float))


def undistorted(image):
    """The ideal pinhole version of a :class:`~hila_lang.sim.camera.CameraImage` taken through a
    lens (``image.dist``): the same ``K``, pose and size, ``dist`` None.  An image without ``dist``
    comes back as it is."""
    if image.dist is None:
        return image
    rgb = undistort_image(np.ascontiguousarray(image.rgb), image.K, image.dist)
    return replace(image, rgb=rgb, dist=None)
