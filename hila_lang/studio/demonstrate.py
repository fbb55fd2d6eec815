"""The Demonstrate page: scenes to draw on, pointer samples -> a timed path, saved as ``hila learn`` does.

Scenes (:func:`scenes`, :func:`scene`): ``blank`` (a white sheet), ``upload:NAME`` (a picture in
the studio's folder) and ``world:NAME``, the scene a world plug-in offers
(:class:`hila_lang.plugins.studio.DrawingScene`, e.g. a sheet as the robot's eye sees it).  Each
comes with ``H``, the 3x3 homography from the drawing plane's (x, y) in metres to the picture's
pixels; the page inverts it for a click.  A sheet or a picture is a 2-D plane at
:data:`SHEET_M_PER_PX` metres per pixel; a world's scene may be a plane at a height ``z`` seen
through a camera, so a drawing on it is a 3-D path.

A demonstration is the person's pointer samples, each ``{x, y, t, down, p}``: plane point
(metres), the event's own time stamp (milliseconds), pen on the paper or not, pressure.  Pen-up
moves between strokes are part of the path (the paper's reach / draw / retract).  On a 3-D
surface a pen-up sample is lifted by :func:`lift`: it rises at 45 degrees from where the pen
left the paper and comes down at 45 degrees to where it next touches, no higher than the scene's
``lift``.  The path is then resampled in time at 20 Hz, the eye cameras' rate (the rate
of every demonstration in hila: :data:`hila_lang.evaluation.lasa.RATE_HZ`).

Saving (:func:`save`) writes the demonstration as ``NAME.demo.csv`` and its ICPs as
``NAME.icps.yaml`` in the studio's folder and learns them with ``hila learn``'s own function
(:func:`hila_lang.hierarchy.learn.learn_files`), so the template is byte for byte what ``hila
learn NAME.demo.csv --icps NAME.icps.yaml ...`` writes.  Cuts the person dragged away from the
method's replace its segments afterwards (the description says so).

A route drawn on an uploaded picture is made a world's scene by :mod:`.photoscene`.

Routes: ``GET /api/scenes``, ``GET /api/scene?name=``, ``GET /api/scene-image?name=``, ``POST
/api/demonstration`` (samples -> path, times, speed and proposed cuts), ``POST /api/save``, ``GET
/api/open?kind=&name=`` (a template, CSV or LASA shape to edit), ``GET /api/lasa``; the Camera
scene's (:mod:`.camera`: a pen on the printed sheet before the webcam) and ``POST
/api/picture-scene`` (:mod:`.photoscene`).
"""

from __future__ import annotations

from pathlib import Path, PurePosixPath

import numpy as np
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route

from ..core.errors import InputError
from ..osila.demofile import lift  # the 45-degree lift rule, shared with the seeded pointer model
from . import camera, files, photoscene, schema, worker
from .photoscene import pictures, picture_worlds
from .save import _names, learned, recorded_pen, save  # noqa: F401 - save: called by the tests as the page saves
from .page import gone, Page, read_json, studio_of, template_json
from .schema import query
from .security import inside, opened
from ..evaluation import lasa as data
from ..evaluation.lasa import RATE_HZ, resample_in_time
from ..osila.segmentation import segments, speed
from ..plugins import registry
from .schema import MAX_SECONDS

#: metres per pixel of a blank sheet or an uploaded picture: 0.25 mm, so an 840-pixel-wide
#: canvas is an A4 sheet's width (0.21 m)
SHEET_M_PER_PX = 0.00025
SHEET_SIZE = (840, 600)
#: an uploaded picture is shown no larger than this (width, height; pixels): the sheet's width and a
#: height that leaves the cuts and Save on a 1000-pixel-high window
SHOWN_MAX = (840, 640)


def _sheet_H(height: int) -> np.ndarray:
    """Plane (x right, y up; metres) -> pixels (u right, v down), origin at the bottom-left."""
    s = 1.0 / SHEET_M_PER_PX
    return np.array([[s, 0.0, 0.0], [0.0, -s, float(height)], [0.0, 0.0, 1.0]])


def scenes(folder: Path | None = None) -> list[dict]:
    """What the page offers to draw on: ``[{name, label}]``, a blank sheet, every world's scene, the
    Camera scene (:mod:`.camera`) and the pictures in ``folder`` itself (where an upload goes) --
    not those in its subfolders, which are what runs wrote (a game's eye.png, top.png, ...)."""
    return [dict(name="blank", label="blank sheet")] + [
        dict(name=f"world:{info.name}", label=info.studio.scene_label or info.name)
        for info in registry.declarations("world") if info.studio is not None and info.studio.scene] + [
        dict(name="camera", label="camera: a pen on the printed sheet")] + [
        dict(name=f"upload:{f}", label=f"picture {f}") for f in pictures(folder)]


def _world_scene(name: str):
    """The :class:`~hila_lang.plugins.studio.DrawingScene` world ``name`` offers."""
    info = registry.world(name)
    if info.studio is None or not info.studio.scene:
        raise InputError(f"world {name!r} offers no scene to draw on")
    return info.studio.load("scene")()


def scene(name: str, folder: Path) -> dict:
    """What the page draws on: ``{name, image, width, height, H, z, lift, features}`` (``image`` is
    the URL path of the picture, or None for a blank sheet; ``z`` the surface height of a 3-D scene
    and ``lift`` the pen's highest rise above it; ``features`` the points an ICP snaps to,
    ``[{name, point}]``)."""
    if name == "blank":
        w, h = SHEET_SIZE
        return dict(name=name, image=None, width=w, height=h, H=_sheet_H(h).tolist(), z=None, features=[], lift=None)
    if name == "camera":  # the printed sheet from above, until a recording says which (studio/camera.py)
        # lazy: only this branch needs it
        from ..perception.sheet import SheetLayout

        return camera.sheet_scene(SheetLayout("a4", grid=True))
    if name.startswith("world:"):
        sc = _world_scene(name[len("world:"):])
        return dict(name=name, image=f"/api/scene-image?name={name}", width=sc.width, height=sc.height,
                    H=np.asarray(sc.H, float).tolist(), z=sc.z, lift=sc.lift,
                    features=[dict(name=n, point=list(p)) for n, p in sc.features])
    if name.startswith("upload:"):
        # lazy: only this branch needs it
        from ..core.images import read_picture

        with opened(folder, name[len("upload:"):], "uploaded image") as picture:
            h, w = read_picture(picture, "uploaded image").shape[:2]
        f = min(1.0, SHOWN_MAX[0] / w, SHOWN_MAX[1] / h)  # scaled to fit; the plane stays the picture's own
        H = np.diag([f, f, 1.0]) @ _sheet_H(h)
        return dict(name=name, image=f"/api/raw?path={name[7:]}", width=max(1, round(w * f)),
                    height=max(1, round(h * f)), H=H.tolist(), z=None, features=[], lift=None,
                    picture=dict(file=name[len("upload:"):], width=w, height=h, m_per_px=SHEET_M_PER_PX,
                                 worlds=picture_worlds()))
    raise InputError(f"unknown scene {name!r}; expected blank, camera, world:NAME or upload:FILE")


def scene_image(name: str) -> bytes:
    if not name.startswith("world:"):
        raise InputError(f"no rendered scene {name!r}")
    return _world_scene(name[len("world:"):]).png


def demonstration_path(samples: list, z: float | None,
                       lift_max: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pointer samples -> (path (T, D), times (T,) seconds from 0, pen (T,) bool), resampled at
    20 Hz; on the plane at height ``z`` (None: 2-D) pen-up samples are lifted (:func:`lift`) up to
    ``lift_max``.  ``pen`` is the pointer's down state resampled (down where the nearest moments
    are mostly down): what ``hila learn`` cuts by (``--method contact``).

    Samples whose time stamp does not increase are dropped (a coalesced duplicate);
    fewer than 2 left is an InputError.
    """
    if not isinstance(samples, list):
        raise InputError("expected the demonstration as a list of pointer samples")
    if z is not None and lift_max is None:
        raise InputError("a demonstration on a plane at a height (z) needs the pen's highest lift above it (lift)")
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
    if t[-1] > MAX_SECONDS:  # resampled at 20 Hz, a longer span would be a path of any length
        raise InputError(f"the demonstration lasts {t[-1]:.0f} s; the studio takes at most {MAX_SECONDS:.0f} s "
                         "(its time stamps are milliseconds)")
    pts = arr[:, 1:] if z is None else lift(arr[:, 1:], down, float(z), float(lift_max))
    both = resample_in_time(t, np.column_stack([pts, down.astype(float)]), RATE_HZ)
    return both[:, :-1], np.arange(len(both)) / RATE_HZ, both[:, -1] > 0.5


def proposal(path, times, k: int, method: str, seed: int = 0, pen=None) -> dict:
    """The cuts hila proposes (``hila learn``'s :func:`hila_lang.osila.segmentation.segments`) and the
    hand's speed under the path; ``method`` ``contact`` cuts by the recorded ``pen``."""
    path = np.asarray(path, float)
    times = np.asarray(times, float)
    ranges = segments(path, int(k), method, times=times, seed=int(seed), pen=pen)
    return dict(cuts=[int(a) for a, _ in ranges[1:]], speed=[float(v) for v in speed(path, times)])


def open_source(folder: Path, kind: str, name: str) -> dict:
    """An existing demonstration to edit: ``template`` (a YAML in the folder), ``csv`` (a
    demonstration CSV in the folder, ICPs from ``NAME.icps.yaml`` beside it when there is one)
    or ``lasa`` (a LASA shape's first demonstration, resampled at 20 Hz as ``hila eval`` does)."""
    if kind == "template":
        # lazy: only this branch needs it
        from ..osila.template import load_template

        with opened(folder, name, "template") as file:
            return template_json(load_template(file))
    if kind == "csv":
        # lazy: only this branch needs it
        from ..osila.demofile import load_icps, read_demo

        file = inside(folder, name)
        with opened(folder, name, "demonstration CSV") as csv:
            path, times, pen = read_demo(csv)
        side = str(PurePosixPath(name).with_name(file.name.replace(".demo.csv", "").replace(".csv", "") + ".icps.yaml"))
        try:  # the sidecar opened as the CSV was: inside the folder, no link followed (issue 32)
            with opened(folder, side, "scene ICP file") as sidecar:
                icps = load_icps(sidecar, path.shape[1])
        except InputError as exc:
            if not exc.message.startswith("no scene ICP file"):
                raise
            icps = {}
        return dict(name=file.stem.replace(".demo", ""), path=path.tolist(),
                    times=None if times is None else times.tolist(), icps=icps, segments=[],
                    pen=None if pen is None else pen.tolist(),
                    description=f"from {name}", dim=int(path.shape[1]))
    if kind == "lasa":
        # lazy: only this branch needs it
        from ..evaluation import lasa

        if name not in lasa.all_shapes():
            raise InputError(f"no LASA shape {name!r}; expected one of {', '.join(lasa.all_shapes())}")
        trial = lasa.load((name,))[0]
        path = trial.path  # in the data set's own units, as hila eval --dataset lasa uses them
        return dict(name=name, path=path.tolist(), times=(np.arange(len(path)) / lasa.RATE_HZ).tolist(),
                    icps={}, segments=[], description=f"LASA {name}, demo 1 (the data set's own units)", dim=2)
    raise InputError(f"unknown source {kind!r}; expected template, csv or lasa")


def demonstration(doc: dict) -> dict:
    """``{samples, z, lift}`` (pointer samples on a scene) or ``{path, times[, pen]}`` -> the path,
    its times and pen, the hand's speed and the cuts proposed for ``k`` segments by ``method``
    (default: ``contact`` -- where the pen touches and leaves the paper -- when the pen is
    recorded, as ``hila learn`` does)."""
    if "samples" in doc:
        path, times, pen = demonstration_path(doc["samples"], doc.get("z"), doc.get("lift"))
    elif "path" not in doc:
        raise InputError("expected the demonstration as samples (pointer samples) or a path")
    else:
        path = np.asarray(doc["path"], float)
        times = np.asarray(doc["times"] if doc.get("times") is not None else np.arange(len(path)) * 0.05)
        pen = recorded_pen(doc, len(path))
    method = doc.get("method") or ("contact" if pen is not None else "speed")
    out = dict(path=path.tolist(), times=times.tolist(), pen=None if pen is None else pen.tolist(), method=method)
    out.update(proposal(path, times, int(doc.get("k", 3)), method, doc.get("seed", 0), pen))
    return out


# ----------------------------------------------------------------------------- routes


async def _scenes(request: Request) -> Response:
    return JSONResponse(await run_in_threadpool(scenes, studio_of(request).folder))


async def _scene(request: Request) -> Response:
    name = query(request, schema.SCENE_QUERY).get("name", "blank")
    return JSONResponse(await run_in_threadpool(scene, name, studio_of(request).folder))


async def _scene_image(request: Request) -> Response:
    data = await run_in_threadpool(scene_image, query(request, schema.SCENE_QUERY).get("name", ""))
    return Response(data, media_type="image/png")


async def _demonstration(request: Request) -> Response:
    return JSONResponse(await worker.run(demonstration, await read_json(request), gone=gone(request)))


async def _save(request: Request) -> Response:
    doc, folder = await read_json(request), studio_of(request).folder
    overwrite = bool(doc.get("overwrite"))
    files.refuse_existing(folder, _names(doc), overwrite)  # 409 before the work
    texts, answer = await worker.run(learned, folder, doc, gone=gone(request))  # off the event loop, in its budget
    await run_in_threadpool(lambda: files.write(folder, texts, overwrite=overwrite))
    return JSONResponse(answer)


async def _open(request: Request) -> Response:
    q = query(request, schema.OPEN_QUERY)
    return JSONResponse(await run_in_threadpool(open_source, studio_of(request).folder, q["kind"], q["name"]))


async def _lasa(request: Request) -> Response:
    return JSONResponse({"shapes": list(data.all_shapes()) if data.available() else []})


PAGE = Page("demo", "1 Demonstrate", "demonstrate.js", routes=[
    Route("/api/scenes", _scenes),
    Route("/api/scene", _scene),
    Route("/api/scene-image", _scene_image),
    Route("/api/demonstration", _demonstration, methods=["POST"]),
    Route("/api/save", _save, methods=["POST"]),
    Route("/api/open", _open),
    Route("/api/lasa", _lasa),
    *camera.ROUTES,  # the Camera scene (studio/camera.py, static/camera.js)
    *photoscene.ROUTES,  # a route drawn on an uploaded picture made a world's scene (studio/photoscene.py)
])
