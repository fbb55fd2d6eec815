"""A person teaching the robot a mark of their own: a seeded pointer model drawing on the sheet.

What ``hila studio`` records when a person draws on the tic-tac-toe scene -- the pointer moving
over the sheet with the pen up (the *reach*), pressed while it draws the mark (the *draw*),
lifted and moved away (the *retract*) -- made by a documented, seeded model instead of a hand, so
tests and ``bench/vision_game.py`` can teach the robot triangles, ticks, squares, stars, letters
and scribbles without a person.  It is a stand-in, like :mod:`.demonstration` for the circle,
and what it makes goes through ``hila learn`` as a person's drawing does.

The marks (:data:`MARKS`) are strokes in a unit box in the moves of
:mod:`hila_lang.worlds.letters.shapes` (``M`` pen down at, ``L`` line to, ``A`` arc), seen as the
person sees the sheet in the studio: the robot's eye view, the box's top away from the robot.
A capital letter ``A``-``Z`` draws that letter's strokes; ``scribble`` a smooth seeded loop.

People draw differently (:data:`STYLES`); each style sets, within seeded ranges:

- the mark's size (a fraction of the cell) and its slant (a turn, degrees);
- the pen's speed while drawing: every line and arc is one minimum-jerk sub-movement (Flash &
  Hogan 1985), so the pen slows to a stop at corners, and a careful person also pauses there;
- how far each corner lands from its ideal place (unit box) and the tremor (metres, low-pass
  filtered noise in the paper's plane);
- where the pointer comes from and goes to: the reach starts 10-16 cm from the cell in a seeded
  direction and the retract ends 8-14 cm from it in another (not back the way the reach came).

Between strokes the pointer moves over with the pen up.  The path is sampled at 20 Hz (the rate
of every demonstration in hila) and lifted off the paper while the pen is up by the studio's
rule (:func:`hila_lang.osila.demofile.lift`: 45 degrees, at most the world's highest park
height, 0.13 m).  :func:`write_demonstration` writes ``NAME.demo.csv`` (``t,x,y,z,pen``) and
``NAME.icps.yaml`` (the cell's corners ``tl tr br bl`` as the robot sees them, and ``hand``: the
path's start) for ``hila learn NAME.demo.csv --icps NAME.icps.yaml -k 3 --tags
reach,draw,retract --contact draw -o NAME.yaml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...osila.demofile import lift, write_demo_csv, write_icps
from ...osila.motion import minimum_jerk
from ..letters.shapes import LETTERS
from .board import cell_center, cell_corners, Grid

#: samples per second of the demonstration (as hila studio resamples a drawing)
RATE_HZ = 20.0
#: the model's own time step, seconds (then sampled at RATE_HZ)
_DT = 1.0 / 400.0
#: the marks, as strokes in a unit box (x right, y up as the person sees the sheet)
MARKS = {
    "circle": ((("M", 0.5, 1.0), ("A", 0.5, 0.5, 0.5, 0.5, 90, 450)),),
    "triangle": ((("M", 0.5, 1.0), ("L", 0.0, 0.0), ("L", 1.0, 0.0), ("L", 0.5, 1.0)),),
    "tick": ((("M", 0.0, 0.5), ("L", 0.35, 0.0), ("L", 1.0, 1.0)),),
    "square": ((("M", 0.0, 1.0), ("L", 0.0, 0.0), ("L", 1.0, 0.0), ("L", 1.0, 1.0), ("L", 0.0, 1.0)),),
    "star": ((("M", 0.5, 1.0), ("L", 0.21, 0.0), ("L", 0.98, 0.62), ("L", 0.02, 0.62), ("L", 0.79, 0.0),
              ("L", 0.5, 1.0)),),
}
#: people's styles: (low, high) ranges the seed draws from
STYLES = {
    "careful": {"size": (0.50, 0.60), "slant": (-4.0, 4.0), "speed": (0.05, 0.07), "pause": 0.10,
                "wobble": 0.02, "tremor": 0.0002},
    "quick": {"size": (0.60, 0.72), "slant": (-12.0, 12.0), "speed": (0.12, 0.16), "pause": 0.0,
              "wobble": 0.05, "tremor": 0.0003},
    "shaky": {"size": (0.50, 0.62), "slant": (-8.0, 8.0), "speed": (0.04, 0.06), "pause": 0.05,
              "wobble": 0.04, "tremor": 0.0006},
    "small": {"size": (0.36, 0.44), "slant": (-6.0, 6.0), "speed": (0.05, 0.08), "pause": 0.05,
              "wobble": 0.03, "tremor": 0.0002},
}
#: where the pointer starts and ends, metres from the cell centre in the paper's plane
REACH_FROM, RETRACT_TO = (0.10, 0.16), (0.08, 0.14)
#: the pointer's speed with the pen up, m/s
TRAVEL_SPEED = 0.15
#: the highest the pen is lifted (the studio's rule; the tic-tac-toe world's highest park height)
LIFT_MAX = 0.13
#: the ICP names of a drawn mark's demonstration (those ``programs/game.hila`` binds)
ICP_NAMES = ("tl", "tr", "br", "bl", "hand")


@dataclass
class Drawing:
    """One drawn demonstration.

    Attributes
    ----------
    path : ndarray, shape (T, 3)
        The pen, world frame, metres (lifted off the paper while it is up).
    times : ndarray, shape (T,)
        Seconds, at :data:`RATE_HZ`.
    pen : ndarray of bool, shape (T,)
        True while the pen touches the paper.
    icps : dict[str, ndarray]
        :data:`ICP_NAMES`, each (3,).
    samples : list of dict
        The pointer events as hila studio's page sends them: ``x``, ``y`` (plane, metres),
        ``t`` (milliseconds), ``down``.
    mark, style : str
    cell, seed : int
    """

    path: np.ndarray
    times: np.ndarray
    pen: np.ndarray
    icps: dict
    samples: list
    mark: str
    style: str
    cell: int
    seed: int


def mark_strokes(mark: str, rng: np.random.Generator | None = None) -> tuple:
    """The strokes of ``mark`` (:data:`MARKS`, a capital letter, or ``scribble``: a smooth loop
    through 6 seeded points, which needs ``rng``)."""
    if mark in MARKS:
        return MARKS[mark]
    if mark in LETTERS:
        return LETTERS[mark]
    if mark == "scribble":
        rng = np.random.default_rng(0) if rng is None else rng
        angles = np.sort(rng.uniform(0, 2 * np.pi, 6))
        radii = rng.uniform(0.2, 0.5, 6)
        pts = np.column_stack([0.5 + radii * np.cos(angles), 0.5 + radii * np.sin(angles)])
        pts = np.vstack([pts, pts[:2]])
        moves = [("M", *pts[0])] + [("L", *p) for p in _catmull_rom(pts)[1:]]
        return (tuple(moves),)
    raise ValueError(f"unknown mark {mark!r}; expected one of {', '.join(MARKS)}, a capital letter or scribble")


def _catmull_rom(pts: np.ndarray, per: int = 8) -> np.ndarray:
    """A smooth closed-ish curve through ``pts`` (n, 2) (the last two repeat the first two)."""
    out = []
    for i in range(1, len(pts) - 2):
        p0, p1, p2, p3 = pts[i - 1], pts[i], pts[i + 1], pts[i + 2]
        for s in np.linspace(0, 1, per, endpoint=False):
            out.append(0.5 * (2 * p1 + (p2 - p0) * s + (2 * p0 - 5 * p1 + 4 * p2 - p3) * s ** 2
                              + (3 * p1 - p0 - 3 * p2 + p3) * s ** 3))
    return np.array(out)


def _move_points(move, start: np.ndarray) -> np.ndarray:
    """Dense unit-box points (n, 2) of one move from ``start`` (its first row is ``start``)."""
    if move[0] == "L":
        end = np.array(move[1:3], dtype=float)
        return start + np.linspace(0.0, 1.0, 32)[:, None] * (end - start)
    _, cx, cy, rx, ry, a0, a1 = move
    a = np.radians(np.linspace(a0, a1, max(16, int(abs(a1 - a0) / 3))))
    pts = np.column_stack([cx + rx * np.cos(a), cy + ry * np.sin(a)])
    return np.vstack([start, pts]) if np.linalg.norm(pts[0] - start) > 1e-9 else pts


def _travel(points: np.ndarray, speed: float, minimum: float = 0.12) -> np.ndarray:
    """``points`` (n, 2) metres travelled in one minimum-jerk movement at about ``speed``: (m, 2)
    at the model's time step."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    seconds = max(s[-1] / speed, minimum)
    at = minimum_jerk(np.linspace(0.0, 1.0, max(int(round(seconds / _DT)), 2) + 1)) * s[-1]
    return np.column_stack([np.interp(at, s, points[:, k]) for k in range(2)])


def draw_mark(mark: str = "triangle", style: str = "careful", seed: int = 0, cell: int = 5, spec=None) -> Drawing:
    """A person drawing ``mark`` in ``cell`` of ``spec`` (default the demonstration sheet,
    :meth:`~hila_lang.worlds.tictactoe.board.Grid.demonstration`) in ``style``: reach, draw,
    retract (see the module docstring).  Seeded by ``seed``, ``mark`` and ``style``."""
    if style not in STYLES:
        raise ValueError(f"unknown style {style!r}; expected one of {', '.join(STYLES)}")
    spec = Grid.demonstration() if spec is None else spec
    rng = np.random.default_rng([seed, sum(map(ord, mark)), sum(map(ord, style))])
    st = STYLES[style]
    strokes = mark_strokes(mark, rng)
    corners = cell_corners(spec, cell)
    right = (corners["br"] - corners["bl"])[:2]
    up = (corners["tl"] - corners["bl"])[:2]
    centre = cell_center(spec, cell)[:2]
    size, turn = rng.uniform(*st["size"]), math.radians(rng.uniform(*st["slant"]))
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])

    def plane(uv: np.ndarray) -> np.ndarray:
        """Unit-box points -> the paper's plane (x, y), metres, centred in the cell, turned and sized."""
        q = ((np.atleast_2d(uv) - 0.5) * size) @ rot.T
        return centre + q[:, :1] * right + q[:, 1:2] * up

    def jitter(p) -> np.ndarray:
        return np.asarray(p, dtype=float) + rng.normal(0.0, st["wobble"], 2)

    speed = rng.uniform(*st["speed"])
    away = rng.uniform(0, 2 * np.pi)
    start = centre + rng.uniform(*REACH_FROM) * np.array([math.cos(away), math.sin(away)])
    back = away + rng.uniform(0.5, 1.5) * np.pi  # the retract does not go back the way the reach came
    end_offset = rng.uniform(*RETRACT_TO) * np.array([math.cos(back), math.sin(back)])
    pieces: list[tuple[np.ndarray, bool]] = []
    pen = start[None]
    for stroke in strokes:
        first = plane(jitter(stroke[0][1:3]))
        pieces.append((_travel(np.vstack([pen[-1:], first]), TRAVEL_SPEED, 0.3), False))
        here = np.array(stroke[0][1:3], dtype=float)
        drawn = [first]
        for move in stroke[1:]:
            if move[0] == "L":
                move = ("L", *jitter(move[1:3]))
            pts = _move_points(move, here)
            here = pts[-1]
            leg = _travel(np.vstack([drawn[-1][-1:], plane(pts[1:])]), speed)
            drawn.append(leg[1:])
            if st["pause"]:
                drawn.append(np.repeat(leg[-1:], int(round(st["pause"] / _DT)), axis=0))
        stroke_xy = np.vstack(drawn)
        pieces.append((stroke_xy, True))
        pen = stroke_xy
    pieces.append((_travel(np.vstack([pen[-1:], centre + end_offset]), TRAVEL_SPEED, 0.3), False))
    xy = np.vstack([p for p, _ in pieces])
    down = np.concatenate([np.full(len(p), d) for p, d in pieces])
    # tremor: low-pass filtered noise in the plane, sampled on the model's time step
    raw = rng.normal(size=(len(xy) + 40, 2))
    kernel = np.hanning(41)
    kernel /= np.linalg.norm(kernel)
    xy = xy + st["tremor"] * np.column_stack([np.convolve(raw[:, k], kernel, mode="valid") for k in range(2)])
    t = np.arange(len(xy)) * _DT
    times = np.arange(0.0, t[-1] + 1e-9, 1.0 / RATE_HZ)
    idx = np.minimum(np.round(times / _DT).astype(int), len(xy) - 1)
    sampled, pen_down = xy[idx], down[idx]
    path = lift(sampled, pen_down, spec.surface_z, LIFT_MAX)
    icps = {name: corners[name].copy() for name in ("tl", "tr", "br", "bl")}
    icps["hand"] = path[0].copy()
    samples = [{"x": float(x), "y": float(y), "t": round(1000.0 * float(tt), 3), "down": bool(d)}
               for (x, y), tt, d in zip(sampled, times, pen_down)]
    return Drawing(path, times, pen_down, icps, samples, mark, style, int(cell), int(seed))


def write_demonstration(folder, name: str, drawing: Drawing) -> tuple[Path, Path]:
    """Write ``NAME.demo.csv`` (``t,x,y,z,pen``) and ``NAME.icps.yaml`` into ``folder``; returns
    both paths (for ``hila learn``)."""
    folder = Path(folder)
    demo, icps = folder / f"{name}.demo.csv", folder / f"{name}.icps.yaml"
    write_demo_csv(demo, drawing.path, drawing.times, drawing.pen)
    write_icps(icps, drawing.icps)
    return demo, icps
