"""Recording a demonstration with the iCub's eyes, and reading recorded frames back.

A *recording* is a folder::

    left/frame_00000.png ...      left eye, 320x240, 20 Hz, distorted like the real lens
    right/frame_00000.png ...     right eye, same count
    calibration/left/*.png        chessboard images shown to each eye before the demonstration
    calibration/right/*.png
    calibration/stereo/left/*.png a larger card seen by both eyes at once (pairs, same names)
    calibration/stereo/right/*.png
    cameras.yaml                  what the robot knows without looking: the eyes' poses from the
                                  head kinematics (world_T_camera), image size, frame rate, the
                                  plane of the demonstration table, the marker's offset above
                                  the pen tip
    truth.yaml                    ground truth for benchmarks and tests only (the pipeline
                                  never reads it): e.g. pen-tip path, times, ICPs, true K and lens

:func:`write_recording` writes one from any simulated scene (the tic-tac-toe world records its
demonstration with it: :func:`hila_lang.worlds.tictactoe.recording.record_demonstration`).

The folder is built under a temporary name beside the target and renamed into place when
complete, so a crash never leaves a half-written recording; every file is written atomically.

:func:`load_frames` reads a folder of images (sorted by name; numbered names must not skip a
number) or a video file, and turns every problem into :class:`~hila_lang.core.errors.InputError`
naming the file; :func:`iter_frames` gives the same frames one at a time, with their times.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

from ..core.errors import InputError
from ..core.fileio import dump_yaml, load_yaml, write_png
from ..core.images import read_picture
from ..sim.camera import Camera
from ..sim.client import quiet_c_output
from .calibration import chessboard_views, stereo_views
from .distortion import DistortedCamera, TRUE_DISTORTION
from .rig import FPS

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm")
#: supersampling of the chessboard images (the demonstration frames use 2x)
CALIBRATION_SUPERSAMPLE = 4
VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".m4v", ".webm", ".mpg", ".mpeg", ".y4m")


def read_image(path: str | os.PathLike) -> np.ndarray:
    """An image file as RGB (H, W, 3) uint8; :class:`InputError` when it cannot be read."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    return cv2.cvtColor(read_picture(path, "frame"), cv2.COLOR_BGR2RGB)  # its size checked before decoding


def frame_files(folder: str | os.PathLike, what: str = "frames") -> list[Path]:
    """Image files in ``folder``, sorted by name; a gap in their numbering is an error."""
    folder = Path(folder)
    if not folder.exists():
        raise InputError(f"{what} folder not found", file=str(folder))
    if not folder.is_dir():
        raise InputError(f"expected a folder of {what} or a video file", file=str(folder))
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith("."))
    if not files:
        raise InputError(f"no image files ({', '.join(IMAGE_SUFFIXES)}) in the {what} folder", file=str(folder))
    numbers = [re.findall(r"\d+", p.stem) for p in files]
    if all(numbers):
        nums = [int(n[-1]) for n in numbers]
        expected = set(range(nums[0], nums[0] + len(nums)))
        missing = sorted(set(range(min(nums), max(nums) + 1)) - set(nums))
        if missing or set(nums) != expected:
            shown = ", ".join(str(m) for m in missing[:10]) + (" ..." if len(missing) > 10 else "")
            raise InputError(f"missing {what}: frame number(s) {shown} absent between "
                             f"{files[0].name} and {files[-1].name}", file=str(folder))
    return files


def iter_frames(source: str | os.PathLike, what: str = "frames", fps: float = 30.0):
    """The frames of a folder of images or a video file, one at a time: ``(image RGB uint8, name,
    time in seconds)``, so a long video never sits in memory whole.

    A video's frame times are its own time stamps (a variable frame rate is kept), or the frame
    index over its frame rate where it has none; a folder's frames are ``fps`` apart.

    Raises
    ------
    InputError
        Missing folder or file, no images, a gap in the numbering, an unreadable image or video.
    """
    source = Path(source)
    if source.is_file() and source.suffix.lower() in VIDEO_SUFFIXES:
        yield from _read_video(source)
        return
    if source.is_file():
        raise InputError(f"expected a folder of images or a video file ({', '.join(VIDEO_SUFFIXES)})",
                         file=str(source))
    for i, p in enumerate(frame_files(source, what)):
        yield read_image(p), p.name, i / fps


def load_frames(source: str | os.PathLike, what: str = "frames") -> tuple[list[np.ndarray], list[str]]:
    """All frames of a folder of images or a video file: (images RGB uint8, names).

    Raises
    ------
    InputError
        Missing folder or file, no images, a gap in the numbering, an unreadable image or video,
        or frames of different sizes.
    """
    images, names = [], []
    for image, name, _ in iter_frames(source, what):
        images.append(image)
        names.append(name)
    shapes = {im.shape for im in images}
    if len(shapes) > 1:
        first = images[0].shape
        odd = next(n for n, im in zip(names, images) if im.shape != first)
        raise InputError(f"{what} differ in size: {names[0]} is {first[1]}x{first[0]}, {odd} is not",
                         file=str(source))
    return images, names


def _read_video(path: Path):
    """(RGB frame, name, time) of every frame of a video file, its own time stamps where it has them."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    with quiet_c_output():  # FFmpeg prints its own complaint (e.g. "moov atom not found")
        cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise InputError("cannot open video file", file=str(path))
    rate = cap.get(cv2.CAP_PROP_FPS)
    rate = rate if np.isfinite(rate) and 1.0 <= rate <= 1000.0 else 30.0
    count, last = 0, -1.0
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            stamp = cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0
            t = stamp if np.isfinite(stamp) and stamp > last else (last + 1.0 / rate if count else 0.0)
            last = t
            yield cv2.cvtColor(frame, cv2.COLOR_BGR2RGB), f"{path.name}#{count}", t
            count += 1
    finally:
        cap.release()
    if not count:
        raise InputError("video file has no readable frames", file=str(path))


def camera_to_dict(camera: Camera) -> dict:
    """The pose and size of a camera (not its intrinsics: those come from calibration)."""
    return {"world_T_camera": np.asarray(camera.world_T_camera).tolist(), "width": camera.width,
            "height": camera.height}


def load_cameras(path: str | os.PathLike) -> dict:
    """Read ``cameras.yaml``: ``{"left": {"world_T_camera": (4, 4), ...}, "right": ..., "fps": ...}``."""
    data = load_yaml(path, "cameras file")
    try:
        out = {"fps": float(data.get("fps", 20.0)), "surface_z": float(data["surface_z"]),
               "marker_offset": np.asarray(data.get("marker_offset", [0, 0, 0]), float).reshape(3)}
        for eye in ("left", "right"):
            T = np.asarray(data[eye]["world_T_camera"], float)
            if T.shape != (4, 4) or not np.isfinite(T).all():
                raise ValueError(f"{eye}.world_T_camera must be 4x4 numbers, got shape {T.shape}")
            out[eye] = {"world_T_camera": T, "width": int(data[eye]["width"]), "height": int(data[eye]["height"])}
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"cameras file: expected left/right world_T_camera, width, height and surface_z; "
                         f"problem: {exc}", file=str(path)) from None
    return out


def write_recording(out_dir: str | os.PathLike, rig, frames: int, render: Callable, *, surface_z: float,
                    marker_offset=(0.0, 0.0, 0.0), truth: dict | None = None, seed: int = 0,
                    n_calibration: int = 40, n_stereo: int = 16, overwrite: bool = False) -> Path:
    """Write a recording folder (see the module docstring) of a simulated scene.

    Parameters
    ----------
    out_dir : path
        The recording folder to create.
    rig : StereoRig
        The true (undistorted) eye cameras (:mod:`hila_lang.perception.rig`).
    frames : int
        Number of frame pairs.
    render : callable
        ``render(i, camera) -> RGB (H, W, 3) uint8``: frame ``i`` seen by an ideal ``camera``
        (the scene moved to time ``i`` first); it is distorted here like the real lenses.
    surface_z : float
        World z of the demonstration table's paper (written to ``cameras.yaml``).
    marker_offset : (3,)
        How far the tracked marker's centre is above the pen tip, metres.
    truth : dict, optional
        Ground truth for ``truth.yaml`` (benchmarks and tests only); the true K and lens are added.
    seed : int
        Seed of the chessboard poses.
    n_calibration, n_stereo : int
        Chessboard images per eye; pairs seen by both eyes at once (0: none).
    overwrite : bool
        Replace an existing folder (otherwise an existing non-empty folder is an error).
    """
    out = Path(out_dir)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise InputError("recording folder exists and is not empty (use overwrite)", file=str(out))
    cams = {eye: DistortedCamera(rig.camera(eye), TRUE_DISTORTION) for eye in ("left", "right")}
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        for eye in ("left", "right"):
            # corner localisation needs faithful edge profiles: the card is rendered at 4x
            dcam = DistortedCamera(rig.camera(eye), TRUE_DISTORTION, supersample=CALIBRATION_SUPERSAMPLE)
            for i, img in enumerate(chessboard_views(dcam, n_calibration, seed=seed + (0 if eye == "left" else 1000))):
                write_png(tmp / "calibration" / eye / f"chess_{i:03d}.png", img)
        if n_stereo:
            sl, sr = (DistortedCamera(rig.camera(e), TRUE_DISTORTION, supersample=CALIBRATION_SUPERSAMPLE)
                      for e in ("left", "right"))
            for i, (a, b) in enumerate(zip(*stereo_views(sl, sr, rig, n_stereo, seed=seed + 2000))):
                write_png(tmp / "calibration" / "stereo" / "left" / f"pair_{i:03d}.png", a)
                write_png(tmp / "calibration" / "stereo" / "right" / f"pair_{i:03d}.png", b)
        for i in range(frames):
            for eye, dcam in cams.items():
                write_png(tmp / eye / f"frame_{i:05d}.png", dcam.distort(render(i, dcam.render_camera)))
        dump_yaml(tmp / "cameras.yaml", {
            "fps": FPS, "surface_z": surface_z, "marker_offset": np.asarray(marker_offset, float).tolist(),
            "left": camera_to_dict(rig.left), "right": camera_to_dict(rig.right)},
            header="eye camera poses from the iCub's head kinematics while it watched (world frame, metres)")
        dump_yaml(tmp / "truth.yaml", {**(truth or {}), "K": rig.left.K.tolist(), "dist": list(TRUE_DISTORTION)},
                  header="ground truth of the simulated recording: for benchmarks and tests only")
        if out.exists():
            shutil.rmtree(out)
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out
