"""Measurements behind two OSILA defaults: the ball's size and the re-timing prior.

Neither uses LASA.  ``--ball`` uses only synthetic templates; ``--timing`` uses synthetic
renditions and also the project's generated stand-in (Experiment A's data), split by set-up:
the stand-in's figures under the default re-timing are therefore not independent of it.

``--ball`` (the default threshold, ``hila_lang.osila.noise``): synthetic templates with a KNOWN
answer — a random smooth curve (``bench/warp.py``'s), mapped by a known random true map with
ICPs around it located exactly, so the warp is right and the only question is what the route
adds.  The template is seen with white noise of 0, 0.2, 0.5 and 1 % of its extent; the task's
truth is the true map of the noise-free curve.  Printed: mean MSD (× 1e4, unit extent²) and
Fréchet distance (% of the extent) of ``imitate`` against the truth for balls of 0, 1, 2, 3 and
4 σ̂ (σ̂ the noise estimated from the path) and of 1 % of the path's size.

``--timing`` (the re-timing prior, ``hila_lang.osila.timing``):

1. synthetic pairs with a known answer: two renditions of one curve, each drawn with a
   minimum-jerk speed profile whose peak moves per rendition (time to peak speed 42–57 %,
   MacKenzie et al. 1987, as in the stand-in) and each moved by its own random similarity and a
   mild smooth deformation; constraints at time fractions k/N (as ``hila eval --dataset lasa``);
   truth = the task rendition.  A second scenario draws both with the SAME timing (where
   re-timing can only lose).
2. the stand-in, paper protocol (its boundaries are points of the task path at k/N), split into
   pairs of the same set-up (the same movement: timing to recover) and of different set-ups (a
   different movement: nothing to recover, Experiment A's cross-mapping).  The default is the
   widest prior whose across-set-up mean Fréchet distance is within 1 % of keeping the stamps.

Not a test.  Seeded.

    python bench/route.py [--ball] [--timing] [--pairs 300] [--rows-step 3]
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from pathlib import Path

import numpy as np

NOISE = (0.0, 0.002, 0.005, 0.01)
PRIORS = (0.0, 0.02, 0.03, 0.04, 0.06)


def _warp_bench():
    spec = importlib.util.spec_from_file_location("bench_warp", Path(__file__).with_name("warp.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def ball(pairs: int, seed: int) -> None:
    from hila_lang.core.jit import batch
    from hila_lang.metrics import frechet, msd
    from hila_lang.osila import imitate
    from hila_lang.osila.noise import position_noise

    wb = _warp_bench()
    rng = np.random.default_rng(seed)
    res: dict = {}
    names = ("0", "1 σ̂", "2 σ̂ (default)", "3 σ̂", "4 σ̂", "1 % of size")
    with batch():
        for _ in range(pairs):
            T = int(rng.integers(40, 161))
            clean = wb.curve(rng, 2, T)
            g = wb.true_map(rng, 2, 0.1, 0.05)
            K = int(rng.integers(4, 9))
            src = rng.uniform(clean.min(0) - 0.2, clean.max(0) + 0.2, (K, 2))
            truth = g(clean)
            for sigma in NOISE:
                tp = clean + rng.normal(0, sigma, clean.shape)
                s = position_noise(g(tp))
                size = float(np.linalg.norm(np.ptp(truth, axis=0)))
                for name, thr in zip(names, (0.0, s, None, 3 * s, 4 * s, 0.01 * size)):
                    out = imitate(tp, src, g(src), threshold=thr, timing=0.0)
                    res.setdefault((sigma, name), []).append((msd(out, truth) * 1e4, frechet(out, truth) * 100))
    print("--ball: mean MSD (x 1e4, unit extent) / Fréchet (% of extent) of imitate against the truth")
    print(f"{'template noise':>16} | " + " | ".join(f"{n:>15}" for n in names))
    for sigma in NOISE:
        cells = [np.mean(res[(sigma, n)], axis=0) for n in names]
        print(f"{100 * sigma:>14.1f} % | " + " | ".join(f"{m:6.2f} / {f:5.2f}" for m, f in cells))


def _rendition(rng, base, skew, deform):
    from hila_lang.osila.motion import minimum_jerk

    wb = _warp_bench()
    T = int(rng.integers(40, 161))
    s = minimum_jerk(np.linspace(0.0, 1.0, T) ** rng.uniform(*skew))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(base, axis=0), axis=1))])
    along = np.column_stack([np.interp(s * arc[-1], arc, base[:, d]) for d in range(2)])
    ang, scale = rng.uniform(-np.pi, np.pi), rng.uniform(0.7, 1.4)
    R = scale * np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    return wb.true_map(rng, 2, *deform)(along) @ R.T + rng.normal(0, 1, 2)


def timing_synthetic(pairs: int, seed: int) -> None:
    from hila_lang.core.jit import batch
    from hila_lang.metrics import frechet, msd
    from hila_lang.osila import imitate

    wb = _warp_bench()
    print("\n--timing, synthetic renditions (constraints at time fractions k/N; truth = the task rendition):")
    print("mean MSD (x 1e4 / extent²) / Fréchet (% of extent), per prior sigma_t")
    for label, skew in (("speed peak 42-57 % (human-like)", (0.8, 1.25)), ("the same timing", (1.0, 1.0))):
        rng = np.random.default_rng(seed)
        res: dict = {}
        with batch():
            for _ in range(pairs):
                base = wb.curve(rng, 2, 2000)
                tp = _rendition(rng, base, skew, (0.05, 0.02))
                task = _rendition(rng, base, skew, (0.05, 0.02))
                ext = float(np.ptp(task, axis=0).max())
                for n in (2, 3, 4):
                    a = [round(k * (len(tp) - 1) / n) for k in range(n + 1)]
                    b = [round(k * (len(task) - 1) / n) for k in range(n + 1)]
                    when = [k / (len(task) - 1) for k in b]  # the pairs carry the task's time: re-timed
                    for p in PRIORS:
                        out = imitate(tp, tp[a], task[b], timing=p, task_times=when)
                        res.setdefault((n, p), []).append((msd(out, task) / ext**2 * 1e4, frechet(out, task) / ext * 100))
        print(f"  {label}:")
        for n in (2, 3, 4):
            print(f"    N = {n}: " + "  ".join(f"{p:g}: {np.mean(res[(n, p)], axis=0)[0]:6.1f} / "
                                            f"{np.mean(res[(n, p)], axis=0)[1]:5.2f}" for p in PRIORS))


def timing_standin(rows_step: int) -> None:
    from hila_lang.evaluation.dataset import generate
    from hila_lang.evaluation.grid import evaluate_rows

    trials = generate(0)
    setup = np.array([t.setup for t in trials])
    rows = list(range(0, len(trials), rows_step))
    same = (setup[rows][:, None] == setup[None, :]) & ~np.eye(len(trials), dtype=bool)[rows]
    other = setup[rows][:, None] != setup[None, :]
    print(f"\n--timing, the stand-in, paper protocol (threshold 2 px), {len(rows)} templates x 75 tasks:")
    print("mean MSD (px²) / Fréchet (px) over N = 2, 3, 4, per prior sigma_t")
    base = None
    chosen = 0.0
    for p in PRIORS:
        out = evaluate_rows(trials, rows, segments=(2, 3, 4), options={"threshold": 2.0, "timing": p}, protocol="paper")
        sc = np.stack([r.scores["osila"] for r in out], axis=1)  # (S, rows, J, M)
        within = sc[:, same][..., 1:3].mean((0, 1))
        across = sc[:, other][..., 1:3].mean((0, 1))
        if base is None:
            base = across
        ok = across[1] <= 1.01 * base[1]
        if ok:
            chosen = p
        print(f"  sigma_t = {p:<5g} same set-up {within[0]:7.1f} / {within[1]:6.2f}   other set-ups "
              f"{across[0]:7.1f} / {across[1]:6.2f}  ({100 * (across[1] / base[1] - 1):+.1f} % Fréchet)")
    print(f"  -> the widest prior within 1 % of keeping the stamps across set-ups: sigma_t = {chosen:g}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ball", action="store_true", help="the ball's size (default when neither is given)")
    ap.add_argument("--timing", action="store_true", help="the re-timing prior")
    ap.add_argument("--pairs", type=int, default=300, help="synthetic pairs per scenario (default 300)")
    ap.add_argument("--rows-step", type=int, default=3, help="stand-in: every k-th template (default 3)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    if args.ball or not args.timing:
        ball(args.pairs, args.seed)
    if args.timing:
        timing_synthetic(args.pairs, args.seed)
        timing_standin(args.rows_step)
    print(f"\n({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
