"""The picture world's demonstration and the template learned from it (``primitives/picture.yaml``).

A person traces a route on the map sheet lying flat at the demonstration pose
(:func:`hila_lang.worlds.picture.scenes.demo_sheet`, texture seed :data:`TEXTURE_SEED`) while
the robot watches.  The motion model (seed :data:`ROUTE_SEED`): the hand starts at
:data:`~.scenes.HOME`, reaches the route's start in a minimum-jerk move (2 s), traces the route
(:func:`~.scenes.route_uv`, 10 s at constant speed along the spline's parameter) with 0.2 mm
tremor, and lifts 8 cm (1.5 s); 20 Hz.  Segments: ``reach``, ``draw`` (contact), ``lift``.

The template's ICPs are what the robot saw before the trace: its eyes' features of the sheet
triangulated with its own calibration (:func:`demonstration_features`), named ``f000``,
``f001``, ... in the order :func:`hila_lang.perception.matching.scene_features` gives them,
plus ``start`` (the hand).  The world sees the same demonstration again when it starts (the
renderer is deterministic) and refuses a template whose ICPs are not these.

A person's own picture and route (``--image FILE --route ROUTE.yaml``): the picture is printed on
the sheet (:func:`~.texture.person_page`: whole, its shape kept, centred), the robot's eyes find
their features on it, and the route is the one the person drew on the picture -- a template (or
demonstration CSV) in the picture's plane, x right and y up from its bottom-left corner, at
:data:`PICTURE_M_PER_PX` metres a pixel (how hila studio lays out an uploaded picture); its
pen-down part, spread evenly along its length over the trace's 10 s.  Run it with the same
picture: ``hila exec PROGRAM --set picture.image=FILE``.

    python -m hila_lang.worlds.picture.demonstration [primitives/picture.yaml]
    python -m hila_lang.worlds.picture.demonstration mine.yaml --image photo.jpg --route route.yaml
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ...core.errors import HilaError, InputError
from ...osila.demofile import read_demo
from ...osila.template import save_template, Segment, Template
from ...perception.matching import scene_features
from ...robot.backend import PyBulletBackend
from ..tictactoe.marks import by_arc_length
from . import scenes as S
from .texture import map_texture, person_page, read_picture

TEXTURE_SEED = 0
ROUTE_SEED = 0
RATE = 20.0
REACH, DRAW, LIFT = 40, 200, 30
#: metres a pixel of a picture a route was drawn on (hila studio's blank sheet and uploads: 0.25 mm)
PICTURE_M_PER_PX = 0.00025


def feature_name(i: int) -> str:
    return f"f{i:03d}"


def page_of(image=None):
    """``(page texture, to_uv)``: the generated map (``to_uv`` None), or the person's picture
    file ``image`` on the page (:func:`~.texture.person_page`)."""
    if image is None:
        return map_texture(S.SIZE, TEXTURE_SEED), None
    return person_page(S.SIZE, read_picture(image))


def demonstration_features(backend, page=None):
    """What the robot saw of the demonstration sheet (printed with ``page``, default the
    generated map): ``(SceneFeatures, Sheet, images, true left camera)`` (the last for the
    referee only).  The hand waits at HOME."""
    backend.reset_hand(S.HOME)
    sheet = S.demo_sheet(backend.surface.z)
    bodies = S.show(backend, sheet, page_of()[0] if page is None else page)
    (left, right), truth = S.look(backend)
    for body in bodies:
        backend.sim.remove(body)
    return scene_features(left, right, hidden=S.own_body(backend)), sheet, (left, right), truth


def recorded_demonstration(page=None):
    """:func:`demonstration_features` (the sheet printed with ``page``) as the demonstration was
    recorded: through the iCub's eyes (who watched it when ``primitives/picture.yaml`` was
    learned), in a simulation of its own.
    A robot with other eyes matches its task images against these."""
    with PyBulletBackend(S.mat()) as watcher:
        return demonstration_features(watcher, page)


def _min_jerk(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    s = np.linspace(0, 1, n)
    s = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
    return a + s[:, None] * (b - a)


def person_route(route_file, picture_shape, to_uv) -> np.ndarray:
    """A route a person drew on their picture (module docstring) as the page's texture
    coordinates (DRAW, 2): its pen-down part, evenly along its length."""
    if str(route_file).endswith(".csv"):
        path = read_demo(route_file).path
        part = path
    else:
        # lazy: only this branch needs it
        from ...osila.template import load_template

        t = load_template(route_file)
        path = np.asarray(t.path, float)
        down = [np.arange(seg.start, seg.stop) for seg in t.segments if seg.contact]
        part = path[np.concatenate(down)] if down else path
    if path.shape[1] != 2:
        raise InputError("the route must be drawn on the picture: a 2-D path (x right, y up, metres at "
                         f"{PICTURE_M_PER_PX * 1000:g} mm a pixel), got a {path.shape[1]}-D one", file=str(route_file))
    h = picture_shape[0]
    px = np.column_stack([part[:, 0] / PICTURE_M_PER_PX, h - part[:, 1] / PICTURE_M_PER_PX, np.ones(len(part))])
    uv = (px @ np.asarray(to_uv).T)[:, :2]
    if (uv < 0).any() or (uv > 1).any():
        raise InputError("the route leaves the picture: drawn on a picture of "
                         f"{picture_shape[1]} x {picture_shape[0]} pixels?", file=str(route_file))
    return by_arc_length(uv, DRAW)


def demonstrated_path(sheet, route_uv=None) -> np.ndarray:
    """The demonstration's hand path (REACH + DRAW + LIFT, 3), world, metres: along ``route_uv``
    (DRAW, 2; default the seeded route)."""
    rng = np.random.default_rng([ROUTE_SEED, 2405])
    route = sheet.to_world(S.route_uv(ROUTE_SEED, DRAW) if route_uv is None else route_uv)
    route[:, :2] += rng.normal(0, 0.0002, (DRAW, 2))
    above = route[0] + [0, 0, 0.02]
    reach = np.vstack([_min_jerk(S.HOME, above, REACH - 8), _min_jerk(above, route[0], 9)[1:]])
    lift = _min_jerk(route[-1], route[-1] + [0, 0, 0.08], LIFT + 1)[1:]
    return np.vstack([reach, route, lift])


def learn(path_out: str, image=None, route=None) -> Template:
    """Write the template (module docstring) and return it; with ``image`` and ``route`` a person's own."""
    if (image is None) != (route is None):
        raise InputError("a person's route needs both --image (the picture) and --route (what was drawn on it)")
    page, to_uv = page_of(image)
    route_uv = None
    if route is not None:
        # lazy: only this branch needs it
        from .texture import read_picture

        route_uv = person_route(route, read_picture(image).shape, to_uv)
    with PyBulletBackend(S.mat()) as backend:
        seen, sheet, _, _ = demonstration_features(backend, page)
    path = demonstrated_path(sheet, route_uv)
    icps = {"start": path[0].copy(), **{feature_name(i): p for i, p in enumerate(seen.points)}}
    t = Template("picture", path, icps, times=np.arange(len(path)) / RATE,
                 segments=[Segment("reach", 0, REACH), Segment("draw", REACH, REACH + DRAW, True),
                           Segment("lift", REACH + DRAW, len(path))],
                 description=(f"The picture world's demonstration (hila_lang.worlds.picture.demonstration; texture "
                              f"seed {TEXTURE_SEED}, route seed {ROUTE_SEED}): reach the route on an A4 map, trace "
                              "it, lift." if image is None else
                              f"A person's route ({route}) on their picture ({image}) printed on the picture world's "
                              f"A4 sheet (hila_lang.worlds.picture.demonstration): reach it, trace it, lift; run it "
                              f"with --set picture.image={image}.")
                 + f" ICPs: the hand's start and {len(seen)} {'map ' if image is None else ''}features the robot's "
                 "eyes triangulated before the trace (f000...).")
    save_template(t, path_out)
    return t


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hila_lang.worlds.picture.demonstration",
                                     description="Learn the picture world's route template: the seeded route on the "
                                                 "generated map, or a person's route on their own picture.")
    parser.add_argument("output", nargs="?", default="primitives/picture.yaml", help="template file to write")
    parser.add_argument("--image", default=None, help="the person's picture (PNG or JPEG)")
    parser.add_argument("--route", default=None, help="the route drawn on it: a 2-D template or CSV, x right, y up from "
                                                      "the picture's bottom-left, 0.25 mm a pixel (hila studio's)")
    args = parser.parse_args(argv)
    try:
        t = learn(args.output, args.image, args.route)
    except HilaError as exc:
        print(str(exc), file=sys.stderr)
        return exc.exit_code
    print(f"wrote {args.output}: {len(t.path)} points, {len(t.icps)} ICPs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
