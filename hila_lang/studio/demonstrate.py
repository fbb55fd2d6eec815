"""Demonstrate: scenes to draw on, pointer samples -> a timed path, and saving it as ``hila learn`` does.

Scenes (:func:`scene`): ``blank`` (a white sheet), ``upload:NAME`` (a picture in the studio's
folder) and ``tictactoe`` (the demonstration grid as the iCub's left eye sees it while it
watches, :func:`hila_lang.worlds.tictactoe.recording.demonstration_rig`).  Each comes with
``H``, the 3x3 homography from the drawing plane's (x, y) in metres to the picture's pixels; the
page inverts it for a click.  A sheet or a picture is a 2-D plane at
:data:`SHEET_M_PER_PX` metres per pixel; the tic-tac-toe scene is the paper's plane z =
``surface_z`` seen through the eye's pinhole (the paper is flat, so the map is a homography).

A demonstration is the person's pointer samples, each ``{x, y, t, down, p}``: plane point
(metres), the event's own time stamp (milliseconds), pen on the paper or not, pressure.  Pen-up
moves between strokes are part of the path (the paper's reach / draw / retract).  On a 3-D
surface a pen-up sample is lifted by :func:`lift`: it rises at 45 degrees from where the pen
left the paper and comes down at 45 degrees to where it next touches, no higher than
:data:`LIFT_MAX`.  The path is then resampled in time at 20 Hz, the eye cameras' rate (the rate
of every demonstration in hila: :data:`hila_lang.evaluation.lasa.RATE_HZ`).

Saving (:func:`save`) writes the demonstration as ``NAME.demo.csv`` and its ICPs as
``NAME.icps.yaml`` in the studio's folder and runs ``hila learn``'s own command on them, so the
template is byte for byte what ``hila learn NAME.demo.csv --icps NAME.icps.yaml ...`` writes.  Cuts
the person dragged away from the method's replace its segments afterwards (the description says so).
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from ..core.errors import InputError

#: metres per pixel of a blank sheet or an uploaded picture: 0.25 mm, so an 840-pixel-wide
#: canvas is an A4 sheet's width (0.21 m)
SHEET_M_PER_PX = 0.00025
#: highest lift of the pen above the paper while it is up, metres: the tic-tac-toe world's
#: highest park height above the paper (hila_lang.worlds.tictactoe.world.PARK_HEIGHT)
LIFT_MAX = 0.13
SHEET_SIZE = (840, 600)


def _sheet_H(height: int) -> np.ndarray:
    """Plane (x right, y up; metres) -> pixels (u right, v down), origin at the bottom-left."""
    s = 1.0 / SHEET_M_PER_PX
    return np.array([[s, 0.0, 0.0], [0.0, -s, float(height)], [0.0, 0.0, 1.0]])


@functools.lru_cache(maxsize=1)
def _tictactoe():
    """(PNG bytes, camera, grid spec) of the demonstration sheet seen by the left eye, at twice
    the eye's resolution (rendered once per studio: it starts a PyBullet client)."""
    import cv2

    from ..worlds.tictactoe.board import Grid
    from ..worlds.tictactoe.recording import DemonstrationScene, demonstration_rig

    spec = Grid.demonstration()
    eye = demonstration_rig(spec).left
    camera = eye.with_size(eye.width * 2, eye.height * 2, scale=2.0)
    with DemonstrationScene(spec, marker=False) as sc:
        rgb = sc.render(camera)
    ok, png = cv2.imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
    return png.tobytes(), camera, spec


def plane_homography(camera, z: float) -> np.ndarray:
    """3x3 H with pixel ~ H @ (x, y, 1) for world points (x, y, z) of the plane at height z."""
    camera_T_world = np.linalg.inv(camera.world_T_camera)
    R, t = camera_T_world[:3, :3], camera_T_world[:3, 3]
    H = camera.K @ np.column_stack([R[:, 0], R[:, 1], R[:, 2] * z + t])
    return H / H[2, 2]


def tictactoe_features(spec) -> list[dict]:
    """Every cell's corners (the grid's 16 line crossings, each named by every cell it is a corner
    of: ``cell5.tl`` is ``cell1.br``), as the places an ICP snaps to."""
    from ..worlds.tictactoe.board import cell_corners

    return [{"name": f"cell{cell}.{corner}", "point": [float(v) for v in p]}
            for cell in range(1, 10) for corner, p in cell_corners(spec, cell).items()]


def scene(name: str, folder: Path) -> dict:
    """What the page draws on: ``{name, image, width, height, H, z, features}`` (``image`` is the
    URL path of the picture, or None for a blank sheet; ``z`` the surface height of a 3-D scene)."""
    from .security import inside

    if name == "blank":
        w, h = SHEET_SIZE
        return dict(name=name, image=None, width=w, height=h, H=_sheet_H(h).tolist(), z=None, features=[])
    if name == "tictactoe":
        png, camera, spec = _tictactoe()
        return dict(name=name, image="/api/scene-image/tictactoe", width=camera.width, height=camera.height,
                    H=plane_homography(camera, spec.surface_z).tolist(), z=spec.surface_z,
                    features=tictactoe_features(spec))
    if name.startswith("upload:"):
        import cv2

        path = inside(folder, name[len("upload:"):])
        from ..core.fileio import read_bytes

        image = cv2.imdecode(np.frombuffer(read_bytes(path, "picture"), np.uint8), cv2.IMREAD_COLOR)
        if image is None:
            raise InputError(f"{name[7:]}: not a picture (expected a PNG or JPEG file)")
        h, w = image.shape[:2]
        return dict(name=name, image=f"/api/raw?path={name[7:]}", width=w, height=h, H=_sheet_H(h).tolist(),
                    z=None, features=[])
    raise InputError(f"unknown scene {name!r}; expected blank, tictactoe or upload:FILE")


def scene_image(name: str) -> bytes:
    if name != "tictactoe":
        raise InputError(f"no rendered scene {name!r}")
    return _tictactoe()[0]


def lift(xy: np.ndarray, down: np.ndarray, z: float, lift_max: float = LIFT_MAX) -> np.ndarray:
    """:func:`hila_lang.osila.demofile.lift` (the rule is shared with the pointer model of
    :mod:`hila_lang.worlds.tictactoe.drawing`), at most :data:`LIFT_MAX` by default."""
    from ..osila.demofile import lift as lifted

    return lifted(xy, down, z, lift_max)


def demonstration_path(samples: list, z: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Pointer samples -> (path (T, D), times (T,) seconds from 0), resampled at 20 Hz.

    Samples whose time stamp does not increase are dropped (a coalesced duplicate);
    fewer than 2 left is an InputError.
    """
    from ..evaluation.lasa import RATE_HZ, resample_in_time

    if not isinstance(samples, list):
        raise InputError("expected the demonstration as a list of pointer samples")
    rows = []
    for i, s in enumerate(samples):
        try:
            rows.append((float(s["t"]), float(s["x"]), float(s["y"]), bool(s.get("down", False))))
        except (KeyError, TypeError, ValueError):
            raise InputError(f"sample {i}: expected {{x, y, t, down}} numbers, got {s!r}") from None
    kept = []
    for r in rows:
        if np.isfinite(r[:3]).all() and (not kept or r[0] > kept[-1][0]):
            kept.append(r)
    if len(kept) < 2:
        raise InputError("draw something first: a demonstration needs at least 2 pointer samples")
    arr = np.array([r[:3] for r in kept])
    down = np.array([r[3] for r in kept])
    t = (arr[:, 0] - arr[0, 0]) / 1000.0
    pts = arr[:, 1:] if z is None else lift(arr[:, 1:], down, z)
    path = resample_in_time(t, pts, RATE_HZ)
    return path, np.arange(len(path)) / RATE_HZ


def proposal(path, times, k: int, method: str, seed: int = 0) -> dict:
    """The cuts hila proposes (``hila learn``'s :func:`hila_lang.osila.segmentation.segments`) and the
    hand's speed under the path."""
    from ..osila.segmentation import segments, speed

    path = np.asarray(path, float)
    times = np.asarray(times, float)
    ranges = segments(path, int(k), method, times=times, seed=int(seed))
    return dict(cuts=[int(a) for a, _ in ranges[1:]], speed=[float(v) for v in speed(path, times)])


def _csv(path: np.ndarray, times: np.ndarray | None) -> str:
    """The demonstration CSV ``hila learn`` reads (:func:`hila_lang.osila.demofile.demo_csv_text`)."""
    from ..osila.demofile import demo_csv_text

    return demo_csv_text(path, times)


def save(folder: Path, req: dict) -> dict:
    """Write ``NAME.demo.csv``, ``NAME.icps.yaml`` and ``NAME.yaml`` (through ``hila learn``'s
    command) in ``folder``; returns ``{template, demo, icps, command, segments}``.

    ``req``: ``name``, ``path`` (T, D), ``times`` (T,), ``icps`` {name: point}, ``tags``
    (list), ``contact`` (list), ``method``, ``seed`` and optional ``cuts`` (k - 1 indices).
    """
    import argparse
    import contextlib
    import io

    import yaml

    from ..commands import learn
    from ..core.fileio import atomic_write_text
    from ..language.transformer import usable_as_tag
    from ..osila.template import Segment, check_segments, load_template, save_template
    from .security import inside

    name = str(req.get("name", "")).strip()
    if not usable_as_tag(name):
        raise InputError(f"template name {name!r}: a program imports it by name, so use a letter or '_' and "
                         "then letters, digits or '_'")
    path = np.asarray(req.get("path"), float)
    times = np.asarray(req.get("times"), float)
    if path.ndim != 2 or path.shape[1] not in (2, 3) or len(times) != len(path):
        raise InputError(f"expected a path (T, 2 or 3) with T times, got {path.shape} and {times.shape}")
    icps = req.get("icps") or {}
    if not icps:
        raise InputError("place at least one ICP (click on the scene) before saving")
    tags = [str(t) for t in req.get("tags") or []]
    contact = [str(t) for t in req.get("contact") or []]
    method = str(req.get("method", "speed"))
    target = inside(folder, f"{name}.yaml")
    demo = inside(folder, f"{name}.demo.csv")
    icps_file = inside(folder, f"{name}.icps.yaml")
    atomic_write_text(demo, _csv(path, times))
    atomic_write_text(icps_file, yaml.safe_dump({str(k): [float(v) for v in p] for k, p in icps.items()},
                                                sort_keys=False, default_flow_style=None))
    argv = [str(demo), "--icps", str(icps_file), "-k", str(max(len(tags), 1)), "--method", method,
            "--seed", str(int(req.get("seed", 0))), "-o", str(target)]
    if tags:
        argv += ["--tags", ",".join(tags)]
    if contact:
        argv += ["--contact", ",".join(contact)]
    parser = argparse.ArgumentParser(prog="hila learn")
    learn.add_arguments(parser)
    with contextlib.redirect_stdout(io.StringIO()):
        learn.run(parser.parse_args(argv))
    command = "hila learn " + " ".join(argv)
    cuts = req.get("cuts")
    template = load_template(target)
    proposed = [s.start for s in template.segments[1:]]
    if cuts is not None and tags and [int(c) for c in cuts] != proposed:
        bounds = [0, *[int(c) for c in cuts], len(path)]
        segs = [Segment(tag, bounds[i], bounds[i + 1], tag in contact) for i, tag in enumerate(tags)]
        check_segments(segs, len(path), "cuts")
        template.segments = segs
        template.description += f" Cuts moved by hand in hila studio to {[int(c) for c in cuts]} (proposed {proposed})."
        save_template(template, target)
    return dict(template=target.name, demo=demo.name, icps=icps_file.name, command=command,
                segments=[dict(tag=s.tag, start=s.start, stop=s.stop, contact=s.contact) for s in template.segments])


def template_json(template) -> dict:
    """A template as the page draws it."""
    return dict(name=template.name, path=template.path.tolist(),
                times=None if template.times is None else template.times.tolist(),
                icps={k: v.tolist() for k, v in template.icps.items()},
                segments=[dict(tag=s.tag, start=s.start, stop=s.stop, contact=s.contact) for s in template.segments],
                description=template.description, dim=int(template.path.shape[1]))


def open_source(folder: Path, kind: str, name: str) -> dict:
    """An existing demonstration to edit: ``template`` (a YAML in the folder), ``csv`` (a
    demonstration CSV in the folder, ICPs from ``NAME.icps.yaml`` beside it when there is one)
    or ``lasa`` (a LASA shape's first demonstration, resampled at 20 Hz as ``hila eval`` does)."""
    from .security import inside

    if kind == "template":
        from ..osila.template import load_template

        return template_json(load_template(inside(folder, name)))
    if kind == "csv":
        from ..osila.demofile import load_icps, read_demo_csv

        file = inside(folder, name)
        path, times = read_demo_csv(file)
        side = file.with_name(file.name.replace(".demo.csv", "").replace(".csv", "") + ".icps.yaml")
        icps = load_icps(side, path.shape[1]) if side.exists() else {}
        return dict(name=file.stem.replace(".demo", ""), path=path.tolist(),
                    times=None if times is None else times.tolist(), icps=icps, segments=[],
                    description=f"from {name}", dim=int(path.shape[1]))
    if kind == "lasa":
        from ..evaluation import lasa

        if name not in lasa.all_shapes():
            raise InputError(f"no LASA shape {name!r}; expected one of {', '.join(lasa.all_shapes())}")
        trial = lasa.load((name,))[0]
        path = trial.path  # in the data set's own units, as hila eval --dataset lasa uses them
        return dict(name=name, path=path.tolist(), times=(np.arange(len(path)) / lasa.RATE_HZ).tolist(),
                    icps={}, segments=[], description=f"LASA {name}, demo 1 (the data set's own units)", dim=2)
    raise InputError(f"unknown source {kind!r}; expected template, csv or lasa")
