"""Human-like stand-in demonstrations for the language's example programs (seeded).

Until perception records real ones, ``primitives/abc.yaml`` and ``primitives/reach.yaml`` come
from this motion model, in the world frame (metres, z up, table top z = 0.57, 20 Hz):

- every movement is a chain of minimum-jerk legs (bell-shaped speed, zero velocity and
  acceleration at each via point) through via points that lift over the table in an arc;
- a seeded tremor (0.3 mm, low-pass) and a seeded wobble of each arc's height (±20 %) are added,
  so the path is not a clean parametric curve;
- the recording is segmented with :func:`hila_lang.osila.segmentation.segment_template`, method
  ``"equal"``: the legs last equally long, so equal-N cuts fall on the touches.  (k-means on
  these minimum-jerk recordings cut mid-leg — e.g. at 19 and 51 of 89 samples for abc — because
  the slow ends of each leg dominate the clusters; the tic-tac-toe demonstration uses k-means.)

``abc``: the paper's §II.B example.  The hand starts at ``hand``, reaches and touches object
``p`` (sub-action *a*), carries on to touch ``q`` (*b*), then ``r`` (*c*); k = 3, tags a, b, c.
``reach``: "move the arm to an object and back": from ``home`` to touch ``object`` and back to
``home``; k = 2, tags reach, back.

Regenerate with ``python -m hila_lang.worlds.scripted.demos [--seed N] [--out primitives]``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ...osila.motion import minimum_jerk_samples
from ...osila.segmentation import segment_template
from ...osila.template import save_template, Template

RATE = 20.0  # samples per second
TABLE_Z = 0.57



def _leg(a, b, seconds: float, lift: float) -> np.ndarray:
    """One minimum-jerk leg from ``a`` to ``b`` (3,), arcing ``lift`` metres up mid-way; (n, 3)."""
    n = max(int(round(seconds * RATE)), 4)
    s = minimum_jerk_samples(n)[:, None]
    line = a + s * (b - a)
    line[:, 2] += lift * np.sin(np.pi * s[:, 0])
    return line


def _tremor(rng: np.random.Generator, n: int, amplitude: float = 0.0003) -> np.ndarray:
    noise = rng.normal(0.0, amplitude, size=(n + 4, 3))
    kernel = np.ones(5) / 5.0
    smooth = np.stack([np.convolve(noise[:, i], kernel, mode="valid") for i in range(3)], axis=1)
    smooth[0] = 0.0  # the hand starts exactly where it is
    return smooth[:n]


def movement(points, seconds, lifts, rng: np.random.Generator) -> tuple[np.ndarray, list[int]]:
    """Chain of legs through ``points`` (P, 3); returns the path (T, 3) and each via point's index."""
    parts, marks = [np.asarray(points[0], float)[None]], [0]
    for a, b, sec, lift in zip(points[:-1], points[1:], seconds, lifts):
        lift *= 1.0 + rng.uniform(-0.2, 0.2)
        leg = _leg(np.asarray(a, float), np.asarray(b, float), sec, lift)[1:]
        parts.append(leg)
        marks.append(marks[-1] + len(leg))
    path = np.vstack(parts)
    return path + _tremor(rng, len(path)), marks


def _demonstration(name: str, path: np.ndarray, icps: dict, seed: int, what: str, tags: list[str]):
    """A 20 Hz recording as a :class:`~hila_lang.osila.template.Template`, segmented equal-N into ``tags``."""
    t = Template(name, path, icps, times=np.arange(len(path)) / RATE, description=(
        f"Stand-in demonstration made by hila_lang.worlds.scripted.demos (seed {seed}; python -m "
        f"hila_lang.worlds.scripted.demos): {what}"))
    return segment_template(t, len(tags), tags, method="equal")


def make_abc(seed: int = 0):
    """The A-B-C demonstration (see the module docstring), segmented a, b, c."""
    rng = np.random.default_rng(seed)
    icps = {
        "hand": np.array([0.20, -0.28, 0.72]),
        "p": np.array([0.34, -0.20, TABLE_Z + 0.02]),
        "q": np.array([0.26, -0.05, TABLE_Z + 0.02]),
        "r": np.array([0.36, 0.08, TABLE_Z + 0.02]),
    }
    pts = [icps["hand"], icps["p"], icps["q"], icps["r"]]
    path, _ = movement(pts, seconds=[1.6, 1.6, 1.6], lifts=[0.03, 0.08, 0.08], rng=rng)
    return _demonstration("abc", path, icps, seed, (
        "minimum-jerk legs of 1.6 s with a lift arc (height varied +-20%), 0.3 mm "
        "tremor, 20 Hz, world frame, metres. The hand starts at ICP 'hand', touches object 'p' (a), "
        "then 'q' (b), then 'r' (c). Segmented equal-N (N = 3; the legs are equally long) into tags a, b, c."),
        ["a", "b", "c"])


def make_reach(seed: int = 0):
    """Reach an object and come back (see the module docstring), segmented reach, back."""
    rng = np.random.default_rng(seed + 1)
    icps = {"home": np.array([0.18, -0.25, 0.75]), "object": np.array([0.34, -0.10, TABLE_Z + 0.03])}
    path, _ = movement([icps["home"], icps["object"], icps["home"]], seconds=[1.8, 1.8], lifts=[0.04, 0.04], rng=rng)
    return _demonstration("reach", path, icps, seed, (
        "from ICP 'home' the hand reaches and touches 'object', then returns "
        "home; minimum-jerk legs of 1.8 s with a lift arc (height varied +-20%), 0.3 mm tremor, 20 Hz, "
        "metres. Segmented equal-N (N = 2; the legs are equally long) into tags reach, back."),
        ["reach", "back"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Write primitives/abc.yaml and primitives/reach.yaml.")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("primitives"))
    args = ap.parse_args(argv)
    for t in (make_abc(args.seed), make_reach(args.seed)):
        path = save_template(t, args.out / f"{t.name}.yaml")
        print(f"wrote {path}: {len(t.path)} points, tags {', '.join(t.tags())}, "
              + ", ".join(f"{s.tag}=[{s.start},{s.stop})" for s in t.segments))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
