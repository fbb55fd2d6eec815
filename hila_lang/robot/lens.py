"""The eyes' lenses: the simulated fish-eye lens, and the robot's own calibration of it.

The real iCub's eyes are fish-eye (paper section III.C), in the demonstration and in the game
alike.  Each simulated eye renders through the lens model the demonstration is recorded with
(:class:`~hila_lang.perception.distortion.DistortedCamera` with the true intrinsics
:data:`ICUB_EYE_K` and the true coefficients
:data:`~hila_lang.perception.distortion.TRUE_DISTORTION`): that is the simulator's truth,
used to make images and never handed to the robot.

What the robot knows of its lenses it measured itself: :func:`eye_calibration` shows a printed
chessboard card to the eye at :data:`CALIBRATION_VIEWS` seeded poses and calibrates it with the
OpenCV pipeline of :mod:`hila_lang.perception.calibration` (the one ``hila learn`` uses for the
demonstration's eyes, with the same number of views and supersampling).  The result is kept in
the cache folder (``$HILA_CACHE_DIR/hila/lens`` or ``~/.cache/hila/lens``, written atomically;
:func:`hila_lang.core.fileio.cache_folders`) under a name that hashes everything it depends on, like
the generated robot model, so it is made once per installation: about 25 s for both eyes and the
pair here (a first ``hila exec programs/game.hila`` took 31.8 s instead of 5.3 s).

hila ships the three calibrations this procedure makes (:data:`SHIPPED`, read after the cache
folders; made by ``python -m hila_lang.robot.lens``, :func:`ship`), as a lab keeps the
calibration file of its robot: a first game after an install reads them instead of spending
those 25 s.  They are used only under the same name, that is, when everything the name hashes
(the lens, the views, the seeds, the eyes in the head, OpenCV's version) is the same; otherwise
the robot calibrates itself as above.  ``tests/test_robot_lens.py`` makes them again and
compares.
"""

from __future__ import annotations

import hashlib
import json
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..perception.rig import EYE_K as ICUB_EYE_K  # the simulated eyes' true intrinsics: rendering only
from ..perception.rig import HEIGHT as EYE_HEIGHT
from ..perception.rig import WIDTH as EYE_WIDTH
import os
import tempfile
from . import ik, model
from ..core.errors import InputError
from ..core.fileio import atomic_write_text
from ..core.fileio import cache_folders
from ..core.fileio import dump_yaml, load_yaml
from ..core.rotation import about_z, pose
from ..perception.calibration import PATTERN, SQUARE
from ..perception.calibration import StereoCalibration, calibrate_stereo, stereo_views
from ..perception.calibration import calibrate, chessboard_views, load_calibration, save_calibration
from ..perception.distortion import TRUE_DISTORTION
from ..perception.distortion import TRUE_DISTORTION, DistortedCamera, distort_points
from ..perception.rig import StereoRig
from ..sim.camera import Camera, CameraImage, project

#: chessboard images per eye and their supersampling: as the demonstration's recording
#: (:func:`hila_lang.perception.recording.write_recording`).  Measured here: 14 views at 2x left
#: the principal point 0.4 px off, 40 views at 4x 0.25 px (0.06 px RMS reprojection)
CALIBRATION_VIEWS = 40
CALIBRATION_SUPERSAMPLE = 4
#: the chessboard poses' seed per eye (the two eyes see different sessions, as the recording's)
CALIBRATION_SEEDS = {"left": 0, "right": 1000}
#: card poses seen by both eyes at once for the eyes' relative pose, and their seed (as the
#: recording's stereo session)
STEREO_PAIRS = 16
STEREO_SEED = 2000
#: bump to invalidate every cached calibration
_VERSION = "1"
#: the calibrations shipped with hila (module docstring), read after the cache folders
SHIPPED = Path(__file__).with_name("calibration")


#: pixels kept around a region's projection when an eye reads only part of its sensor
#: (:func:`sensor_window`): its calibration's and pose's errors are a fraction of a pixel
WINDOW_MARGIN = 4


def sensor_window(region, calib, world_T_camera: np.ndarray, margin: int = WINDOW_MARGIN,
                  width: int = EYE_WIDTH, height: int = EYE_HEIGHT) -> tuple[int, int, int, int] | None:
    """The sensor pixels ``(u0, v0, u1, v1)`` (end exclusive) that see the world points
    ``region`` (N, 3), as the robot's own calibration ``calib`` (``K``, ``dist``) and its own pose
    of the camera ``world_T_camera`` place them, grown by ``margin`` pixels: the part of an image a
    reader of that region needs.  None -- the whole image -- when a point is behind the camera or
    the region lies outside the image."""
    points = np.asarray(region, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0 or not np.all(np.isfinite(points)):
        raise InputError(f"an eye's region must be finite world points of shape (N, 3), got shape {points.shape}")
    uv = project(points, calib.K, world_T_camera)
    if not np.all(np.isfinite(uv)):
        return None
    uv = distort_points(uv, calib.K, calib.dist)
    u0, v0 = (max(0, int(np.floor(v)) - margin) for v in uv.min(axis=0))
    u1, v1 = (min(n, int(np.ceil(v)) + margin + 1) for v, n in zip(uv.max(axis=0), (width, height)))
    if u1 - u0 < 2 * margin or v1 - v0 < 2 * margin:
        return None
    return u0, v0, u1, v1


def through_lens(lens, render, world_T_camera: np.ndarray, window=None, shadow: bool = False) -> np.ndarray:
    """The image ``lens`` (a :class:`~hila_lang.perception.distortion.DistortedCamera`) makes at
    the camera pose ``world_T_camera`` (the simulator's: rendering only): all of it, or only its
    pixels ``window`` (:func:`sensor_window`), for which only the part of the ideal canvas they
    are made from is rendered (the same pixels, far fewer rendered)."""
    if window is None:
        ideal = lens.render_camera
        return lens.distort(render(Camera(ideal.K, world_T_camera, ideal.width, ideal.height), shadow=shadow))
    source = lens.window_source(window)
    part = lens.render_window(source)
    rgb = render(Camera(part.K, world_T_camera, part.width, part.height), shadow=shadow)
    return lens.distort_window(rgb, window, source)


def lens_image(rgb: np.ndarray, calib, world_T_camera: np.ndarray, joints, window) -> CameraImage:
    """A :class:`CameraImage` of a lens camera's pixels ``window`` (None: all), with the robot's
    calibration ``calib`` (its principal point moved to the window's frame) and pose."""
    K = calib.K.copy()
    if window is not None:
        K[0, 2] -= window[0]
        K[1, 2] -= window[1]
    return CameraImage(rgb, K, np.asarray(world_T_camera, dtype=float).copy(), rgb.shape[1], rgb.shape[0], joints,
                       tuple(float(v) for v in calib.dist))


def true_lens(supersample: int = 1):
    """The simulated eye lens at the origin: a
    :class:`~hila_lang.perception.distortion.DistortedCamera` (truth: renders only)."""
    return DistortedCamera(Camera(ICUB_EYE_K, np.eye(4), EYE_WIDTH, EYE_HEIGHT), TRUE_DISTORTION,
                           supersample=supersample)


def _key(opencv: str | None = None, **what) -> str:
    """A hash of ``what`` and everything a calibration depends on (``opencv``: the version to
    hash, default the one loaded)."""
    if opencv is None:
        # lazy: loads cv2, which importing this module does not
        import cv2

        opencv = cv2.__version__
    what.update({"K": ICUB_EYE_K.tolist(), "dist": list(TRUE_DISTORTION), "size": [EYE_WIDTH, EYE_HEIGHT],
                 "views": CALIBRATION_VIEWS, "supersample": CALIBRATION_SUPERSAMPLE, "pattern": list(PATTERN),
                 "square": SQUARE, "version": _VERSION, "opencv": opencv})
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()[:12]


def _cached(name: str, load, make, save):
    """``load(path)`` of the first cached (or shipped) ``name`` that reads, else ``make()`` saved
    with ``save(path, value)`` into the first writable cache folder."""
    folders = cache_folders("lens")
    for folder in [*folders, SHIPPED]:
        if (folder / name).is_file():
            try:
                return load(folder / name)
            except (InputError, KeyError, TypeError, ValueError):  # damaged: make it again
                print(f"note: the cached lens calibration {folder / name} cannot be read; making it again",
                      file=sys.stderr)
                break
    value = make(folders[0])
    for folder in folders:
        try:
            save(folder / name, value)
            break
        except OSError:
            continue
    return value


def _progress(text: str) -> None:
    if sys.stderr.isatty():
        print(f"hila: {text}", file=sys.stderr, flush=True)


@lru_cache(maxsize=None)
def eye_calibration(eye: str):
    """The robot's calibration of ``eye``'s lens (:class:`~hila_lang.perception.calibration.Calibration`):
    read from the cache, else made from simulated chessboard images and cached (see the module
    docstring).  A cache file that cannot be read is made again."""
    if eye not in CALIBRATION_SEEDS:
        raise InputError(f"eye must be 'left' or 'right', got {eye!r}")

    def make(folder):
        _progress(f"calibrating the iCub's {eye} eye from {CALIBRATION_VIEWS} chessboard images "
                  f"(once; kept in {folder})")
        images = chessboard_views(true_lens(CALIBRATION_SUPERSAMPLE), CALIBRATION_VIEWS, seed=CALIBRATION_SEEDS[eye])
        return calibrate(images, names=[f"{eye} chessboard {i}" for i in range(len(images))])

    def save(path, calib):
        save_calibration(path, calib, header=f"the iCub's {eye} eye calibrated from {calib.n_views} simulated "
                                             f"chessboard images (hila_lang.robot.lens); made once, delete to make again")

    return _cached(_eye_name(eye), load_calibration, make, save)


def _eye_name(eye: str, opencv: str | None = None) -> str:
    return f"eye_{eye}_{_key(opencv, eye=eye, seed=CALIBRATION_SEEDS[eye])}.yaml"


def _pair_name(opencv: str | None = None, head: np.ndarray | None = None) -> str:
    """The file name of the calibration of the pair whose right eye is at ``head`` (default the
    iCub's eyes in its head)."""
    head = eyes_in_head() if head is None else head
    key = _key(opencv, pairs=STEREO_PAIRS, seed=STEREO_SEED, head=np.round(head, 6).tolist(),
               left=CALIBRATION_SEEDS["left"], right=CALIBRATION_SEEDS["right"])
    return f"eyes_{key}.yaml"


def names(opencv: str | None = None) -> list[str]:
    """The file names of the three calibrations the iCub uses (each eye, its eye pair) for
    ``opencv``'s version (default the one loaded): what :data:`SHIPPED` must hold to be used.
    A stand rig's pair (another robot's eyes) is calibrated on first use and cached."""
    return [_eye_name("left", opencv), _eye_name("right", opencv), _pair_name(opencv)]


def eyes_in_head() -> np.ndarray:
    """``left_T_right`` (4, 4): the right eye camera in the left one's frame, from the head's
    model (the eyes tilt together, so it never changes): truth, to render the stereo session."""
    text = model.urdf_path().read_text()
    root = pose(about_z(model.ROOT_YAW), model.ROOT_POSITION)
    left, right = (ik.KinematicChain.from_urdf(text, model.EYE_LINKS[e], root) for e in ("left", "right"))
    q = np.zeros(left.dof)
    return np.linalg.inv(left.forward(q)[0]) @ right.forward(q)[0]


@lru_cache(maxsize=None)
def _head_pair() -> tuple:
    """:func:`eyes_in_head` as nested tuples, worked out once (it never changes; the URDF read
    twice for it took 10-24 ms at every look of the game)."""
    return tuple(map(tuple, eyes_in_head().tolist()))


def eyes_calibration():
    """The iCub's calibration of its eye pair: :func:`pair_calibration` of its head's eyes."""
    return pair_calibration(_head_pair(), "the iCub's eye pair")


@lru_cache(maxsize=None)
def pair_calibration(left_T_right: tuple, who: str = "a stereo rig"):
    """The robot's calibration of an eye pair whose right eye is at ``left_T_right`` (4x4 nested
    tuples: truth, to render the sessions; the lenses are the eyes' lens model), a
    :class:`~hila_lang.perception.calibration.StereoCalibration` (``right_T_left``), from a card both eyes see (:func:`~hila_lang.perception.calibration.stereo_views`,
    :func:`~hila_lang.perception.calibration.calibrate_stereo` with each eye's own calibration);
    cached like :func:`eye_calibration`.  Triangulating with it keeps the two eyes' rays
    consistent with their calibrated intrinsics (a principal point 0.1 px off moves a depth at
    0.5 m by about 1 mm)."""
    head = np.array(left_T_right, dtype=float)

    def make(folder):
        _progress(f"calibrating {who} from {STEREO_PAIRS} chessboard pairs (once; kept in {folder})")
        rig = StereoRig(Camera(ICUB_EYE_K, np.eye(4), EYE_WIDTH, EYE_HEIGHT),
                        Camera(ICUB_EYE_K, head, EYE_WIDTH, EYE_HEIGHT))  # the left eye at the origin
        lens = true_lens(CALIBRATION_SUPERSAMPLE)
        right = type(lens)(rig.right, lens.dist, supersample=CALIBRATION_SUPERSAMPLE)
        left_images, right_images = stereo_views(lens, right, rig, STEREO_PAIRS, seed=STEREO_SEED)
        return calibrate_stereo(left_images, right_images, eye_calibration("left"), eye_calibration("right"))

    def load(path):
        data = load_yaml(path, "eye pair calibration")
        return StereoCalibration(np.asarray(data["right_T_left"], float).reshape(4, 4), float(data["rms_px"]),
                                 int(data["n_pairs"]))

    def save(path, stereo):
        dump_yaml(path, {"right_T_left": stereo.right_T_left.tolist(), "rms_px": stereo.rms, "n_pairs": stereo.n_pairs},
                  header=f"{who} calibrated from simulated chessboard pairs (hila_lang.robot.lens)")

    return _cached(_pair_name(head=head), load, make, save)


#: what :data:`SHIPPED` was made with (the OpenCV version its names hash), beside the files
SHIPPED_MANIFEST = "made-with.json"


def ship(folder: str | Path | None = None) -> list[Path]:
    """Make the three calibrations afresh (nothing cached or shipped is read) and write them into
    ``folder`` (default :data:`SHIPPED`), replacing what was there, with :data:`SHIPPED_MANIFEST`.
    Returns the files written."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    global SHIPPED
    target = Path(folder) if folder is not None else SHIPPED
    with tempfile.TemporaryDirectory() as tmp:
        saved = SHIPPED, os.environ.get("HILA_CACHE_DIR")
        SHIPPED, os.environ["HILA_CACHE_DIR"] = Path(tmp) / "nothing-shipped", tmp
        eye_calibration.cache_clear()
        pair_calibration.cache_clear()
        try:
            wanted = names()
            eyes_calibration()  # and both eyes
        finally:
            SHIPPED = saved[0]
            if saved[1] is None:
                del os.environ["HILA_CACHE_DIR"]
            else:
                os.environ["HILA_CACHE_DIR"] = saved[1]
            eye_calibration.cache_clear()
            pair_calibration.cache_clear()
        target.mkdir(parents=True, exist_ok=True)
        for old in target.glob("*.yaml"):
            old.unlink()
        out = []
        for name in wanted:
            out.append(atomic_write_text(target / name, (Path(tmp) / "hila" / "lens" / name).read_text()))
        atomic_write_text(target / SHIPPED_MANIFEST, json.dumps({"opencv": cv2.__version__, "files": wanted}, indent=1))
    return out


if __name__ == "__main__":  # python -m hila_lang.robot.lens: make the shipped calibrations again
    for written in ship():
        print(written)
