"""Synthetic videos of a pen drawing on the printed sheet, with their truth; ``.y4m`` files.

What a test, the bench (``bench/pen.py``) and a browser's fake camera need: a seeded video of
the sheet (:mod:`hila_lang.perception.sheet`) seen in perspective by a webcam, a pen with a
coloured ball on its tip drawing a known path with pauses, and what really happened (the tip's
path, when the pen touched and left the paper).  The camera's intrinsics are not the ones the
tracker assumes (its principal point is off the image centre), and the perturbations a kitchen
table brings can be turned up one by one (:class:`PenVideoSpec`): a steeper view, optical and
motion blur, sensor noise, light that brightens, dims and moves, and a hand-coloured occluder
that passes over a marker and, for a few frames, over the pen's ball.

Units: millimetres in the sheet frame (origin at the paper's bottom-left corner, x right, y up
the page, z out of the paper), seconds, pixels.

The pen (:func:`demonstration`): it waits in the air, reaches to just above where the mark
starts, comes down and touches, pauses, draws a closed wobbly loop (in a grid cell of a grid
sheet), pauses, lifts and goes away -- minimum-jerk legs, as a hand moves.  The ball (diameter
``ball_mm``) is rendered by ray casting against a sphere, and the pen's dark body (a cylinder
leaning as a right hand holds it) hides what it covers, at twice the resolution, averaged over
the exposure (motion blur).

Files: :func:`write_y4m` writes YUV4MPEG2 (4:2:0, the format Chromium's
``--use-file-for-fake-video-capture`` reads; OpenCV's FFmpeg reads it too, so ``hila learn``
takes it); :func:`write_video` writes ``.y4m``, a video OpenCV can encode (``.mp4``, ``.avi``)
or a folder of PNGs.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np

from ..core.errors import InputError
from ..core.fileio import AtomicFile, write_png
from ..sim.camera import Camera, intrinsics, look_at
from .sheet import raster, SheetLayout

#: colours (RGB albedo, 0..255) of the ball on the pen's tip, by name
BALL_RGB = {"green": (45, 185, 70), "blue": (40, 80, 200), "red": (205, 40, 40)}
SKIN_RGB = (224, 172, 140)
TABLE_RGB = (150, 118, 86)
BODY_RGB = (48, 50, 62)
#: sampling rate of the pen's motion before it is read at the frames' times, Hz
MOTION_HZ = 1000.0
#: supersampling of the rendered frames
SUPERSAMPLE = 2


@dataclass(frozen=True)
class PenVideoSpec:
    """One synthetic video (module docstring); every random choice comes from ``seed``.

    Attributes
    ----------
    seed : int
    paper, grid : str, bool
        The sheet (:class:`~hila_lang.perception.sheet.SheetLayout`).
    width, height, fps : int, int, float
        The camera's image size and frame rate.
    hfov_deg : float
        Horizontal field of view.
    tilt_deg : float
        Angle between the camera's view of the sheet's centre and the vertical (0: from above).
    yaw_deg : float
        Where the camera stands around the sheet: 0 beyond its top edge (a laptop behind the
        sheet, looking back at the person), positive turns it towards the sheet's right.
    distance_mm : float or None
        From the camera to the sheet's centre; None: the nearest (in 5 mm steps) that shows the
        whole sheet with a 6 % margin.
    blur_px : float
        Optical blur, Gaussian sigma in pixels.
    exposure : float
        Fraction of a frame interval the shutter is open (motion blur).
    noise : float
        Sensor noise, standard deviation in grey levels.
    light : float
        How much the light changes: brightness swings by +-light, and a gradient across the
        image of the same size turns around.
    occluder : bool
        A hand-coloured occluder (the free hand holding the sheet) comes over the top-left
        marker for about a second, and a finger covers the ball for ``hidden_frames`` frames.
    hidden_frames : int
    ball : str
        Colour of the ball (:data:`BALL_RGB`).
    ball_mm : float
        Diameter of the ball.
    principal_offset_px : (float, float)
        Where the true principal point is, from the image centre.
    cell : int or None
        The grid cell the pen draws in (1..9, as :meth:`SheetLayout.features` numbers them);
        None: chosen by the seed.
    wait_s : float
        Seconds more the pen waits in the air before it moves and after it stops (a person
        pressing Record, then Stop); rendered as every frame is (noise, light), not repeated.
    """

    seed: int = 0
    paper: str = "a4"
    grid: bool = True
    width: int = 640
    height: int = 480
    fps: float = 30.0
    hfov_deg: float = 62.0
    tilt_deg: float = 38.0
    yaw_deg: float = 0.0
    distance_mm: float | None = None
    blur_px: float = 0.6
    exposure: float = 0.5
    noise: float = 1.5
    light: float = 0.05
    occluder: bool = False
    hidden_frames: int = 2
    ball: str = "green"
    ball_mm: float = 12.0
    principal_offset_px: tuple[float, float] = (6.0, -4.0)
    cell: int | None = None
    wait_s: float = 0.0

    def __post_init__(self) -> None:
        if self.ball not in BALL_RGB:
            raise InputError(f"unknown ball colour {self.ball!r}; expected one of {', '.join(BALL_RGB)}")
        if self.width % 2 or self.height % 2:
            raise InputError(f"expected an even image size (4:2:0 video), got {self.width}x{self.height}")


@dataclass
class PenTruth:
    """What really happened in a synthetic video.

    Attributes
    ----------
    times : ndarray (T,)
        Frame times, seconds from the first frame.
    tip : ndarray (T, 3)
        The pen's tip (where the ball touches the paper when it does), sheet frame, mm.
    contact : ndarray (T,) bool
        The ball on the paper.
    touch, lift : float
        When the pen touched the paper and when it left it, seconds.
    K : ndarray (3, 3)
        The camera's true intrinsics.
    world_T_camera : ndarray (4, 4)
        The camera's pose in the sheet frame (mm).
    hidden : list of int
        Frames where the occluder covers the ball.
    marker_hidden : list of int
        Frames where the occluder covers (part of) a marker.
    cell : int
        The grid cell the loop was drawn in (on a sheet without grid: the one it would be).
    """

    times: np.ndarray
    tip: np.ndarray
    contact: np.ndarray
    touch: float
    lift: float
    K: np.ndarray
    world_T_camera: np.ndarray
    hidden: list = field(default_factory=list)
    marker_hidden: list = field(default_factory=list)
    cell: int = 0


# -- the pen's motion ----------------------------------------------------------------------------

def _minimum_jerk(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)[:, None]
    return a + (b - a) * (10 * s**3 - 15 * s**4 + 6 * s**5)


def _loop(rng: np.random.Generator, centre: np.ndarray, n: int) -> np.ndarray:
    """A hand-drawn closed loop (n, 3) on the paper around ``centre``: radius 14-20 mm with a
    wobble, a little overlap where it closes, minimum-jerk timing along it."""
    radius = rng.uniform(14.0, 20.0)
    wobble = rng.uniform(0.03, 0.09)
    phase, start = rng.uniform(0, 2 * np.pi, size=2)
    sweep = 2 * np.pi * rng.uniform(1.02, 1.10)
    s = np.linspace(0.0, 1.0, n)
    angle = start + sweep * (10 * s**3 - 15 * s**4 + 6 * s**5)
    r = radius * (1 + wobble * np.sin(2 * angle + phase))
    return np.column_stack([centre[0] + r * np.cos(angle), centre[1] + r * np.sin(angle), np.zeros(n)])


def demonstration(spec: PenVideoSpec, layout: SheetLayout):
    """The pen's tip sampled at :data:`MOTION_HZ`: (times (N,), tip (N, 3) mm, contact (N,), touch,
    lift, the grid cell drawn in)."""
    rng = np.random.default_rng(spec.seed)
    w, h = layout.size
    feats = layout.features()
    cell = int(rng.integers(1, 10))
    if spec.cell is not None:
        cell = spec.cell
    if layout.grid:
        corners = np.array([feats[f"cell{cell}.{c}"] for c in ("tl", "tr", "br", "bl")])
        centre = corners.mean(axis=0) + rng.normal(0.0, 2.0, size=2)
    else:
        centre = np.array([w / 2, h / 2]) + rng.uniform(-40, 40, size=2)
    hz = MOTION_HZ

    def n(seconds: float) -> int:
        return max(2, int(round(seconds * hz)))

    loop = _loop(rng, centre, n(rng.uniform(1.8, 2.4)))
    start = np.array([w * rng.uniform(0.6, 0.85), h * rng.uniform(0.2, 0.35), rng.uniform(45.0, 70.0)])
    end = np.array([w * rng.uniform(0.6, 0.85), h * rng.uniform(0.2, 0.35), rng.uniform(45.0, 70.0)])
    hover = loop[0] + [0.0, 0.0, rng.uniform(8.0, 14.0)]
    leave = loop[-1] + [0.0, 0.0, rng.uniform(8.0, 14.0)]
    legs = [np.repeat(start[None], n(rng.uniform(0.3, 0.5) + spec.wait_s), axis=0),  # waits in the air
            _minimum_jerk(start, hover, n(rng.uniform(1.0, 1.3))),      # reaches
            _minimum_jerk(hover, loop[0], n(rng.uniform(0.2, 0.3)))]    # comes down
    touch_index = sum(len(leg) for leg in legs) - 1
    legs += [np.repeat(loop[:1], n(rng.uniform(0.25, 0.4)), axis=0),     # pauses on the paper
             loop,                                                       # draws
             np.repeat(loop[-1:], n(rng.uniform(0.25, 0.4)), axis=0)]   # pauses
    lift_index = sum(len(leg) for leg in legs)
    legs += [_minimum_jerk(loop[-1], leave, n(rng.uniform(0.2, 0.3))),  # lifts
             _minimum_jerk(leave, end, n(rng.uniform(0.9, 1.2))),        # goes away
             np.repeat(end[None], n(rng.uniform(0.3, 0.5) + spec.wait_s), axis=0)]  # waits
    tip = np.concatenate(legs)
    times = np.arange(len(tip)) / hz
    contact = np.zeros(len(tip), bool)
    contact[touch_index:lift_index] = True
    return times, tip, contact, float(times[touch_index]), float(times[lift_index]), cell


# -- the camera --------------------------------------------------------------------------------

def camera(spec: PenVideoSpec, layout: SheetLayout):
    """The true camera: :class:`~hila_lang.sim.camera.Camera` in the sheet frame (mm)."""
    K = intrinsics(spec.width, spec.height, spec.hfov_deg)
    K[0, 2] += spec.principal_offset_px[0]
    K[1, 2] += spec.principal_offset_px[1]
    w, h = layout.size
    centre = np.array([w / 2, h / 2, 0.0])
    tilt, yaw = np.radians(spec.tilt_deg), np.radians(spec.yaw_deg)
    direction = np.array([np.sin(tilt) * np.sin(yaw), np.sin(tilt) * np.cos(yaw), np.cos(tilt)])
    corners = np.array([[0, 0, 0], [w, 0, 0], [w, h, 0], [0, h, 0]], float)
    margin = 0.06

    def at(distance: float):
        return Camera(K, look_at(centre + distance * direction, centre, up=(0.0, 0.0, 1.0)
                                 if spec.tilt_deg > 1 else (0.0, 1.0, 0.0)), spec.width, spec.height)

    if spec.distance_mm is not None:
        return at(spec.distance_mm)
    for distance in np.arange(200.0, 3000.0, 5.0):
        uv = at(distance).project(corners)
        if (uv[:, 0].min() > margin * spec.width and uv[:, 0].max() < (1 - margin) * spec.width
                and uv[:, 1].min() > margin * spec.height and uv[:, 1].max() < (1 - margin) * spec.height):
            return at(distance)
    raise InputError(f"no camera distance shows the whole sheet at tilt {spec.tilt_deg} degrees")  # pragma: no cover


# -- rendering ---------------------------------------------------------------------------------

class PenVideo:
    """A synthetic video: iterate it for ``(time, RGB frame)``; :attr:`truth` says what happened.

    Frames are rendered when read, so a long video never sits in memory.
    """

    def __init__(self, spec: PenVideoSpec = PenVideoSpec()):
        # lazy: loads cv2, which importing this module does not
        import cv2

        self.spec = spec
        self.layout = SheetLayout(spec.paper, spec.grid)
        self.camera = camera(spec, self.layout)
        self.big = self.camera.with_size(spec.width * SUPERSAMPLE, spec.height * SUPERSAMPLE, scale=SUPERSAMPLE)
        t, tip, contact, touch, lift, cell = demonstration(spec, self.layout)
        self._motion = (t, tip)
        frames = int(np.floor(t[-1] * spec.fps)) + 1
        times = np.arange(frames) / spec.fps
        self._rng = np.random.default_rng(spec.seed + 7919)
        self._lean = self._pen_lean()
        self._light = self._rng.uniform(0, 2 * np.pi, size=2)
        self._occluder = self._plan_occluder(times)
        hidden = [i for i in range(frames) if self._occluder_hides_ball(i, times[i], tip_at(t, tip, times[i]))]
        self.truth = PenTruth(times, tip_at(t, tip, times), np.interp(times, t, contact.astype(float)) > 0.5,
                              touch, lift, self.camera.K.copy(), self.camera.world_T_camera.copy(), hidden,
                              [i for i in range(frames) if self._occluder_on_marker(times[i])], cell)
        # the sheet on the table, at the supersampled size, without light: albedo (H, W, 3) float
        px_per_mm = 4.0
        sheet = raster(self.layout, px_per_mm).astype(np.float32) / 255.0
        w, h = self.layout.size
        to_mm = np.array([[1 / px_per_mm, 0, 0.5 / px_per_mm], [0, -1 / px_per_mm, h - 0.5 / px_per_mm], [0, 0, 1]])
        H = self._plane_to_image(self.big) @ to_mm
        size = (self.big.width, self.big.height)
        warped = cv2.warpPerspective(sheet, H, size, flags=cv2.INTER_LINEAR, borderValue=0.0)
        mask = cv2.warpPerspective(np.ones_like(sheet), H, size, flags=cv2.INTER_LINEAR, borderValue=0.0)
        paper = np.array([0.93, 0.93, 0.91], np.float32)
        table = np.array(TABLE_RGB, np.float32) / 255.0
        v, u = np.mgrid[0:size[1], 0:size[0]].astype(np.float32)
        grain = 1.0 + 0.04 * np.sin(u / 37.0 + 2.0 * np.sin(v / 91.0))  # the table's grain
        self._albedo = (warped[..., None] * paper * mask[..., None]
                        + (1 - mask[..., None]) * table * grain[..., None]).astype(np.float32)
        v, u = np.mgrid[0:spec.height, 0:spec.width].astype(np.float32)
        self._uv = (u / spec.width - 0.5, v / spec.height - 0.5)  # where the light's gradient is

    def __len__(self) -> int:
        return len(self.truth.times)

    def __iter__(self) -> Iterator[tuple[float, np.ndarray]]:
        for i in range(len(self)):
            yield float(self.truth.times[i]), self.frame(i)

    @staticmethod
    def _plane_to_image(cam) -> np.ndarray:
        """3x3 homography from the paper's plane (x, y mm) to ``cam``'s pixels."""
        camera_T_world = np.linalg.inv(cam.world_T_camera)
        R, t = camera_T_world[:3, :3], camera_T_world[:3, 3]
        H = cam.K @ np.column_stack([R[:, 0], R[:, 1], t])
        return H / H[2, 2]

    def _pen_lean(self) -> np.ndarray:
        """The pen's axis from the tip up (unit, sheet frame): 20-35 degrees from vertical, its
        top towards the person's right shoulder (down the page and to the right)."""
        tilt = np.radians(self._rng.uniform(20.0, 35.0))
        azimuth = np.radians(self._rng.uniform(-80.0, -40.0))  # from +x, towards -y (the person)
        return np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.cos(tilt)])

    # -- the occluder: an ellipse of skin, in the image ---------------------------------------
    def _plan_occluder(self, times: np.ndarray) -> dict | None:
        """The free hand holding the sheet's top-left corner: it comes in from outside the sheet,
        covers the marker there for about a second, and goes; a finger of the drawing hand
        covers the ball for ``hidden_frames`` frames in the middle of the video."""
        if not self.spec.occluder:
            return None
        w, h = self.layout.size
        tl = self.layout.marker_corners()[self.layout.ids[0]].mean(axis=0)
        marker, centre = self.camera.project(np.array([[tl[0], tl[1], 0.0], [w / 2, h / 2, 0.0]]))
        outward = (marker - centre) / np.linalg.norm(marker - centre)
        t0 = self._rng.uniform(0.15, 0.35) * times[-1]
        return {"marker": marker, "outward": outward, "t0": t0, "t1": t0 + 1.0,
                "axes": (0.11 * self.spec.width, 0.08 * self.spec.height),
                "hide": int(self._rng.integers(len(times) // 3, 2 * len(times) // 3))}

    def _occluder_centre(self, t: float) -> np.ndarray | None:
        o = self._occluder
        if o is None or not (o["t0"] <= t <= o["t1"]):
            return None
        s = (t - o["t0"]) / (o["t1"] - o["t0"])
        reach = np.sin(np.pi * s)  # 0 outside the sheet .. 1 over the marker .. 0
        return o["marker"] + o["outward"] * (1.0 - reach) * 2.2 * o["axes"][0]

    def _occluder_on_marker(self, t: float) -> bool:
        return self._occluder_centre(t) is not None

    def _occluder_hides_ball(self, i: int, t: float, tip: np.ndarray) -> bool:
        o = self._occluder
        return o is not None and o["hide"] <= i < o["hide"] + self.spec.hidden_frames

    def _draw_occluder(self, img: np.ndarray, i: int, t: float, tip: np.ndarray, light: np.ndarray) -> None:
        """Skin over ``img`` (the output-size image, lit by ``light``) where the occluder is."""
        # lazy: loads cv2, which importing this module does not
        import cv2

        skin = np.array(SKIN_RGB, np.float32) / 255.0
        shapes = []
        c = self._occluder_centre(t)
        if c is not None:
            shapes.append((c, self._occluder["axes"]))
        if self._occluder_hides_ball(i, t, tip):  # a finger passing over the ball
            uv = self.camera.project(tip[None] + [0.0, 0.0, self.spec.ball_mm / 2])[0]
            shapes.append((uv + [2.0, 1.5], (self.spec.ball_mm * 0.9, self.spec.ball_mm * 0.75)))
        for (cu, cv), (au, av) in shapes:
            mask = np.zeros(img.shape[:2], np.uint8)
            cv2.ellipse(mask, (int(cu * 16), int(cv * 16)), (int(au * 16), int(av * 16)), 20.0, 0, 360, 255, -1,
                        cv2.LINE_AA, 4)
            a = (mask.astype(np.float32) / 255.0)[..., None]
            img[:] = img * (1 - a) + a * skin * light[..., None]

    # -- the pen ------------------------------------------------------------------------------------
    def _pen_layer(self, tip: np.ndarray, light_dir: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple]:
        """(colour (h, w, 3), coverage (h, w), (row0, col0)) of the pen over the big image."""
        r = self.spec.ball_mm / 2
        centre = tip + [0.0, 0.0, r]
        axis = self._lean
        body_r, body_len = 0.32 * self.spec.ball_mm, 110.0
        ends = np.array([centre, centre + axis * body_len])
        cam = self.big
        pts = np.vstack([centre + d for d in np.array(np.meshgrid([-r, r], [-r, r], [-r, r])).T.reshape(-1, 3)]
                        + [ends[1] + d for d in np.array(np.meshgrid([-body_r, body_r], [-body_r, body_r],
                                                                       [-body_r, body_r])).T.reshape(-1, 3)])
        uv = cam.project(pts)
        c0, r0 = np.floor(uv.min(axis=0)).astype(int) - 2
        c1, r1 = np.ceil(uv.max(axis=0)).astype(int) + 2
        c0, r0 = max(c0, 0), max(r0, 0)
        c1, r1 = min(c1, cam.width), min(r1, cam.height)
        if c1 <= c0 or r1 <= r0:
            return np.zeros((0, 0, 3)), np.zeros((0, 0)), (0, 0)
        vv, uu = np.mgrid[r0:r1, c0:c1].astype(float)
        rays = np.stack([(uu - cam.K[0, 2]) / cam.K[0, 0], (vv - cam.K[1, 2]) / cam.K[1, 1], np.ones_like(uu)], -1)
        R = cam.world_T_camera[:3, :3]
        d = rays @ R.T
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        o = cam.world_T_camera[:3, 3]
        # the ball
        oc = o - centre
        b = d @ oc
        disc = b * b - (oc @ oc - r * r)
        t_ball = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
        # the body: an infinite cylinder about the axis, cut to [r * 0.6, body_len] along it
        w0 = o - centre
        dd = d - (d @ axis)[..., None] * axis
        ww = w0 - (w0 @ axis) * axis
        A = (dd * dd).sum(-1)
        B = 2 * (dd @ ww)
        C = ww @ ww - body_r * body_r
        disc2 = B * B - 4 * A * C
        t_body = np.where((disc2 >= 0) & (A > 1e-12), (-B - np.sqrt(np.maximum(disc2, 0))) / (2 * np.maximum(A, 1e-12)), np.inf)
        along = (w0 @ axis) + t_body * (d @ axis)
        t_body = np.where((along >= 0.6 * r) & (along <= body_len), t_body, np.inf)
        ball_rgb = np.array(BALL_RGB[self.spec.ball], float) / 255.0
        body_rgb = np.array(BODY_RGB, float) / 255.0
        hit_ball = t_ball < t_body
        t = np.minimum(t_ball, t_body)
        hit = np.isfinite(t)
        p = o + d * np.where(hit, t, 0.0)[..., None]
        n_ball = (p - centre) / r
        q = p - centre
        n_body = q - (q @ axis)[..., None] * axis
        n_body /= np.maximum(np.linalg.norm(n_body, axis=-1, keepdims=True), 1e-9)
        normal = np.where(hit_ball[..., None], n_ball, n_body)
        shade = 0.6 + 0.4 * np.clip(normal @ light_dir, 0.0, 1.0)
        colour = np.where(hit_ball[..., None], ball_rgb, body_rgb) * shade[..., None]
        return colour.astype(np.float32), hit.astype(np.float32), (r0, c0)

    def frame(self, i: int) -> np.ndarray:
        """Frame ``i`` as RGB (height, width, 3) uint8."""
        # lazy: loads cv2, which importing this module does not
        import cv2

        spec = self.spec
        t = float(self.truth.times[i])
        rng = np.random.default_rng([spec.seed, i])
        swing = spec.light * np.sin(2 * np.pi * t / 3.0 + self._light[0])
        turn = self._light[1] + t * 0.9
        gx, gy = self._uv
        light = (0.92 + swing + spec.light * 2 * (np.cos(turn) * gx + np.sin(turn) * gy)).astype(np.float32)
        img = self._albedo.copy()
        light_dir = np.array([0.3, 0.2, 0.93])
        light_dir /= np.linalg.norm(light_dir)
        # the pen, averaged over the exposure
        offsets = np.linspace(-0.5, 0.5, 3) * spec.exposure / spec.fps if spec.exposure > 0 else [0.0]
        t_motion, tip_motion = self._motion
        layers = [self._pen_layer(tip_at(t_motion, tip_motion, t + dt), light_dir) for dt in offsets]
        layers = [layer for layer in layers if layer[1].size]
        if layers:  # composite the exposure's average over the union of the pen's boxes only
            r0 = min(o[0] for _, _, o in layers)
            c0 = min(o[1] for _, _, o in layers)
            r1 = max(o[0] + cov.shape[0] for _, cov, o in layers)
            c1 = max(o[1] + cov.shape[1] for _, cov, o in layers)
            colour_sum = np.zeros((r1 - r0, c1 - c0, 3), np.float32)
            cover_sum = np.zeros((r1 - r0, c1 - c0), np.float32)
            for colour, cover, (a, b) in layers:
                h, w = cover.shape
                colour_sum[a - r0:a - r0 + h, b - c0:b - c0 + w] += colour * cover[..., None]
                cover_sum[a - r0:a - r0 + h, b - c0:b - c0 + w] += cover
            alpha = (cover_sum / len(layers))[..., None]
            img[r0:r1, c0:c1] = img[r0:r1, c0:c1] * (1 - alpha) + colour_sum / len(layers)
        img = cv2.resize(img, (spec.width, spec.height), interpolation=cv2.INTER_AREA) * light[..., None]
        self._draw_occluder(img, i, t, self.truth.tip[i], light)
        if spec.blur_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), spec.blur_px)
        img = img * 255.0 + rng.normal(0.0, spec.noise, size=img.shape)
        return np.clip(np.round(img), 0, 255).astype(np.uint8)


def tip_at(times: np.ndarray, tip: np.ndarray, t) -> np.ndarray:
    """The tip (3,) or (N, 3) at time(s) ``t``, linearly between the motion's samples."""
    t = np.asarray(t, float)
    out = np.stack([np.interp(t, times, tip[:, k]) for k in range(3)], axis=-1)
    return out


def variant(spec: PenVideoSpec, **changes) -> PenVideoSpec:
    """``spec`` with ``changes`` (a perturbation of the bench's)."""
    return replace(spec, **changes)


# -- files -------------------------------------------------------------------------------------

def write_y4m(path: str | os.PathLike, frames: Iterable[np.ndarray], fps: float) -> Path:
    """Write RGB frames (all the same even size) as YUV4MPEG2 4:2:0 (``C420jpeg``), atomically.

    The frame rate is written as a fraction (30 -> ``F30:1``, 29.97 -> ``F30000:1001``).
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    rate = Fraction(fps).limit_denominator(1001)
    out = AtomicFile(path, binary=True)
    size = None
    try:
        for i, rgb in enumerate(frames):
            rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
            if size is None:
                size = rgb.shape
                if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.shape[0] % 2 or rgb.shape[1] % 2:
                    raise InputError(f"expected RGB frames of an even size (H, W, 3), got {rgb.shape}")
                out.write(f"YUV4MPEG2 W{rgb.shape[1]} H{rgb.shape[0]} F{rate.numerator}:{rate.denominator} "
                          f"Ip A1:1 C420jpeg\n".encode())
            elif rgb.shape != size:
                raise InputError(f"frame {i} is {rgb.shape}, expected {size} like the first")
            out.write(b"FRAME\n" + cv2.cvtColor(rgb, cv2.COLOR_RGB2YUV_I420).tobytes())
        if size is None:
            raise InputError("no frames to write")
    except BaseException:
        out.discard()
        raise
    return out.commit()


def write_video(path: str | os.PathLike, video: PenVideo) -> Path:
    """Write ``video`` as ``.y4m``, an OpenCV video (``.mp4``, ``.avi``: ``mp4v`` / ``MJPG``) or,
    for a path without a suffix, a folder of ``frame_00000.png`` ... (written whole or not at all)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    path = Path(path)
    suffix = path.suffix.lower()
    frames = (rgb for _, rgb in video)
    if suffix == ".y4m":
        return write_y4m(path, frames, video.spec.fps)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    try:
        if suffix in (".mp4", ".avi"):
            part = tmp / f"video{suffix}"
            fourcc = cv2.VideoWriter_fourcc(*("mp4v" if suffix == ".mp4" else "MJPG"))
            writer = cv2.VideoWriter(str(part), fourcc, video.spec.fps, (video.spec.width, video.spec.height))
            if not writer.isOpened():  # pragma: no cover - the wheel's FFmpeg has both
                raise InputError(f"OpenCV cannot write {suffix} video here", file=str(path))
            for rgb in frames:
                writer.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
            writer.release()
            os.replace(part, path)
        elif suffix == "":
            for i, rgb in enumerate(frames):
                write_png(tmp / f"frame_{i:05d}.png", rgb)
            if path.exists():
                shutil.rmtree(path)
            os.replace(tmp, path)
        else:
            raise InputError(f"expected a .y4m, .mp4 or .avi file or a folder name, got {path.name}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return path
