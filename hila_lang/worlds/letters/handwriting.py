"""The demonstrations behind ``primitives/letters/<L>.yaml``: a seeded human-like handwriting model.

No person wrote these letters.  Each capital letter is written ONCE by a documented, seeded
motion model -- a stand-in for one recorded human demonstration -- and learned from that single
path with ``hila learn``.  The model writes the strokes of :mod:`.shapes` the way people do:

- **one person's style, varied per letter**: a slant (shear of about +-3 degrees), a slightly
  different width and height (+-3 %), and every stroke's corner or arc a little off its ideal
  place (0.4 mm), so no two letters are clean geometry;
- **sub-movements**: each straight line and each arc is one minimum-jerk movement (Flash & Hogan
  1985: bell-shaped speed, the pen slows to a stop at corners and joins), lasting its length at
  3.5 cm/s (at least 0.12 s), as in handwriting studies that model strokes as velocity bumps;
- **pen lifts**: between strokes the pen lifts 6 mm, moves over in an arc and comes down again
  (one minimum-jerk movement); the letter starts with the pen 6 mm above its first point and
  ends with it lifted 6 mm;
- **tremor**: low-pass filtered noise of about 0.15 mm in the paper's plane; the pen stays
  exactly on the paper while it writes (contact), so the template's drawing parts lie on it;
- sampled at 30 Hz (a writing tablet's or motion-capture rate), world frame, metres.

Why a model and not real data: the project has no recordings of handwriting, and the LASA set is
issue 11's evaluation data; a seeded model is reproducible and its shape and timing are
documented here, where a reviewer can check them.  What matters for the method is that each
template is one imperfect, human-timed demonstration with named ICPs, not a parametric curve.

Where: the demonstrator writes each letter in a 32 x 40 mm box on the demonstration table
(:data:`DEMO_SURFACE_Z`, 0.20 m below the robot's table, as in the tic-tac-toe experiment),
upright for someone sitting where the robot sits (the letter's top is away from the robot, +x).
The ICPs are the box's corners, named as the robot sees them: ``tl`` (top-left = far-left),
``tr``, ``br``, ``bl``.

Make the demonstrations and learn them::

    python -m hila_lang.worlds.letters.handwriting --out primitives/letters

writes ``primitives/letters/demos/<L>.csv`` (t, x, y, z) and ``demos/box.yaml`` (the ICPs) and
learns every letter through :func:`hila_lang.hierarchy.learn.learn_files`, in process: the file
``hila learn demos/<L>.csv --icps demos/box.yaml --tags write --contact write --name <L> -o
<L>.yaml`` writes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ...hierarchy.learn import learn_files
from ...osila.demofile import write_demo_csv, write_icps
from ...osila.motion import minimum_jerk
from ...osila.template import save_template
from .shapes import ALPHABET, LETTERS

#: samples per second
RATE_HZ = 30.0
#: mean pen speed while writing, m/s
SPEED = 0.035
#: shortest sub-movement, seconds
MIN_MOVE = 0.12
#: how high the pen lifts between strokes, metres
HOP = 0.006
#: the demonstrator's letter box: width, height, metres
BOX = (0.032, 0.040)
#: where the demonstrator writes: the box's centre (x, y) and the paper's surface z, metres
DEMO_CENTER = (0.30, -0.05)
DEMO_SURFACE_Z = 0.371
#: style variation: slant (shear, unit box), size (relative), corner placement (unit box)
SLANT, SIZE, WOBBLE = 0.05, 0.03, 0.01
#: tremor in the paper's plane, metres
TREMOR = 0.00015


def box_corners(center=DEMO_CENTER, z: float = DEMO_SURFACE_Z, size=BOX) -> dict[str, np.ndarray]:
    """The letter box's corners ``tl``, ``tr``, ``br``, ``bl`` (3,) as the robot sees them: the
    letter's top is away from the robot (+x), its left on the robot's left (+y)."""
    w, h = size
    cx, cy = center
    return {"tl": np.array([cx + h / 2, cy + w / 2, z]), "tr": np.array([cx + h / 2, cy - w / 2, z]),
            "br": np.array([cx - h / 2, cy - w / 2, z]), "bl": np.array([cx - h / 2, cy + w / 2, z])}


def _to_world(uv: np.ndarray, corners: dict[str, np.ndarray]) -> np.ndarray:
    """Unit-box points (N, 2) (x right, y up, as read) -> world (N, 3) on the box's plane."""
    bl, br, tl = corners["bl"], corners["br"], corners["tl"]
    return bl + uv[:, :1] * (br - bl) + uv[:, 1:2] * (tl - bl)


def _curve(move, start: np.ndarray, style) -> np.ndarray:
    """Dense unit-box points (n, 2) of one move from ``start`` (its first row is ``start``)."""
    kind = move[0]
    if kind == "L":
        end = style(np.array(move[1:3], dtype=float))
        return start + np.linspace(0.0, 1.0, 64)[:, None] * (end - start)
    _, cx, cy, rx, ry, a0, a1 = move
    a = np.radians(np.linspace(a0, a1, max(16, int(abs(a1 - a0) / 3))))
    pts = style(np.column_stack([cx + rx * np.cos(a), cy + ry * np.sin(a)]))
    return np.vstack([start, pts]) if np.linalg.norm(pts[0] - start) > 1e-9 else pts


def _timed(curve: np.ndarray, seconds: float) -> np.ndarray:
    """``curve`` (n, D) travelled with a minimum-jerk profile in ``seconds``: samples (m, D)."""
    m = max(int(round(seconds * RATE_HZ)), 3) + 1
    step = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(step)])
    at = minimum_jerk(np.linspace(0.0, 1.0, m)) * s[-1]
    return np.column_stack([np.interp(at, s, curve[:, k]) for k in range(curve.shape[1])])


def _tremor(rng: np.random.Generator, n: int) -> np.ndarray:
    raw = rng.normal(size=(n + 6, 2))
    kernel = np.hanning(7)
    kernel /= np.linalg.norm(kernel)
    return TREMOR * np.stack([np.convolve(raw[:, k], kernel, mode="valid") for k in range(2)], axis=1)[:n]


def write_letter(letter: str, seed: int = 0, corners: dict[str, np.ndarray] | None = None):
    """The demonstration of ``letter``: (path (T, 3) metres, times (T,) s, contact (T,) bool).

    Seeded by ``seed`` and the letter, so each letter has its own small variations.
    """
    if letter not in LETTERS:
        raise ValueError(f"no strokes for {letter!r}; letters: {ALPHABET}")
    corners = box_corners() if corners is None else corners
    rng = np.random.default_rng([seed, ord(letter)])
    slant, sx, sy = rng.normal(0.0, SLANT), 1 + rng.normal(0.0, SIZE), 1 + rng.normal(0.0, SIZE)

    def style(p: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(p).astype(float)
        q = np.column_stack([0.5 + (p[:, 0] - 0.5 + slant * (p[:, 1] - 0.5)) * sx, 0.5 + (p[:, 1] - 0.5) * sy])
        return q[0] if q.shape[0] == 1 else q

    width, height = (np.linalg.norm(corners["br"] - corners["bl"]), np.linalg.norm(corners["tl"] - corners["bl"]))
    scale = np.array([width, height])  # unit box -> metres, for timing
    pieces: list[tuple[np.ndarray, np.ndarray]] = []  # (uv samples, height above the paper)
    pen = None
    for stroke in LETTERS[letter]:
        start = style(np.array(stroke[0][1:3], dtype=float)) + rng.normal(0.0, WOBBLE, 2)
        if pen is None:  # the pen comes down onto the first point
            down = _timed(np.array([[0.0], [1.0]]), 0.25)[:, 0]
            pieces.append((np.repeat(start[None], len(down), axis=0), HOP * (1 - down)))
        else:  # a pen lift: up, over, down in one movement
            hop = _timed(np.array([pen, start]), 0.25 + np.linalg.norm((start - pen) * scale) / 0.08)
            arc = np.sin(np.pi * np.linspace(0.0, 1.0, len(hop)))
            arc[[0, -1]] = 0.0
            pieces.append((hop, HOP * arc))
        pen = start
        for move in stroke[1:]:
            if move[0] == "L":
                move = ("L", *(np.array(move[1:3]) + rng.normal(0.0, WOBBLE, 2)))
            curve = _curve(move, pen, style)
            length = float(np.linalg.norm(np.diff(curve, axis=0) * scale, axis=1).sum())
            samples = _timed(curve, max(length / SPEED, MIN_MOVE))
            pieces.append((samples, np.zeros(len(samples))))
            pen = samples[-1]
    up = _timed(np.array([[0.0], [1.0]]), 0.25)[:, 0]
    pieces.append((np.repeat(pen[None], len(up), axis=0), HOP * up))
    uv = np.vstack([pieces[0][0]] + [p[0][1:] for p in pieces[1:]])
    lift = np.concatenate([pieces[0][1]] + [p[1][1:] for p in pieces[1:]])
    normal = np.cross(corners["br"] - corners["bl"], corners["tl"] - corners["bl"])
    normal /= np.linalg.norm(normal)
    normal *= np.sign(normal[2]) or 1.0
    path = _to_world(uv, corners) + lift[:, None] * normal
    axes = np.stack([(corners["br"] - corners["bl"]) / width, (corners["tl"] - corners["bl"]) / height])
    path += _tremor(rng, len(path)) @ axes
    contact = lift == 0.0
    return path, np.arange(len(path)) / RATE_HZ, contact


def main(argv: list[str] | None = None) -> int:
    """Write every letter's demonstration and learn it as ``hila learn`` does (see the module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m hila_lang.worlds.letters.handwriting",
                                 description="Make the letters' demonstrations and learn them as hila learn does.")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("primitives/letters"))
    ap.add_argument("--letters", default=ALPHABET, help="which letters (default: all)")
    args = ap.parse_args(argv)
    demos = args.out / "demos"
    box = demos / "box.yaml"
    write_icps(box, {k: [round(float(v), 6) for v in p] for k, p in box_corners().items()},
               header="the demonstrator's letter box: ICPs tl, tr, br, bl (world frame, metres)")
    for letter in args.letters.upper():
        path, times, _ = write_letter(letter, args.seed)
        csv = demos / f"{letter}.csv"
        write_demo_csv(csv, path, times, decimals=7, time_decimals=4)  # 0.1 um, 0.1 ms: far below the tremor
        command = ["learn", str(csv), "--icps", str(box), "--tags", "write", "--contact", "write",
                   "--name", letter, "-o", str(args.out / f"{letter}.yaml")]
        description = (
            f"Handwritten capital {letter}: ONE demonstration by the seeded handwriting model "
            f"hila_lang.worlds.letters.handwriting (seed {args.seed}; strokes of shapes.py written as minimum-jerk "
            f"sub-movements at {SPEED * 100:g} cm/s, slant and size varied, pen lifts of {HOP * 1000:g} mm, "
            f"{TREMOR * 1000:g} mm tremor, {RATE_HZ:g} Hz) in a {BOX[0] * 1000:g} x {BOX[1] * 1000:g} mm box "
            f"whose corners are the ICPs. Made by: python -m hila_lang.worlds.letters.handwriting; "
            f"learned by: hila {' '.join(command[:-2])} -o {letter}.yaml")
        template = learn_files(csv, box, name=letter, tags=["write"], contact=["write"], description=description)
        save_template(template, args.out / f"{letter}.yaml")
        print(f"{letter}: {len(path)} points -> {args.out / f'{letter}.yaml'}", flush=True)
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
