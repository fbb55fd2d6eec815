"""Measurement behind ``hila_lang.osila.segmentation.DEFAULT_METHOD``: which segmenter finds the phases?

Demonstrations with KNOWN phase boundaries, all from the project's own seeded motion models:

- ``legs (k=3)``, ``legs (k=2)``: chains of minimum-jerk legs through random via points with
  random durations (0.8–2.4 s each; ``hila_lang.worlds.scripted.demos.movement``, seeds 0..29); truth
  = the via points, where the hand stops.  (The abc and reach demonstrations have equal legs,
  where an equal split is trivially right.)
- ``circle (k=5)``: the tic-tac-toe demonstration (``hila_lang.worlds.tictactoe.demonstration``, seeds
  0..29) is five minimum-jerk strokes — transit, descent, draw, lift, away; truth = the four
  stops between them, read from the model's construction (the descent and the lift are vertical
  above the circle's first and last points; the draw is where the pen touches).
- ``seen (k=3)``: ``primitives/circle.yaml``, the same demonstration (seed 0) learned through the
  eye cameras — perception noise, smoothing — cut into reach, draw, retract; truth = where the
  pen touched and left the paper.

The default is the method with the smallest mean cut error over these.  Reported beside them,
not used for the choice: ``circle (k=3)``, the noise-free model cut into three against pen
contact.  With four stops and three segments, "the" phase change is ambiguous (the deepest
dips may be the end of the transit or of the lift rather than the touch and the lift-off), and
the model's three phases happen to be about equally long, so an equal split fits them there.

For each segmenter: the mean distance of its cuts from the true boundaries (samples at 20 Hz;
cuts matched to boundaries in order), the share of demonstrations with every cut within 2
samples, and, for the circle cut in three, the share of samples whose segment's contact flag
(draw = pen down) agrees with the pen.  Not a test.  Seeded; about 15 s.

    python bench/segmentation.py
"""

from __future__ import annotations

import numpy as np

from hila_lang.osila.segmentation import DEFAULT_METHOD, METHODS, segments

SEEDS = range(30)


def _demonstrate():
    """The tic-tac-toe demonstration model."""
    from hila_lang.worlds.tictactoe.demonstration import demonstrate

    return demonstrate


def _circles():
    demonstrate = _demonstrate()

    for seed in SEEDS:
        yield demonstrate(seed)


def circle_cases():
    """The model's circle in three against pen contact."""
    for d in _circles():
        yield d.path, d.times, [d.phases["draw"][0], d.phases["retract"][0]], d.contact


def circle_stop_cases():
    """The model's circle in five strokes: truth = the stops between them."""
    for d in _circles():
        on, off = d.phases["draw"][0], d.phases["retract"][0]
        xy = d.path[:, :2]
        above_first = np.flatnonzero(np.all(np.abs(xy[:on] - xy[on]) < 1e-12, axis=1))
        above_last = np.flatnonzero(np.all(np.abs(xy[off:] - xy[off - 1]) < 1e-12, axis=1)) + off
        yield d.path, d.times, [int(above_first[0]), on, off, int(above_last[-1])], None


def seen_circle_case():
    from pathlib import Path

    demonstrate = _demonstrate()
    from hila_lang.osila.template import load_template

    t = load_template(Path(__file__).resolve().parents[1] / "primitives" / "circle.yaml")
    d = demonstrate(0)
    if len(t.path) == len(d.path):
        yield t.path, t.times, [d.phases["draw"][0], d.phases["retract"][0]], d.contact


def leg_cases(legs: int):
    from hila_lang.worlds.scripted.demos import RATE, movement

    for seed in SEEDS:
        rng = np.random.default_rng(1000 * legs + seed)
        points = rng.uniform([0.15, -0.3, 0.6], [0.4, 0.1, 0.75], (legs + 1, 3))
        seconds = rng.uniform(0.8, 2.4, legs)
        path, marks = movement(points, seconds, rng.uniform(0.02, 0.08, legs), rng)
        yield path, np.arange(len(path)) / RATE, marks[1:-1], None


def evaluate(method: str, cases) -> dict:
    errors, exact, agree = [], [], []
    for path, times, truth, contact in cases:
        cuts = [a for a, _ in segments(path, len(truth) + 1, method, times=times)[1:]]
        err = np.abs(np.array(cuts) - np.array(truth))
        errors.extend(err.tolist())
        exact.append(bool((err <= 2).all()))
        if contact is not None and len(cuts) == 2:
            flag = np.zeros(len(path), bool)
            flag[cuts[0]:cuts[1]] = True
            agree.append(float((flag == contact).mean()))
    return {"error": float(np.mean(errors)), "within2": float(np.mean(exact)),
            "contact": float(np.mean(agree)) if agree else float("nan")}


def main() -> None:
    chosen = {"legs (k=3)": lambda: leg_cases(3), "legs (k=2)": lambda: leg_cases(2),
              "circle (k=5)": lambda: circle_stop_cases(), "seen (k=3)": lambda: seen_circle_case()}
    shown = {"circle (k=3)": lambda: circle_cases()}
    print(f"DEFAULT_METHOD in use: {DEFAULT_METHOD}")
    print("mean |cut - true boundary| in samples (20 Hz) (share of demonstrations with every cut within 2 samples"
          "; contact: share of samples whose contact flag matches the pen)")
    overall = {}
    for method in METHODS:
        try:
            rows = {name: evaluate(method, make()) for name, make in {**chosen, **shown}.items()}
        except Exception as exc:  # noqa: BLE001 -- a method that fails is a row, not a crash
            print(f"{method:<12} unavailable: {exc}")
            continue
        overall[method] = float(np.mean([rows[name]["error"] for name in chosen]))
        cells = "  ".join(f"{name}: {r['error']:5.2f} ({100 * r['within2']:3.0f}%"
                          + (f", contact {100 * r['contact']:3.0f}%" if np.isfinite(r["contact"]) else "") + ")"
                          for name, r in rows.items())
        print(f"{method:<12} mean {overall[method]:5.2f} | {cells}")
    best = min(overall, key=overall.get)
    print(f"-> smallest mean cut error over {', '.join(chosen)}: {best} ({overall[best]:.2f} samples)")


if __name__ == "__main__":
    main()
