"""From stereo frames to a segmented template: the perception pipeline's entry points.

:func:`perceive` runs the pipeline on two frame sequences:

1. the hand marker's sub-pixel centre in every left and right frame (short losses bridged),
2. undistorted with each eye's calibration, smoothed with Gaussian RBFs (0.5 pixel),
3. triangulated with the calibrated intrinsics and the eyes' poses; the marker sits a known
   offset above the pen tip, which is subtracted,
4. the ICPs detected in the images by the caller's *ICP reader*: perception knows no scene, so
   what the ICPs are (a game board's cell corners, a letter's box) is the world's business.
   ``read_icps(view, frames, path, surface_z) -> IcpReading`` gets ``view(eye, i)``: frame
   ``i`` of ``eye`` undistorted, as an image with the calibrated ``K`` and the eye's pose.
   (The tic-tac-toe world's reader is
   :func:`hila_lang.worlds.tictactoe.vision.demonstration_icps`.)

:func:`template_from_frames` (a recording folder, or left/right folders or videos) then segments
the path with k-means (:func:`hila_lang.osila.segmentation.segment_template`), after putting pen-tip
points within ``CONTACT_SNAP`` of the known paper plane on it (:attr:`Perception.path` keeps
the raw triangulation).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..core.errors import InputError
from ..osila.segmentation import DEFAULT_METHOD, describe, segment_template
from ..osila.template import Template
from ..sim.camera import CameraImage
from .calibration import calibrate, calibrate_stereo, Calibration, load_calibration
from .distortion import undistort_image, undistort_points
from .extraction import marker_track, rbf_smooth
from .recording import load_cameras, load_frames
from .triangulation import reprojection_error, triangulate

#: template points at most this far above (or below) the paper are put on it, metres: the
#: triangulated pen tip scatters about +-2 mm in height, and the robot's pen only inks within
#: 0.5 mm of the paper, so a drawn stroke must lie exactly on the known table plane
CONTACT_SNAP = 0.0025
DEFAULT_TAGS = ("reach", "draw", "retract")
DEFAULT_CONTACT = ("draw",)


@dataclass
class Perception:
    """Everything the pipeline measured.

    Attributes
    ----------
    path : ndarray, shape (T, 3)
        Pen-tip path, world frame, metres.
    times : ndarray, shape (T,)
        Seconds from the first frame.
    icps : dict[str, ndarray]
        Name -> (3,), world, metres, as the ICP reader found them.
    icp_reading : IcpReading
        What the ICP reader reported (its note for the template, its details).
    uv : dict[str, ndarray]
        Per eye, the undistorted, smoothed marker track (T, 2), pixels.
    bridged : dict[str, list[int]]
        Per eye, the frames where the marker was lost and interpolated.
    reprojection_px : dict[str, float]
        Per eye, the median distance between the track and the path's reprojection, pixels.
    calibration : dict[str, Calibration]
    seconds : dict[str, float]
        Wall time of each stage.
    """

    path: np.ndarray
    times: np.ndarray
    icps: dict[str, np.ndarray]
    icp_reading: "IcpReading"
    uv: dict[str, np.ndarray]
    bridged: dict[str, list[int]]
    reprojection_px: dict[str, float]
    calibration: dict[str, Calibration]
    stereo: object = None
    seconds: dict[str, float] = field(default_factory=dict)


@dataclass
class IcpReading:
    """What an ICP reader found in a demonstration's images.

    Attributes
    ----------
    icps : dict[str, ndarray]
        Name -> point (3,), world, metres.
    note : str
        One sentence for the template's description (how the ICPs were found).
    detail : dict
        Anything else worth reporting (e.g. ``{"cell": 5}``).
    """

    icps: dict[str, np.ndarray]
    note: str = ""
    detail: dict = field(default_factory=dict)


def frame_name(names, i: int) -> str:
    """``"frame NAME"`` (or ``"frame i"``) for error messages."""
    return f"frame {names[i]}" if names is not None else f"frame {i}"


def perceive(left: list[np.ndarray], right: list[np.ndarray], calibration: dict[str, Calibration],
             cameras: dict, read_icps: Callable, *, stereo=None, left_names=None, right_names=None,
             max_gap: int = 3, smoothing_px: float = 0.5) -> Perception:
    """Run the pipeline on left and right frames (lists of RGB (H, W, 3) uint8).

    Parameters
    ----------
    left, right : list of ndarray
        The two eyes' frames, same count, frame i of both taken at the same time.
    calibration : dict
        ``{"left": Calibration, "right": Calibration}``.
    cameras : dict
        As :func:`hila_lang.perception.recording.load_cameras` returns: per eye
        ``world_T_camera``, plus ``fps``, ``surface_z``, ``marker_offset``.
    read_icps : callable
        ``read_icps(view, frames, path, surface_z, names) -> IcpReading`` (see the module
        docstring); ``names`` maps an eye to its frame names (or None).
    stereo : StereoCalibration, optional
        The eyes' relative pose from a chessboard seen by both; when given, the right eye's
        pose is the left eye's (kinematics) composed with it, which keeps the two rays
        consistent with the calibrated intrinsics (a principal point off by 0.1 px would move
        the triangulated depth by about 3 mm at 0.7 m).
    left_names, right_names : list of str, optional
        Frame names for error messages.
    max_gap : int
        Longest run of frames without the marker that is bridged.
    smoothing_px : float
        Largest correction of the RBF smoothing, pixels (paper: 0.5).

    Raises
    ------
    InputError
        Different frame counts, image size not matching the calibration, the marker lost too
        long (frames named), or whatever the ICP reader could not find.
    """
    if len(left) != len(right):
        raise InputError(f"left and right frame counts differ: {len(left)} left, {len(right)} right "
                         "(the eyes record in sync, one frame each per time step)")
    if len(left) < 4:
        raise InputError(f"expected at least 4 frames per eye, got {len(left)}")
    seconds: dict[str, float] = {}
    fps = float(cameras.get("fps", 20.0))
    times = np.arange(len(left)) / fps
    frames = {"left": left, "right": right}
    names = {"left": left_names, "right": right_names}
    uv, bridged = {}, {}
    t0 = time.perf_counter()
    for eye in ("left", "right"):
        cal = calibration[eye]
        h, w = frames[eye][0].shape[:2]
        if (w, h) != (cal.width, cal.height):
            raise InputError(f"{eye} frames are {w}x{h} but the {eye} calibration is for "
                             f"{cal.width}x{cal.height}")
        raw, bridged[eye] = marker_track(frames[eye], names[eye], camera=eye, max_gap=max_gap)
        ideal = undistort_points(raw, cal.K, cal.dist)
        uv[eye] = rbf_smooth(times, ideal, tolerance=smoothing_px)
    seconds["extract"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    TL, TR = cameras["left"]["world_T_camera"], cameras["right"]["world_T_camera"]
    if stereo is not None:
        # the head's pose from the kinematics, the eyes' relative pose from the stereo card
        TR = TL @ np.linalg.inv(stereo.right_T_left)
    KL, KR = calibration["left"].K, calibration["right"].K
    marker = triangulate(uv["left"], uv["right"], KL, TL, KR, TR)
    path = marker - np.asarray(cameras.get("marker_offset", np.zeros(3)), float)
    reproj = {"left": float(np.median(reprojection_error(marker, uv["left"], KL, TL))),
              "right": float(np.median(reprojection_error(marker, uv["right"], KR, TR)))}
    seconds["triangulate"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    surface_z = float(cameras["surface_z"])
    poses, Ks = {"left": TL, "right": TR}, {"left": KL, "right": KR}

    def view(eye: str, i: int) -> CameraImage:
        cal = calibration[eye]
        rgb = undistort_image(frames[eye][i], cal.K, cal.dist)
        return CameraImage(rgb, Ks[eye], poses[eye], rgb.shape[1], rgb.shape[0])

    reading = read_icps(view, len(left), path, surface_z, names)
    seconds["icps"] = time.perf_counter() - t0
    return Perception(path, times, reading.icps, reading, uv, bridged, reproj, dict(calibration), stereo, seconds)


def snap_contact(path: np.ndarray, surface_z: float, tolerance: float = CONTACT_SNAP) -> np.ndarray:
    """``path`` (T, 3) with every point within ``tolerance`` of the plane z = ``surface_z`` put on it."""
    out = np.array(path, dtype=float)
    near = np.abs(out[:, 2] - surface_z) <= tolerance
    out[near, 2] = surface_z
    return out


def load_calibration_source(source, eye: str) -> Calibration:
    """A calibration from a YAML file, or calibrated now from a folder of chessboard images."""
    source = Path(source)
    if source.is_file() and source.suffix.lower() in (".yaml", ".yml"):
        return load_calibration(source)
    images, names = load_frames(source, f"{eye} chessboard images")
    try:
        return calibrate(images, names=names)
    except InputError as exc:
        raise InputError(f"{eye} camera: {exc.message}", file=str(source)) from None


def template_from_frames(left, right=None, *, read_icps: Callable, calibration_left=None, calibration_right=None,
                         cameras=None, stereo=None,
                         k: int = 3, tags=DEFAULT_TAGS, contact=DEFAULT_CONTACT, name: str = "circle",
                         method: str = DEFAULT_METHOD, seed: int = 0, max_gap: int = 3, description: str = "", return_perception: bool = False):
    """A segmented template from recorded stereo frames.

    Parameters
    ----------
    left : path
        A recording folder (with ``left/``, ``right/``, ``calibration/``, ``cameras.yaml``,
        see :mod:`hila_lang.perception.recording`), or the left frames (folder or video) when
        ``right`` is given.
    right : path, optional
        The right frames (folder or video).
    read_icps : callable
        Finds the ICPs in the images (see :func:`perceive`).
    calibration_left, calibration_right : path, optional
        A calibration YAML or a folder of chessboard images per eye (default: the recording's
        ``calibration/left`` and ``calibration/right``).
    cameras : path, optional
        ``cameras.yaml`` (default: the recording's, or the one beside the left frames).
    stereo : path, optional
        A folder with ``left/`` and ``right/`` chessboard pairs seen by both eyes (default: the
        recording's ``calibration/stereo`` when it exists; without it the eyes' relative pose is
        the kinematics').
    k, tags, contact, method, seed
        Segmentation (:func:`hila_lang.osila.segmentation.segment_template`; ``method`` one of
        :data:`hila_lang.osila.segmentation.METHODS`).
    name : str
        Template name.
    max_gap : int
        Longest marker loss that is bridged, frames.

    Returns
    -------
    Template, or (Template, Perception) with ``return_perception``.
    """
    left = Path(left)
    if right is None:
        root = left
        if not root.is_dir():
            raise InputError("expected a recording folder (left/, right/, calibration/, cameras.yaml), "
                             "or left and right frames", file=str(root))
        lsrc, rsrc = root / "left", root / "right"
    else:
        root = left.parent
        lsrc, rsrc = left, Path(right)
    cal_l = Path(calibration_left) if calibration_left else root / "calibration" / "left"
    cal_r = Path(calibration_right) if calibration_right else root / "calibration" / "right"
    cams_path = Path(cameras) if cameras else root / "cameras.yaml"
    t0 = time.perf_counter()
    lframes, lnames = load_frames(lsrc, "left frames")
    rframes, rnames = load_frames(rsrc, "right frames")
    t_load = time.perf_counter() - t0
    t0 = time.perf_counter()
    calibration = {"left": load_calibration_source(cal_l, "left"), "right": load_calibration_source(cal_r, "right")}
    stereo_dir = Path(stereo) if stereo else root / "calibration" / "stereo"
    stereo_cal = None
    if stereo or stereo_dir.is_dir():
        sl, sln = load_frames(stereo_dir / "left", "left stereo chessboard images")
        sr, _ = load_frames(stereo_dir / "right", "right stereo chessboard images")
        stereo_cal = calibrate_stereo(sl, sr, calibration["left"], calibration["right"], names=sln)
    t_cal = time.perf_counter() - t0
    cams = load_cameras(cams_path)
    result = perceive(lframes, rframes, calibration, cams, read_icps, stereo=stereo_cal, left_names=lnames,
                      right_names=rnames, max_gap=max_gap)
    result.seconds = {"load": t_load, "calibrate": t_cal, **result.seconds}
    desc = description or (
        f"Learned by perception (hila_lang.perception) from {len(lframes)} stereo frames at "
        f"{cams['fps']:g} Hz in {root}: hand marker detected sub-pixel in both iCub eye cameras, "
        f"undistorted with chessboard calibrations (RMS reprojection "
        f"{calibration['left'].rms:.3f} / {calibration['right'].rms:.3f} px), Gaussian RBF smoothed "
        f"(0.5 px), triangulated; points within {CONTACT_SNAP * 1000:g} mm of the paper put on it; "
        f"{result.icp_reading.note} {describe(method, k)}")
    path = snap_contact(result.path, float(cams["surface_z"]))
    whole = Template(name=name, path=path, icps=result.icps, times=result.times, description=desc)
    template = segment_template(whole, k, list(tags), method=method, seed=seed, contact=tuple(contact))
    return (template, result) if return_perception else template
