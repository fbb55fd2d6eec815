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

    python -m hila_lang.worlds.picture.demonstration [primitives/picture.yaml]
"""

from __future__ import annotations

import sys

import numpy as np

from . import scenes as S

TEXTURE_SEED = 0
ROUTE_SEED = 0
RATE = 20.0
REACH, DRAW, LIFT = 40, 200, 30


def feature_name(i: int) -> str:
    return f"f{i:03d}"


def demonstration_features(backend):
    """What the robot saw of the demonstration sheet: ``(SceneFeatures, Sheet, images, true
    left camera)`` (the last for the referee only).  The hand waits at HOME."""
    from ...perception.matching import scene_features
    from .texture import map_texture

    backend.reset_hand(S.HOME)
    sheet = S.demo_sheet(backend.surface.z)
    bodies = S.show(backend, sheet, map_texture(S.SIZE, TEXTURE_SEED))
    (left, right), truth = S.look(backend)
    for body in bodies:
        backend.sim.remove(body)
    return scene_features(left, right, hidden=S.own_body(backend)), sheet, (left, right), truth


def recorded_demonstration():
    """:func:`demonstration_features` as the demonstration was recorded: through the iCub's eyes
    (who watched it when ``primitives/picture.yaml`` was learned), in a simulation of its own.
    A robot with other eyes matches its task images against these."""
    from ...robot.backend import PyBulletBackend

    with PyBulletBackend(S.mat()) as watcher:
        return demonstration_features(watcher)


def _min_jerk(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    s = np.linspace(0, 1, n)
    s = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
    return a + s[:, None] * (b - a)


def demonstrated_path(sheet) -> np.ndarray:
    """The demonstration's hand path (REACH + DRAW + LIFT, 3), world, metres."""
    rng = np.random.default_rng([ROUTE_SEED, 2405])
    route = sheet.to_world(S.route_uv(ROUTE_SEED, DRAW))
    route[:, :2] += rng.normal(0, 0.0002, (DRAW, 2))
    above = route[0] + [0, 0, 0.02]
    reach = np.vstack([_min_jerk(S.HOME, above, REACH - 8), _min_jerk(above, route[0], 9)[1:]])
    lift = _min_jerk(route[-1], route[-1] + [0, 0, 0.08], LIFT + 1)[1:]
    return np.vstack([reach, route, lift])


def learn(path_out: str) -> None:
    from ...robot.backend import PyBulletBackend
    from ...osila.template import Segment, Template, save_template

    with PyBulletBackend(S.mat()) as backend:
        seen, sheet, _, _ = demonstration_features(backend)
    path = demonstrated_path(sheet)
    icps = {"start": path[0].copy(), **{feature_name(i): p for i, p in enumerate(seen.points)}}
    t = Template("picture", path, icps, times=np.arange(len(path)) / RATE,
                 segments=[Segment("reach", 0, REACH), Segment("draw", REACH, REACH + DRAW, True),
                           Segment("lift", REACH + DRAW, len(path))],
                 description=f"The picture world's demonstration (hila_lang.worlds.picture.demonstration; texture "
                             f"seed {TEXTURE_SEED}, route seed {ROUTE_SEED}): reach the route on an A4 map, trace it, "
                             f"lift. ICPs: the hand's start and {len(seen)} map features the robot's eyes "
                             "triangulated before the trace (f000...).")
    save_template(t, path_out)
    print(f"wrote {path_out}: {len(path)} points, {len(icps)} ICPs")


if __name__ == "__main__":
    learn(sys.argv[1] if len(sys.argv) > 1 else "primitives/picture.yaml")
