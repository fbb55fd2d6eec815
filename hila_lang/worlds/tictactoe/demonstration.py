"""The seeded human-like demonstration behind ``primitives/circle.yaml``.

One demonstration of "reach a cell, draw a circle, retract" (the paper's Experiment B, Fig. 6a),
made in :meth:`Grid.demonstration` (an A4 sheet with a 0.20 m grid on a low table), in the
world frame, metres, sampled at 20 Hz like the iCub's cameras.  It is a documented motion model,
not a recording, and not a parametric circle:

- **reach**: a minimum-jerk movement (Flash & Hogan 1985) from the hand's start, above and to the
  right of the sheet, to a point just above the circle's first point, with a slight sideways bow
  as human reaches have, then a short minimum-jerk descent until the pen touches the paper;
- **draw**: one counter-clockwise stroke around the centre cell; the radius is uneven (two
  seeded low-order harmonics and a slow drift), the pen speeds up and slows down (minimum-jerk
  progress along the stroke), it closes with a seeded overlap or gap, and a slight tremor
  (low-pass filtered noise, ~0.3 mm) rides on it; the pen stays on the paper (contact);
- **retract**: the pen lifts and the hand moves away and up with a minimum-jerk profile.

:func:`make_circle_template` segments the demonstration with k-means (k = 3) into sub-templates
tagged ``reach``, ``draw`` (contact) and ``retract``.  k-means on position and time does not cut
exactly where the pen touches: the ``draw`` cluster also takes the slow end of the approach and
the start of the lift-off (with seed 0: draw = samples 12..70, pen on paper 25..57).  That is
harmless -- ink is laid only where the pen touches -- and it even helps: the robot's ``draw``
state ends with the pen lifted, so the next ``reach`` starts in the air.

ICP names (relied on by ``programs/game.hila``, the world and perception): the four corners of
the target cell :data:`CORNER_ICPS` = ``tl``, ``tr``, ``br``, ``bl`` (far-left, far-right,
near-right, near-left as the robot sees the board) and :data:`HAND_ICP` = ``hand`` (the hand's
start).

Run ``python -m hila_lang.worlds.tictactoe.demonstration -o primitives/circle.yaml`` to (re)make the file.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass

import numpy as np

from ...core.errors import HilaError
from ...osila.motion import minimum_jerk_samples
from ...osila.segmentation import segment_template
from ...osila.template import save_template, Template
from .board import cell_center, cell_corners, Grid

#: the four corners of the target cell, as ICP names
CORNER_ICPS = ("tl", "tr", "br", "bl")
#: the hand's start, as an ICP name
HAND_ICP = "hand"
#: all ICP names of the circle template, in file order
ICP_NAMES = CORNER_ICPS + (HAND_ICP,)
#: sub-template tags, in order
TAGS = ("reach", "draw", "retract")
#: the cell the demonstrator draws in (the centre, as the paper's iCub opened)
DEMO_CELL = 5
#: sampling rate of the demonstration, Hz (the iCub cameras' frame rate)
RATE_HZ = 20.0
#: where the hand starts and where it retracts to, metres from the cell centre (low, high):
#: grid right, grid far, height above the paper
GEOMETRY = {"start_right": (0.10, 0.14), "start_far": (-0.16, -0.10), "start_height": (0.16, 0.20),
            "away_right": (0.10, 0.14), "away_far": (-0.16, -0.10), "away_height": (0.14, 0.18)}
#: durations, seconds (low, high): reach transit, descent, stroke, lift, move away
TIMING = {"reach": (1.0, 1.3), "down": (0.25, 0.3), "draw": (1.4, 1.8), "lift": (0.2, 0.25),
          "away": (0.9, 1.2)}


@dataclass
class Demonstration:
    """One demonstrated movement with its scene.

    Attributes
    ----------
    path : ndarray, shape (T, 3)
        Pen-tip positions, world frame, metres.
    times : ndarray, shape (T,)
        Seconds from the start, strictly increasing.
    contact : ndarray of bool, shape (T,)
        True where the pen touches the paper.
    icps : dict[str, ndarray]
        ``tl``, ``tr``, ``br``, ``bl`` (target cell corners) and ``hand`` (the start), each (3,).
    phases : dict[str, tuple[int, int]]
        The generating model's own phase ranges ``[start, stop)`` (ground truth for segmentation).
    cell : int
        The cell drawn in (1..9).
    seed : int
        The seed that made it.
    """

    path: np.ndarray
    times: np.ndarray
    contact: np.ndarray
    icps: dict[str, np.ndarray]
    phases: dict[str, tuple[int, int]]
    cell: int
    seed: int


def _tremor(rng: np.random.Generator, n: int, amplitude: float) -> np.ndarray:
    """Smooth random jitter, shape (n, 2), standard deviation about ``amplitude`` metres."""
    raw = rng.normal(size=(n + 4, 2))
    kernel = np.array([1.0, 2.0, 3.0, 2.0, 1.0])
    kernel /= np.linalg.norm(kernel)
    smooth = np.stack([np.convolve(raw[:, k], kernel, mode="valid") for k in range(2)], axis=1)
    return amplitude * smooth[:n]


def _samples(seconds: float) -> int:
    return max(int(round(seconds * RATE_HZ)), 4)


def demonstrate(seed: int = 0, scene=None, cell: int = DEMO_CELL) -> Demonstration:
    """Make the human-like demonstration.

    Parameters
    ----------
    seed : int
        Fixes every random choice (start, circle shape, closure, tremor, timing).
    scene : Grid, optional
        The demonstration scene; :meth:`Grid.demonstration` by default.
    cell : int
        The cell to draw in, 1..9.

    Returns
    -------
    Demonstration
    """
    spec = Grid.demonstration() if scene is None else scene
    rng = np.random.default_rng(seed)
    corners = cell_corners(spec, cell)
    centre_grid = spec.world_to_grid(cell_center(spec, cell))
    cell_size = spec.grid_size / 3
    z0 = spec.surface_z

    # -- the circle, in grid coordinates (right, far), drawn counter-clockwise seen from above
    n_draw = _samples(rng.uniform(*TIMING["draw"]))
    radius = cell_size * rng.uniform(0.31, 0.35)
    start_angle = math.radians(rng.uniform(60.0, 120.0))  # starts near the far side, like a "C"
    closure = math.radians(rng.choice([-1.0, 1.0]) * rng.uniform(12.0, 25.0))  # gap (<0) or overlap
    sweep = 2.0 * math.pi + closure
    progress = 0.15 * np.linspace(0, 1, n_draw) + 0.85 * minimum_jerk_samples(n_draw)
    angle = start_angle + sweep * progress
    a1, a2 = rng.uniform(0.04, 0.08), rng.uniform(0.05, 0.08)
    p1, p2 = rng.uniform(0, 2 * math.pi, size=2)
    drift = rng.uniform(-0.06, 0.06) * progress  # the stroke spirals slightly in or out
    r = radius * (1.0 + a1 * np.cos(angle + p1) + a2 * np.cos(2.0 * angle + p2) + drift)
    # grid coordinates (right, far) form a right-handed frame seen from above, so a growing
    # angle (0 = right, 90 deg = far) runs counter-clockwise
    circle = np.stack([r * np.cos(angle), r * np.sin(angle)], axis=1)
    circle += centre_grid + rng.normal(scale=0.002, size=2)
    circle += _tremor(rng, n_draw, 0.0003)
    draw = spec.grid_to_world(circle[:, 0], circle[:, 1])
    draw[:, 2] = z0

    # -- reach: from the hand's start to just above the first circle point, then down
    start_grid = centre_grid + np.array([rng.uniform(*GEOMETRY["start_right"]),
                                         rng.uniform(*GEOMETRY["start_far"])])
    hand = spec.grid_to_world(start_grid[0], start_grid[1])
    hand[2] = z0 + rng.uniform(*GEOMETRY["start_height"])
    hover = draw[0] + np.array([0.0, 0.0, rng.uniform(0.012, 0.018)])
    n_reach = _samples(rng.uniform(*TIMING["reach"]))
    s = minimum_jerk_samples(n_reach)[:, None]
    reach = hand + s * (hover - hand)
    side = np.cross(hover - hand, [0.0, 0.0, 1.0])
    side /= max(np.linalg.norm(side), 1e-9)
    reach += np.sin(np.pi * s) * side * rng.uniform(0.01, 0.025)
    n_down = _samples(rng.uniform(*TIMING["down"]))
    down = hover + minimum_jerk_samples(n_down + 1)[1:, None] * (draw[0] - hover)
    down[-1, 2] = z0 + 0.0005  # the last sample before contact hovers a hair above the paper
    reach = np.vstack([reach, down[:-1]])

    # -- retract: lift, then away and up, toward the start but not back to it
    n_lift = _samples(rng.uniform(*TIMING["lift"]))
    lift_to = draw[-1] + np.array([0.0, 0.0, rng.uniform(0.015, 0.02)])
    lift = draw[-1] + minimum_jerk_samples(n_lift + 1)[1:, None] * (lift_to - draw[-1])
    away_grid = centre_grid + np.array([rng.uniform(*GEOMETRY["away_right"]),
                                        rng.uniform(*GEOMETRY["away_far"])])
    away = spec.grid_to_world(away_grid[0], away_grid[1])
    away[2] = z0 + rng.uniform(*GEOMETRY["away_height"])
    n_away = _samples(rng.uniform(*TIMING["away"]))
    retract = np.vstack([lift, lift_to + minimum_jerk_samples(n_away + 1)[1:, None] * (away - lift_to)])

    path = np.vstack([reach, draw, retract])
    n = len(path)
    times = np.arange(n) / RATE_HZ
    contact = np.zeros(n, dtype=bool)
    contact[len(reach) : len(reach) + n_draw] = True
    phases = {
        "reach": (0, len(reach)),
        "draw": (len(reach), len(reach) + n_draw),
        "retract": (len(reach) + n_draw, n),
    }
    icps = {name: corners[name].copy() for name in CORNER_ICPS}
    icps[HAND_ICP] = hand
    return Demonstration(path, times, contact, icps, phases, int(cell), int(seed))


def make_circle_template(seed: int = 0, *, segmentation_seed: int = 0):
    """The circle template: :func:`demonstrate` segmented by k-means (k = 3).

    Parameters
    ----------
    seed : int
        Seed of the demonstration.
    segmentation_seed : int
        Seed of k-means.

    Returns
    -------
    Template
        Named ``circle``, ICPs :data:`ICP_NAMES`, segments tagged :data:`TAGS` with contact on
        ``draw``, times in seconds, and a description saying how it was made.
    """
    demo = demonstrate(seed)
    description = (
        f"Human-like demonstration made by a documented motion model "
        f"(hila_lang.worlds.tictactoe.demonstration, seed {seed}): in the demonstration scene (A4 sheet, "
        f"0.20 m grid on a low table, world frame, metres, {RATE_HZ:g} Hz) the hand reaches from "
        f"its start (ICP 'hand') to cell {demo.cell} with a minimum-jerk movement, draws one "
        "uneven hand-drawn circle (radius wobble, overlap or gap where it closes, slight "
        "tremor) with the pen on the paper, and retracts. ICPs tl, tr, br, bl are the target "
        "cell's corners. Segmented by k-means (k = 3) into reach, draw (contact), retract; the "
        "draw cluster also holds the last part of the approach and the first part of the "
        "lift-off (the pen touches the paper only in its middle). "
        "Made by: python -m hila_lang.worlds.tictactoe.demonstration -o primitives/circle.yaml "
        f"--seed {seed}"
    )
    whole = Template(
        name="circle",
        path=demo.path,
        icps=demo.icps,
        times=demo.times,
        description=description,
    )
    return segment_template(whole, 3, list(TAGS), method="kmeans", seed=segmentation_seed,
                            contact=("draw",))


def main(argv: list[str] | None = None) -> int:
    """``python -m hila_lang.worlds.tictactoe.demonstration -o primitives/circle.yaml [--seed N]``."""
    parser = argparse.ArgumentParser(
        prog="python -m hila_lang.worlds.tictactoe.demonstration",
        description="Write the seeded human-like circle demonstration as a segmented template.",
    )
    parser.add_argument("-o", "--output", default="primitives/circle.yaml", help="template file to write")
    parser.add_argument("--seed", type=int, default=0, help="seed of the demonstration (default 0)")
    args = parser.parse_args(argv)
    try:
        template = make_circle_template(args.seed)
        save_template(template, args.output)
    except HilaError as exc:
        print(str(exc), file=sys.stderr)
        return exc.exit_code
    segs = ", ".join(f"{s.tag} [{s.start}, {s.stop})" for s in template.segments)
    print(f"wrote {args.output}: {len(template.path)} waypoints, segments {segs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
