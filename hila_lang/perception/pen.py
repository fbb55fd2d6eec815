"""Tracking a pen on the printed sheet in one camera's frames: the paper's plane, the tip, contact.

One camera, uncalibrated (a laptop's webcam), a sheet printed by ``hila sheet``
(:mod:`hila_lang.perception.sheet`), a pen with a coloured ball on its tip.  A
:class:`PenTracker` is fed one frame at a time (:meth:`PenTracker.feed` returns what that frame
shows: the markers, the ball, the tip on the paper, so a live page can draw them) and
:meth:`PenTracker.finish` turns the whole recording into a :class:`PenTrack`.

Per frame:

1. *The sheet.*  OpenCV's ArUco detector finds the sheet's markers (corners refined
   sub-pixel; a marker it missed is looked for again where the others put it,
   ``refineDetectedMarkers``); their ids say which sheet it is.  A marker hidden (a hand
   over it) is taken from the last frame that showed all four when the markers seen now are
   where they were then (:data:`STILL_PX`: the camera and the sheet at rest).  With at least
   :data:`MIN_MARKERS` of the four the homography from the paper (mm) to the image is fitted
   to all their corners (least squares); with fewer the frame has no sheet.
2. *The ball.*  The largest blob of the ball's colour, its coverage-weighted centroid
   (sub-pixel) and its area (:func:`hila_lang.perception.extraction.detect_blob`).

Over the recording (:meth:`PenTracker.finish`):

3. *Gaps.*  Frames without the sheet, then frames without the ball, are bridged by cubic
   interpolation when a run is at most ``max_gap`` frames long and lies between two frames
   that have them (:func:`hila_lang.perception.extraction.bridge`); a longer run, or one at
   the start or end, is an error that names the frames and which was missing -- never
   guessed.  The bridged frames, and those with a remembered marker, are listed in the track.
4. *The camera.*  Its focal length from the homographies (principal point at the image centre,
   square pixels: a plane seen at an angle fixes f; Zhang's two constraints, least squares over
   the frames).  A sheet seen nearly face-on does not: then f comes from an assumed horizontal
   field of view (``hfov_deg``, default :data:`DEFAULT_HFOV`), and the track says so.  The
   camera's pose in the paper's frame then comes from each frame's homography.
5. *The tip.*  The ball's image track is smoothed (the stereo pipeline's Gaussian RBF, 0.5 px)
   and each point cast as a ray from the camera.  A ball resting on the paper has its centre
   one radius above the point it touches, straight above it whatever the pen's tilt, so the
   tip is where the ray meets the plane z = radius.  A ball in the air is nearer the camera:
   its image is larger than a ball on the paper at the same ray would be, by the ratio of the
   distances.  The ratio of the measured size to the on-paper size is calibrated on the
   recording itself (its :data:`PAPER_QUANTILE` quantile is taken as on the paper: at least a
   fifth of a demonstration has the pen down), which gives every frame's distance along its
   ray, so the ball's centre in 3-D and the tip's *height* above the paper.
6. *Contact: the cap's distance, and the speed dips.*  The pen is down where the tip's height
   (median of 5 frames) is below :data:`CONTACT_MM` (with hysteresis: it is up again above
   :data:`RELEASE_MM`, and then it left when it rose past :data:`CONTACT_MM`); runs shorter
   than :data:`MIN_RUN_S` are dropped.  Height says *whether*
   the pen touches; *when* it touched and left comes from the hand's speed, which dips where
   it lands and where it takes off: each change is moved, within :data:`SNAP_S`, to the edge of
   the nearest speed dip that faces the air (the first slow frame of a landing, the last slow
   frame before a take-off).
7. *Path.*  On the paper the tip is the ray's point at z = radius, put on the paper (z = 0);
   in the air it is the ball's centre less a radius.  Millimetres in the sheet frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..metrics import resample_in_time
from ..osila.segmentation import speed
from .extraction import bridge, colourness, COLOURS, detect_blob, rbf_smooth
from .recording import iter_frames
from .sheet import DICTIONARY, layout_for_ids, SheetLayout

#: markers needed in a frame for its homography: three of the four span the sheet
MIN_MARKERS = 3
#: markers whose corners moved less than this since the last frame that showed all four are at rest, pixels
STILL_PX = 1.0
#: the focal length is measured only from a sheet seen at least this far from face-on, degrees:
#: below it the perspective is within the noise of the marker corners (bench/pen.py, row face-on)
MIN_TILT_DEG = 15.0
#: horizontal field of view assumed when the sheet is seen too face-on to measure the focal
#: length, degrees (laptop webcams: about 55-75)
DEFAULT_HFOV = 62.0
#: the pen is down where the tip is lower than this, and up again above RELEASE_MM, millimetres.
#: Measured (seeded videos 10-12 of bench/pen.py's base row): with the pen on the paper the
#: measured height is 0.05 mm (median), 3.1 mm (95th percentile, the frames about a landing)
#: and at most 4.0 mm; below 15 mm in the air it is off by 0.6 mm (median), 2.1 mm (p95).  So
#: a landing is taken under 4 mm and a take-off above 7 mm, clear of what the paper gives.
CONTACT_MM = 4.0
RELEASE_MM = 7.0
#: contact (or lift) runs shorter than this are noise, seconds
MIN_RUN_S = 0.1
#: how far a contact change may move to a speed dip's edge, seconds; a speed within SLOW_MM_S
#: (or a tenth of the window's range) of the window's lowest is slow, mm/s
SNAP_S = 0.25
SLOW_MM_S = 10.0
#: the quantile of the size ratio taken as "on the paper" (module docstring, step 5): the pen was
#: down in 40-43 % of the frames of the bench's videos; a fifth leaves room for demonstrations
#: that draw for less of their time
PAPER_QUANTILE = 0.2
#: brightness between a ball and its background needed to see its edge, grey levels
MIN_CONTRAST = 20.0
#: how far apart a ray's brightness and colour edges may be and still be one edge, pixels
AGREE_PX = 1.5
#: an outline point further inside the fitted circle than this is hidden, not edge, pixels
EDGE_TOLERANCE_PX = 0.5
#: default diameter of the pen's ball, millimetres
BALL_MM = 12.0


@dataclass
class PenFrame:
    """What one frame shows (:meth:`PenTracker.feed`).

    Attributes
    ----------
    index : int
    time : float
        Seconds.
    markers : dict[int, ndarray]
        Marker id -> its four image corners (4, 2), pixels (the sheet's markers only).
    H : ndarray (3, 3) or None
        Paper (mm) -> image; None with fewer than :data:`MIN_MARKERS` markers.
    ball : ndarray (2,) or None
        The centre of the ball's outline in the image, pixels (:func:`fit_ball`).
    ball_radius : float
        Its radius, pixels (0 without a ball).
    edges : ndarray (N, 2) or None
        The outline points it was fitted to (:func:`ball_edges`).
    tip : ndarray (2,) or None
        Where the ball would touch the paper (the ray at z = radius), mm: a live estimate, with
        the focal length known so far.
    remembered : list of int
        Markers not seen in this frame, taken from the last frame that showed all four (the
        sheet at rest: :meth:`PenTracker._remember`).
    """

    index: int
    time: float
    markers: dict
    H: np.ndarray | None
    ball: np.ndarray | None
    ball_radius: float = 0.0
    edges: np.ndarray | None = None
    tip: np.ndarray | None = None
    remembered: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """Plain data (JSON) for a page that draws the frame."""
        return {"index": self.index, "time": self.time,
                "markers": {str(k): v.tolist() for k, v in self.markers.items()},
                "sheet": self.H is not None, "remembered": list(self.remembered),
                "ball": None if self.ball is None else {"uv": self.ball.tolist(), "radius": self.ball_radius},
                "tip": None if self.tip is None else self.tip.tolist()}


@dataclass
class PenTrack:
    """A pen demonstration tracked on the sheet (:meth:`PenTracker.finish`).

    Attributes
    ----------
    times : ndarray (T,)
        Seconds from the first frame.
    tip : ndarray (T, 3)
        The pen's tip, sheet frame, mm; z = 0 where the pen is down.
    contact : ndarray (T,) bool
        The pen on the paper.
    height : ndarray (T,)
        The tip's measured height above the paper, mm (before contact put it on the paper).
    layout : SheetLayout
        The sheet seen.
    focal_px : float
        The focal length used.
    focal_measured : bool
        Whether it was measured from the sheet's perspective (else assumed: ``hfov_deg``).
    sheet_bridged, ball_bridged : list of int
        Frames where the sheet, or the ball, was not seen and was interpolated.
    markers_seen : ndarray (T,) int
        How many of the sheet's markers each frame showed.
    sheet_remembered : list of int
        Frames where a hidden marker was taken from the last frame that showed all four.
    names : list of str
        The frames' names.
    """

    times: np.ndarray
    tip: np.ndarray
    contact: np.ndarray
    height: np.ndarray
    layout: SheetLayout
    focal_px: float
    focal_measured: bool
    sheet_bridged: list = field(default_factory=list)
    ball_bridged: list = field(default_factory=list)
    markers_seen: np.ndarray | None = None
    sheet_remembered: list = field(default_factory=list)
    names: list = field(default_factory=list)

    def summary(self) -> str:
        """One sentence on how the track was made (for a template's description)."""
        focal = (f"focal length {self.focal_px:.0f} px measured from the sheet's perspective" if self.focal_measured
                 else f"focal length {self.focal_px:.0f} px assumed (the sheet was seen too face-on to measure it)")
        gaps = []
        if self.sheet_remembered:
            gaps.append(f"a hidden marker taken from where it was in {len(self.sheet_remembered)} frame(s)")
        if self.sheet_bridged:
            gaps.append(f"the sheet interpolated in {len(self.sheet_bridged)} frame(s)")
        if self.ball_bridged:
            gaps.append(f"the ball interpolated in {len(self.ball_bridged)} frame(s)")
        touches = int(np.sum(np.diff(self.contact.astype(int)) == 1) + int(self.contact[0]))
        return (f"{len(self.times)} frames over {self.times[-1] - self.times[0]:.2f} s on the {self.layout.name} "
                f"sheet; {focal}; pen down {touches} time(s), {np.mean(self.contact) * 100:.0f} % of the frames"
                + (f"; {', '.join(gaps)}" if gaps else "") + ".")


def _aruco_detector():
    # lazy: loads cv2, which importing this module does not
    import cv2

    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY))
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    params.cornerRefinementWinSize = 4
    return cv2.aruco.ArucoDetector(dictionary, params)


def focal_constraints(H: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Zhang's two constraints on a = 1 / f^2 from one plane -> image homography: rows (A, B)
    of A a + B = 0, each row scaled to unit length (principal point ``centre``, square pixels)."""
    T = np.array([[1.0, 0.0, -centre[0]], [0.0, 1.0, -centre[1]], [0.0, 0.0, 1.0]])
    M = T @ H
    M = M / np.linalg.norm(M[:, :2])
    h1, h2 = M[:, 0], M[:, 1]
    rows = np.array([[h1[0] * h2[0] + h1[1] * h2[1], h1[2] * h2[2]],
                     [h1[0] ** 2 + h1[1] ** 2 - h2[0] ** 2 - h2[1] ** 2, h1[2] ** 2 - h2[2] ** 2]])
    return rows


def solve_focal(rows: np.ndarray, width: int, H: np.ndarray | None = None, centre=None) -> float | None:
    """f from stacked :func:`focal_constraints` rows, or None when they do not fix it: a
    negative or vanishing solution, an f outside 0.3 to 5 image widths (a horizontal field of
    view outside about 11-120 degrees), or -- given a homography ``H`` and the principal point
    ``centre`` -- a sheet that this f shows less than :data:`MIN_TILT_DEG` from face-on, where
    the perspective the constraints rest on is within the noise of the marker corners."""
    A, B = rows[:, 0], rows[:, 1]
    if A @ A < 1e-18:
        return None
    a = -(A @ B) / (A @ A)
    if a <= 0:
        return None
    f = 1.0 / np.sqrt(a)
    if not 0.3 * width <= f <= 5 * width:
        return None
    if H is not None:
        K = np.array([[f, 0.0, centre[0]], [0.0, f, centre[1]], [0.0, 0.0, 1.0]])
        R, _ = camera_pose(H, K)
        if np.degrees(np.arccos(min(1.0, abs(R[2, 2])))) < MIN_TILT_DEG:
            return None
    return float(f)


def camera_pose(H: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, C): the rotation sheet -> camera (3, 3) and the camera's centre in the sheet frame
    (3,), mm, from the paper -> image homography ``H`` and intrinsics ``K``."""
    M = np.linalg.solve(K, H)
    lam = 2.0 / (np.linalg.norm(M[:, 0]) + np.linalg.norm(M[:, 1]))
    if M[2, 2] * lam < 0:  # the sheet is in front of the camera
        lam = -lam
    r1, r2, t = M[:, 0] * lam, M[:, 1] * lam, M[:, 2] * lam
    U, _, Vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    R = U @ Vt
    return R, -R.T @ t


def _crossing(g: np.ndarray, hit: np.ndarray, level: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """(distance along each ray of the first sample where ``hit``, interpolated to where ``g``
    crosses ``level`` (per ray); whether the ray has one)."""
    has = hit.any(axis=1)
    j = np.maximum(np.argmax(hit, axis=1), 1)
    k = np.arange(len(g))
    g0, g1 = g[k, j - 1], g[k, j]
    frac = np.clip((level - g0) / np.where(np.abs(g1 - g0) > 1e-9, g1 - g0, 1e-9), 0.0, 1.0)
    return (j - 1 + frac) * step, has


def ball_edges(grey: np.ndarray, colour_map: np.ndarray, start: np.ndarray, radius: float,
               rays: int = 48) -> np.ndarray:
    """Points (N, 2) on the outline of the ball around ``start`` (pixels), along ``rays`` rays.

    On each ray two edges: where the colourness (``colour_map``) falls below half its peak so
    far, and where the brightness (``grey``, (H, W)) crosses half-way from the ball's own level
    (the median over its inner half) to the background's (the median from 1.5 to 2.2 radii out)
    -- bilinear, sub-pixel; half-way is where a blurred edge was.  A camera sends colour at
    half the resolution of brightness (4:2:0 video: every webcam and video file), so the
    brightness edge is the sharp one and is kept where the two agree within
    :data:`AGREE_PX` and the background is brighter than the ball by :data:`MIN_CONTRAST`.
    Elsewhere -- the ball over a table as dark as itself, a ray that met something else first
    (the pen's dark body beside the ball, a grid line) -- the colourness edge is the point.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    angles = np.linspace(0.0, 2 * np.pi, rays, endpoint=False)
    u = np.column_stack([np.cos(angles), np.sin(angles)])
    step = 0.25
    s = np.arange(0.0, 2.2 * radius + 3.0, step)
    xs = (start[0] + u[:, :1] * s).astype(np.float32)
    ys = (start[1] + u[:, 1:] * s).astype(np.float32)

    def sample(image):
        return cv2.remap(image.astype(np.float32), xs, ys, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    c = sample(colour_map)
    peak = np.maximum.accumulate(c, axis=1)
    half = peak / 2
    falls = (c < half) & (peak > 0)
    falls[:, 0] = False
    d_colour, has_colour = _crossing(c, falls, half[np.arange(rays), np.argmax(falls, axis=1)], step)
    g = sample(grey)
    inner = np.median(g[:, s <= 0.5 * radius], axis=1)
    outer = np.median(g[:, (s >= 1.5 * radius) & (s <= 2.2 * radius)], axis=1)
    mid = (inner + outer) / 2
    rising = (g >= mid[:, None]) & (s > 0.3 * radius)
    d_grey, has_grey = _crossing(g, rising, mid, step)
    sharp = has_grey & has_colour & (outer - inner >= MIN_CONTRAST) & (np.abs(d_grey - d_colour) <= AGREE_PX)
    dist = np.where(sharp, d_grey, d_colour)
    return start + u[has_colour] * dist[has_colour, None]


def fit_ball(edges: np.ndarray, start: np.ndarray, principal: np.ndarray, f: float) -> tuple[np.ndarray, float] | None:
    """(centre (2,), radius) of a ball's image from its outline points, or None (too few).

    A ball off the optical axis images as an ellipse stretched away from the principal point by
    1 / cos(angle to the axis); the points are first squeezed back along that direction, so the
    outline is a circle.  The circle is fitted by least squares (Kasa), then the points well
    inside it are dropped and it is fitted again (three rounds): what hides part of a ball --
    the pen's own body above it, a finger -- only ever cuts the outline short, never extends
    it.  ``radius`` is the circle's, i.e. the ball's radius across the direction to the axis.
    """
    if len(edges) < 8:
        return None
    off = start - principal
    n = float(np.linalg.norm(off))
    e = off / n if n > 1e-9 else np.array([1.0, 0.0])
    cos_axis = f / np.hypot(f, n)
    q = edges - start
    q = q - np.outer((1 - cos_axis) * (q @ e), e)
    keep = np.ones(len(q), bool)
    centre, radius = np.zeros(2), 0.0
    for _ in range(6):
        if keep.sum() < 8:
            return None
        x, y = q[keep, 0], q[keep, 1]
        A = np.column_stack([2 * x, 2 * y, np.ones_like(x)])
        (a, b, c), *_ = np.linalg.lstsq(A, x * x + y * y, rcond=None)
        centre = np.array([a, b])
        radius = float(np.sqrt(max(c + a * a + b * b, 1e-12)))
        res = np.linalg.norm(q - centre, axis=1) - radius
        keep = res > -EDGE_TOLERANCE_PX
    centre = centre + ((1 / cos_axis - 1) * (centre @ e)) * e
    return start + centre, radius


class PenTracker:
    """Feed frames one at a time (:meth:`feed`), then :meth:`finish` (module docstring).

    Parameters
    ----------
    ball : str
        The ball's colour (:data:`hila_lang.perception.extraction.COLOURS`).
    ball_mm : float
        The ball's diameter, millimetres.
    hfov_deg : float, optional
        The camera's horizontal field of view, when known: used instead of measuring the focal
        length (and when it cannot be measured: :data:`DEFAULT_HFOV`).
    """

    def __init__(self, ball: str = "green", ball_mm: float = BALL_MM, hfov_deg: float | None = None):
        if ball not in COLOURS:
            raise InputError(f"unknown ball colour {ball!r}; expected one of {', '.join(COLOURS)}")
        if not (np.isfinite(ball_mm) and 2.0 <= ball_mm <= 60.0):
            raise InputError(f"expected the ball's diameter in millimetres, 2 to 60, got {ball_mm}")
        if hfov_deg is not None and not (np.isfinite(hfov_deg) and 20.0 <= hfov_deg <= 150.0):
            raise InputError(f"expected the camera's horizontal field of view in degrees, 20 to 150, got {hfov_deg}")
        self.ball_colour = ball
        self.radius = ball_mm / 2.0
        self.hfov_deg = hfov_deg
        self.frames: list[PenFrame] = []
        self.layout: SheetLayout | None = None
        self.size: tuple[int, int] | None = None
        self._detector = _aruco_detector()
        self._board_cache = None
        self._rows: list[np.ndarray] = []
        self._last_H: np.ndarray | None = None
        self._reference: dict | None = None

    # -- one frame ---------------------------------------------------------------------------
    def feed(self, rgb: np.ndarray, t: float | None = None, fps: float = 30.0) -> PenFrame:
        """Look at one RGB frame (H, W, 3) uint8 taken at ``t`` seconds (default index / fps)."""
        # lazy: loads cv2, which importing this module does not
        import cv2

        rgb = np.asarray(rgb)
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
            raise InputError(f"expected an RGB frame (H, W, 3) uint8, got {rgb.shape} {rgb.dtype}")
        size = (rgb.shape[1], rgb.shape[0])
        if self.size is None:
            self.size = size
        elif size != self.size:
            raise InputError(f"frame {len(self.frames)} is {size[0]}x{size[1]}, the first was "
                             f"{self.size[0]}x{self.size[1]}")
        index = len(self.frames)
        time = index / fps if t is None else float(t)
        grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        corners, ids, rejected = self._detector.detectMarkers(grey)
        if self.layout is None and ids is not None:
            self.layout = layout_for_ids(ids.ravel())
        if self.layout is not None and ids is not None and len(ids) < 4:
            # the markers missed (blur, a shadow) are looked for where the ones found put them
            corners, ids, _, _ = self._detector.refineDetectedMarkers(grey, self._board(), corners, ids, rejected)
        found = {} if ids is None else {int(i): c.reshape(4, 2).astype(float) for i, c in zip(ids.ravel(), corners)}
        markers = {} if self.layout is None else {i: c for i, c in found.items() if i in self.layout.ids}
        use, remembered = self._remember(markers)
        H = None
        if len(use) >= MIN_MARKERS:
            printed = self.layout.marker_corners()
            src = np.concatenate([printed[i] for i in use])
            dst = np.concatenate([use[i] for i in use])
            H, _ = cv2.findHomography(src, dst, 0)
            if H is not None:
                self._rows.append(focal_constraints(H, self._centre()))
                self._last_H = H
        blob = detect_blob(rgb, colour=self.ball_colour)
        f_px = self.focal()[0]
        ball, radius, edges, tip = None, 0.0, None, None
        if blob is not None:
            edges = ball_edges(grey, colourness(rgb, self.ball_colour), blob.centre, np.sqrt(blob.area / np.pi))
            fitted = fit_ball(edges, blob.centre, self._centre(), f_px)
            if fitted is not None:
                ball, radius = fitted
        if H is not None and ball is not None:
            K = self.intrinsics(f_px)
            R, C = camera_pose(H, K)
            tip = self._on_paper(ball[None], R, C, K)[0, :2]
        frame = PenFrame(index, time, markers, H, ball, radius, edges, tip, remembered)
        self.frames.append(frame)
        return frame

    def _remember(self, markers: dict) -> tuple[dict, list[int]]:
        """(the markers to fit the sheet to, the ids taken from memory) for a frame showing
        ``markers``.  The last frame that showed all four is the reference; a marker missing now
        (a hand over it) is taken from it when the markers seen now are where they were then,
        within :data:`STILL_PX` -- two of them at least: the camera and the sheet at rest."""
        if self.layout is not None and len(markers) == len(self.layout.ids):
            self._reference = {i: c.copy() for i, c in markers.items()}
            return markers, []
        if self._reference is None or len(markers) < 2:
            return markers, []
        moved = max(np.abs(c - self._reference[i]).max() for i, c in markers.items())
        if moved > STILL_PX:
            return markers, []
        missing = sorted(i for i in self._reference if i not in markers)
        return {**{i: self._reference[i] for i in missing}, **markers}, missing

    def _board(self):
        """The sheet's markers as an OpenCV ArUco board (corners in mm on the plane z = 0)."""
        # lazy: loads cv2, which importing this module does not
        import cv2

        if self._board_cache is None:
            printed = self.layout.marker_corners()
            points = [np.column_stack([printed[i], np.zeros(4)]).astype(np.float32) for i in self.layout.ids]
            self._board_cache = cv2.aruco.Board(points, self._detector.getDictionary(), np.array(self.layout.ids))
        return self._board_cache

    def _centre(self) -> np.ndarray:
        return np.array([(self.size[0] - 1) / 2.0, (self.size[1] - 1) / 2.0])

    def focal(self) -> tuple[float, bool]:
        """(focal length in pixels, whether it was measured) from the frames so far."""
        width = self.size[0]
        if self.hfov_deg is None and self._rows:
            f = solve_focal(np.concatenate(self._rows), width, self._last_H, self._centre())
            if f is not None:
                return f, True
        hfov = DEFAULT_HFOV if self.hfov_deg is None else self.hfov_deg
        return (width / 2.0) / np.tan(np.radians(hfov) / 2.0), False

    def intrinsics(self, f: float) -> np.ndarray:
        c = self._centre()
        return np.array([[f, 0.0, c[0]], [0.0, f, c[1]], [0.0, 0.0, 1.0]])

    def _rays(self, uv: np.ndarray, R: np.ndarray, K: np.ndarray) -> np.ndarray:
        """Unit directions (N, 3), sheet frame, of the pixels ``uv`` (N, 2)."""
        d = np.column_stack([uv, np.ones(len(uv))]) @ np.linalg.inv(K).T @ R
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def _on_paper(self, uv: np.ndarray, R: np.ndarray, C: np.ndarray, K: np.ndarray) -> np.ndarray:
        """Where the rays through ``uv`` meet the plane z = radius (N, 3), mm."""
        d = self._rays(uv, R, K)
        s = (self.radius - C[2]) / d[:, 2]
        return C + s[:, None] * d

    # -- the recording -------------------------------------------------------------------------
    def finish(self, max_gap: int = 3, names=None, source: str = "the video") -> PenTrack:
        """The whole recording as a :class:`PenTrack` (module docstring, steps 3-7).

        Raises
        ------
        InputError
            No frames; no marker of a hila sheet in any frame; the sheet hidden (fewer than
            :data:`MIN_MARKERS` markers) or the ball not found for longer than ``max_gap``
            frames, or in the first or last frame; no ball in any frame.  Each message names
            which, and the frames.
        """
        T = len(self.frames)
        if T < 4:
            raise InputError(f"{source}: expected at least 4 frames, got {T}")
        names = list(names) if names is not None else [str(i) for i in range(T)]
        if self.layout is None:
            raise InputError(f"{source}: no marker of a hila sheet in any of its {T} frames (ArUco {DICTIONARY}, "
                             f"ids 0-15)", hint="print the sheet with 'hila sheet --out sheet.pdf' and keep its four "
                             "corner markers in the camera's view")
        seen = np.array([len(f.markers) for f in self.frames])
        if not any(f.H is not None for f in self.frames):
            raise InputError(f"{source}: the sheet is hidden in every frame: at most {seen.max()} of its 4 markers "
                             f"seen at once, {MIN_MARKERS} are needed", hint="keep at least three corners of the sheet "
                             "in the camera's view, uncovered")
        if not any(fr.ball is not None for fr in self.frames):
            raise InputError(f"{source}: no {self.ball_colour} ball (the pen's tip) in any of its {T} frames",
                             hint=f"put a {self.ball_colour} ball or cap on the pen's tip, or name its colour "
                                  "with --ball")
        Hs = np.array([f.H.ravel() / f.H[2, 2] if f.H is not None else np.full(9, np.nan) for f in self.frames])
        lost_sheet = np.flatnonzero(~np.isfinite(Hs).all(axis=1)).tolist()
        Hs = bridge(Hs, max_gap, camera="camera", names=names,
                    what=f"sheet (at least {MIN_MARKERS} of its 4 markers)")
        f_px, measured = self.focal()
        balls = np.full((T, 3), np.nan)
        for i, fr in enumerate(self.frames):  # the outlines again, with the focal length of the whole recording
            fitted = None if fr.ball is None else fit_ball(fr.edges, fr.ball, self._centre(), f_px)
            if fitted is not None:
                balls[i] = [*fitted[0], fitted[1]]
        lost_ball = np.flatnonzero(~np.isfinite(balls).all(axis=1)).tolist()
        balls = bridge(balls, max_gap, camera="camera", names=names, what=f"{self.ball_colour} ball")
        times = np.array([f.time for f in self.frames])
        if not (np.diff(times) > 0).all():
            raise InputError(f"{source}: frame times must increase")
        times = times - times[0]
        K = self.intrinsics(f_px)
        uv = rbf_smooth(times, balls[:, :2])
        on_paper, cams, rays, ratio = np.empty((T, 3)), np.empty((T, 3)), np.empty((T, 3)), np.empty(T)
        for i in range(T):
            R, C = camera_pose(Hs[i].reshape(3, 3), K)
            d = self._rays(uv[i:i + 1], R, K)[0]
            on_paper[i] = C + (self.radius - C[2]) / d[2] * d
            cams[i], rays[i] = C, d
            L = np.linalg.norm(on_paper[i] - C)
            cos_axis = (R @ d)[2]  # the ray's angle to the optical axis
            ratio[i] = balls[i, 2] / (f_px * self.radius / L / cos_axis)  # to a ball's image radius there
        paper_ratio = float(np.quantile(ratio, PAPER_QUANTILE))
        # along its ray, the ball is nearer than the paper by the size ratio, never beyond the paper
        along = np.linalg.norm(on_paper - cams, axis=1) * np.clip(paper_ratio / ratio, 0.2, 1.0)
        centres = cams + rays * along[:, None]
        height = centres[:, 2] - self.radius
        contact = self._contact(times, height, np.column_stack([on_paper[:, :2], height]))
        tip = np.where(contact[:, None], np.column_stack([on_paper[:, :2], np.zeros(T)]),
                       np.column_stack([centres[:, :2], np.maximum(height, 0.0)]))
        remembered = [fr.index for fr in self.frames if fr.remembered]
        return PenTrack(times, tip, contact, height, self.layout, f_px, measured, lost_sheet, lost_ball, seen,
                        remembered, names)

    def _contact(self, times: np.ndarray, height: np.ndarray, path: np.ndarray) -> np.ndarray:
        """Pen down per frame: the height (median of 5) with hysteresis, short runs dropped, each
        change moved to the air-facing edge of the nearest speed dip (module docstring, step 6)."""
        # lazy: loads scipy, which importing this module does not
        from scipy.ndimage import median_filter

        h = median_filter(height, size=5, mode="nearest")
        down = np.zeros(len(h), bool)
        state = bool(h[0] < CONTACT_MM)
        for i, v in enumerate(h):
            state = v < CONTACT_MM if not state else v < RELEASE_MM
            down[i] = state
        dt = float(np.median(np.diff(times)))
        min_run = max(1, int(round(MIN_RUN_S / dt)))
        for value in (True, False):  # drop short contacts, then fill short lifts
            runs = _runs(down)
            for a, b, val in runs:
                if val == value and b - a < min_run and 0 < a and b < len(down):
                    down[a:b] = not value
        v = speed(path, times)
        window = max(1, int(round(SNAP_S / dt)))
        out = down.copy()
        for a, b, val in _runs(down):
            if a == 0:
                continue
            if not val:  # a take-off is confirmed above RELEASE_MM; it began when the tip rose past CONTACT_MM
                while a > 1 and out[a - 2] and h[a - 1] >= CONTACT_MM:
                    a -= 1
                out[a:b] = False
            # a change at a: a landing (val True) or a take-off (val False).  The slow frames near
            # it with the ball low are where the pen rests on the paper: a landing moves to the
            # first of them, a take-off to just after the last.
            lo, hi = max(a - window, 0), min(a + window, len(v) - 1)
            seg = v[lo:hi + 1]
            floor = seg.min() + max(SLOW_MM_S, 0.1 * (seg.max() - seg.min()))
            resting = np.flatnonzero((seg <= floor) & (h[lo:hi + 1] < CONTACT_MM)) + lo
            if not len(resting):
                continue
            if val:
                new = int(resting[0])
                out[min(new, a):max(new, a)] = new < a
            else:
                new = int(resting[-1]) + 1
                out[min(new, a):max(new, a)] = new > a
        return out


def _runs(mask: np.ndarray) -> list[tuple[int, int, bool]]:
    """Runs of equal values: (start, stop, value)."""
    edges = np.flatnonzero(np.diff(mask.astype(int))) + 1
    bounds = [0, *edges.tolist(), len(mask)]
    return [(bounds[k], bounds[k + 1], bool(mask[bounds[k]])) for k in range(len(bounds) - 1)]


def track_video(source, *, ball: str = "green", ball_mm: float = BALL_MM, hfov_deg: float | None = None,
                fps: float = 30.0, max_gap: int = 3, progress=None) -> PenTrack:
    """Track the pen in a video file or a folder of frames (``fps`` apart) on the sheet.

    ``progress(frames_done)`` is called every 100 frames.  Raises :class:`InputError` as
    :meth:`PenTracker.finish` does (and for an unreadable video or folder).
    """
    tracker = PenTracker(ball, ball_mm, hfov_deg)
    names = []
    for image, name, t in iter_frames(source, "frames", fps=fps):
        tracker.feed(image, t)
        names.append(name)
        if progress is not None and len(names) % 100 == 0:
            progress(len(names))
    return tracker.finish(max_gap, names=names, source=Path(source).name)


def as_demonstration(track: PenTrack, rate: float, icps: dict | None = None, cell: int | None = None):
    """A tracked pen as every demonstration in hila is: ``(path (T, 3) metres, times (T,) s, pen
    (T,) bool, icps)`` resampled at ``rate`` Hz (20: :data:`hila_lang.evaluation.lasa.RATE_HZ`), the tip on
    the paper (z = 0) where the pen is down.  ``icps``: given ones (sheet frame, metres), else
    :func:`sheet_icps` (``cell``'s corners, or the corner markers); ``hand`` is where the pen
    starts unless they name it.  ``hila learn --sheet`` and the studio's Camera scene both use it."""
    icps = dict(icps) if icps is not None else sheet_icps(track.layout, cell)
    path = resample_in_time(track.times, np.column_stack([track.tip / 1000.0, track.contact]), rate)
    pen = path[:, 3] > 0.5
    path = np.where(pen[:, None], np.column_stack([path[:, :2], np.zeros(len(path))]), path[:, :3])
    if "hand" not in icps:
        icps["hand"] = path[0]
    return path, np.arange(len(path)) / rate, pen, icps


def drawn_cell(layout: SheetLayout, path: np.ndarray, pen: np.ndarray) -> int | None:
    """The grid cell (1..9) holding the middle of what the pen drew (the mean of the pen-down
    points of ``path``, metres), or None: a sheet without a grid, nothing drawn, or drawn off the grid."""
    if not layout.grid or not np.any(pen):
        return None
    x, y = np.asarray(path, float)[np.asarray(pen, bool), :2].mean(axis=0) * 1000.0
    feats = layout.features()
    for cell in range(1, 10):
        (x0, y1), (x1, y0) = feats[f"cell{cell}.tl"], feats[f"cell{cell}.br"]
        if x0 <= x <= x1 and y0 <= y <= y1:
            return cell
    return None


def sheet_icps(layout: SheetLayout, cell: int | None = None) -> dict[str, np.ndarray]:
    """The ICPs the sheet prints, metres on the paper (z = 0): the grid cell ``cell``'s corners
    ``tl``, ``tr``, ``br``, ``bl`` (a sheet printed with its grid), or without ``cell`` the
    corner markers' centres under the same names."""
    feats = layout.features()
    if cell is None:
        chosen = {name: feats[name] for name in ("tl", "tr", "br", "bl")}
    else:
        if not layout.grid:
            raise InputError(f"--cell {cell}: the video shows the {layout.name} sheet, which has no grid",
                             hint="print the sheet with 'hila sheet --grid', or leave out --cell")
        if not 1 <= cell <= 9:
            raise InputError(f"--cell {cell}: expected a cell 1 to 9 (1 top left, 9 bottom right as you read the sheet)")
        chosen = {name: feats[f"cell{cell}.{name}"] for name in ("tl", "tr", "br", "bl")}
    return {name: np.array([p[0] / 1000.0, p[1] / 1000.0, 0.0]) for name, p in chosen.items()}
