"""From stereo frames to a segmented template: the perception pipeline's entry points.

:func:`perceive` runs the pipeline on two frame sequences:

1. the hand marker's sub-pixel centre in every left and right frame (short losses bridged),
2. undistorted with each eye's calibration, smoothed with Gaussian RBFs (0.5 pixel),
3. triangulated with the calibrated intrinsics and the eyes' poses; the marker sits a known
   offset above the pen tip, which is subtracted,
4. the ICPs detected in the images: the grid read in each undistorted image (the first frame,
   else the last or the middle one when the hand hides the grid)
   (:func:`hila_lang.perception.board.read_board`, left and right averaged); the demonstrated
   cell is the one the pen touches (path points within ``CONTACT_TOLERANCE`` of the paper),
   its corners become ``tl``, ``tr``, ``br``, ``bl``; the hand's start ``hand`` is the first
   triangulated point (names as :mod:`hila_lang.games.demonstration` uses them).

:func:`template_from_frames` (a recording folder, or left/right folders or videos) and
:func:`template_from_sim` (record the seeded demonstration in PyBullet first) then segment the
path with k-means (:func:`hila_lang.segmentation.segment_template`), after putting pen-tip
points within ``CONTACT_SNAP`` of the known paper plane on it (:attr:`Perception.path` keeps
the raw triangulation).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .calibration import Calibration

#: a path point within this height of the paper counts as touching it (demonstrated cell), metres
CONTACT_TOLERANCE = 0.004
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
        ``tl``, ``tr``, ``br``, ``bl``, ``hand``, each (3,), world, metres.
    cell : int
        The demonstrated cell (1..9).
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
    cell: int
    uv: dict[str, np.ndarray]
    bridged: dict[str, list[int]]
    reprojection_px: dict[str, float]
    calibration: dict[str, Calibration]
    stereo: object = None
    seconds: dict[str, float] = field(default_factory=dict)


class _Undistorted:
    """A CameraImage-like view of an undistorted frame (rgb, K, world_T_camera, width, height)."""

    def __init__(self, rgb, K, world_T_camera):
        self.rgb, self.K, self.world_T_camera = rgb, K, world_T_camera
        self.height, self.width = rgb.shape[:2]


def perceive(left: list[np.ndarray], right: list[np.ndarray], calibration: dict[str, Calibration],
             cameras: dict, *, stereo=None, left_names=None, right_names=None, max_gap: int = 3,
             smoothing_px: float = 0.5) -> Perception:
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
        long (frames named), no grid found, the pen never touching the paper inside the grid.
    """
    from .board import read_board
    from .distortion import undistort_image, undistort_points
    from .extraction import marker_track, rbf_smooth
    from .triangulation import reprojection_error, triangulate

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
    readings = []
    for eye, K, T in (("left", KL, TL), ("right", KR, TR)):
        cal = calibration[eye]
        problems = []
        for i in dict.fromkeys([0, len(left) - 1, len(left) // 2]):  # the hand may hide the grid
            img = _Undistorted(undistort_image(frames[eye][i], cal.K, cal.dist), K, T)
            try:
                readings.append(read_board(img, surface_z))
                break
            except InputError as exc:
                problems.append(f"{_name(names[eye], i)}: {exc.message}")
        else:
            raise InputError(f"no grid found in the {eye} frames tried ({'; '.join(problems)})",
                             hint="the ICPs (cell corners) are read from the first, last or middle frame")
    cell = _touched_cell(path, readings[0], surface_z)
    icps = {name: (readings[0].corners[cell][name] + readings[1].corners[cell][name]) / 2
            for name in ("tl", "tr", "br", "bl")}
    icps["hand"] = path[0].copy()
    seconds["icps"] = time.perf_counter() - t0
    return Perception(path, times, icps, cell, uv, bridged, reproj, dict(calibration), stereo, seconds)


def _name(names, i: int) -> str:
    return f"frame {names[i]}" if names is not None else f"frame {i}"


def snap_contact(path: np.ndarray, surface_z: float, tolerance: float = CONTACT_SNAP) -> np.ndarray:
    """``path`` (T, 3) with every point within ``tolerance`` of the plane z = ``surface_z`` put on it."""
    out = np.array(path, dtype=float)
    near = np.abs(out[:, 2] - surface_z) <= tolerance
    out[near, 2] = surface_z
    return out


def _touched_cell(path: np.ndarray, reading, surface_z: float) -> int:
    """The cell (1..9) holding most path points within CONTACT_TOLERANCE of the paper."""
    low = path[np.abs(path[:, 2] - surface_z) < CONTACT_TOLERANCE]
    if len(low) == 0:
        raise InputError(f"the pen never touches the paper (lowest point {path[:, 2].min() - surface_z:+.3f} m "
                         f"from the surface): cannot tell which cell was demonstrated")
    rel = low[:, :2] - reading.center[:2]
    right = rel @ reading.right[:2] / reading.cell_size
    far = rel @ reading.far[:2] / reading.cell_size
    col = np.floor(right + 1.5).astype(int)
    row = np.floor(1.5 - far).astype(int)
    inside = (col >= 0) & (col < 3) & (row >= 0) & (row < 3)
    if not inside.any():
        raise InputError("the pen touches the paper only outside the grid: cannot tell the demonstrated cell")
    cells = row[inside] * 3 + col[inside] + 1
    return int(np.bincount(cells).argmax())


def load_calibration_source(source, eye: str) -> Calibration:
    """A calibration from a YAML file, or calibrated now from a folder of chessboard images."""
    from .calibration import calibrate, load_calibration
    from .recording import load_frames

    source = Path(source)
    if source.is_file() and source.suffix.lower() in (".yaml", ".yml"):
        return load_calibration(source)
    images, names = load_frames(source, f"{eye} chessboard images")
    try:
        return calibrate(images, names=names)
    except InputError as exc:
        raise InputError(f"{eye} camera: {exc.message}", file=str(source)) from None


def template_from_frames(left, right=None, *, calibration_left=None, calibration_right=None, cameras=None,
                         stereo=None,
                         k: int = 3, tags=DEFAULT_TAGS, contact=DEFAULT_CONTACT, name: str = "circle",
                         seed: int = 0, max_gap: int = 3, description: str = "", return_perception: bool = False):
    """A k-means segmented template from recorded stereo frames.

    Parameters
    ----------
    left : path
        A recording folder (with ``left/``, ``right/``, ``calibration/``, ``cameras.yaml``,
        see :mod:`hila_lang.perception.recording`), or the left frames (folder or video) when
        ``right`` is given.
    right : path, optional
        The right frames (folder or video).
    calibration_left, calibration_right : path, optional
        A calibration YAML or a folder of chessboard images per eye (default: the recording's
        ``calibration/left`` and ``calibration/right``).
    cameras : path, optional
        ``cameras.yaml`` (default: the recording's, or the one beside the left frames).
    stereo : path, optional
        A folder with ``left/`` and ``right/`` chessboard pairs seen by both eyes (default: the
        recording's ``calibration/stereo`` when it exists; without it the eyes' relative pose is
        the kinematics').
    k, tags, contact, seed
        Segmentation (:func:`hila_lang.segmentation.segment_template`).
    name : str
        Template name.
    max_gap : int
        Longest marker loss that is bridged, frames.

    Returns
    -------
    Template, or (Template, Perception) with ``return_perception``.
    """
    from ..segmentation import segment_template
    from ..template import Template
    from .calibration import calibrate_stereo
    from .recording import load_cameras, load_frames

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
    result = perceive(lframes, rframes, calibration, cams, stereo=stereo_cal, left_names=lnames,
                      right_names=rnames, max_gap=max_gap)
    result.seconds = {"load": t_load, "calibrate": t_cal, **result.seconds}
    desc = description or (
        f"Learned by perception (hila_lang.perception) from {len(lframes)} stereo frames at "
        f"{cams['fps']:g} Hz in {root}: hand marker detected sub-pixel in both iCub eye cameras, "
        f"undistorted with chessboard calibrations (RMS reprojection "
        f"{calibration['left'].rms:.3f} / {calibration['right'].rms:.3f} px), Gaussian RBF smoothed "
        f"(0.5 px), triangulated; points within {CONTACT_SNAP * 1000:g} mm of the paper put on it; ICPs tl, tr, br, bl = corners of cell {result.cell} read from the "
        f"images, hand = the first triangulated point. Segmented by k-means (k = {k}).")
    path = snap_contact(result.path, float(cams["surface_z"]))
    whole = Template(name=name, path=path, icps=result.icps, times=result.times, description=desc)
    template = segment_template(whole, k, list(tags), method="kmeans", seed=seed, contact=tuple(contact))
    return (template, result) if return_perception else template


def template_from_sim(seed: int = 0, *, k: int = 3, tags=DEFAULT_TAGS, contact=DEFAULT_CONTACT,
                      name: str = "circle", recording_dir=None, frames: int | None = None,
                      n_calibration: int = 40, n_stereo: int = 16, return_perception: bool = False):
    """Record the seeded demonstration in PyBullet, then learn it with :func:`template_from_frames`.

    ``recording_dir`` keeps the recording (default: a temporary folder, deleted afterwards);
    ``frames`` records only the first frames, ``n_calibration`` and ``n_stereo`` set the
    chessboard sessions (see :func:`hila_lang.perception.recording.record_demonstration`).
    """
    from .recording import record_demonstration

    def run(folder: Path):
        record_demonstration(folder, seed, n_calibration=n_calibration, n_stereo=n_stereo, overwrite=True,
                             frames=frames)
        out = template_from_frames(folder, k=k, tags=tags, contact=contact, name=name, seed=0,
                                   return_perception=return_perception)
        template = out[0] if return_perception else out
        template.description = (
            f"Learned by perception from a simulated recording: the seeded human-like demonstration "
            f"(hila_lang.games.demonstration, seed {seed}) performed by a green hand marker in "
            f"PyBullet, seen by the iCub's two eye cameras (320x240, 20 Hz, barrel lens distortion). "
            + template.description.split(f" in {folder}: ", 1)[-1]
            + f" Made by: hila learn --from-sim --seed {seed} -k {k} --tags {','.join(tags)}"
            + (f" --contact {','.join(contact)}" if contact else ""))
        return out

    if recording_dir is not None:
        return run(Path(recording_dir))
    with tempfile.TemporaryDirectory(prefix="hila_recording_") as tmp:
        return run(Path(tmp) / "recording")
