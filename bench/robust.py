"""Measurement behind ``hila_lang.osila.robust``: which outlier rejection, on many noisy pairs?

Seeded synthetic scenes with a KNOWN answer (no evaluation data set is used):

- a template path: a random smooth curve (``bench/warp.py``'s), unit extent, 200 points;
- a true map g: a random linear part (stretch/shear ~10 %) plus three Gaussian bumps (~5 %);
- K ICPs on a jittered grid over the path's box (scene features around the path); their task
  points are g(ICP) + N(0, sigma) (sigma = 0.5 % of the extent), and a fraction of them (the
  outliers) replaced by uniform points in the task scene's box — a feature matched to a
  look-alike elsewhere.

For each ``reject`` method, the route's RMS error against g(template) (task units, % of the
extent) over the seeds: median and 90th percentile, and the share of outliers rejected and of
good pairs kept.  Not a test.  About a minute.

    python bench/robust.py [--seeds 20] [--pairs 40]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from warp import curve, true_map  # noqa: E402

METHODS = ("none", "loo", "lmeds")


def scene(rng, dim: int, K: int, outliers: float, sigma: float = 0.005):
    path = curve(rng, dim, 200)
    g = true_map(rng, dim, 0.1, 0.05)
    lo, hi = path.min(0) - 0.1, path.max(0) + 0.1
    n = int(np.ceil(K ** (1.0 / dim)))
    grid = np.stack(np.meshgrid(*[np.linspace(0, 1, n)] * dim, indexing="ij"), -1).reshape(-1, dim)
    grid = grid[rng.permutation(len(grid))[:K]]
    src = lo + (hi - lo) * (grid + rng.uniform(-0.3, 0.3, grid.shape) / n)
    dst = g(src) + rng.normal(0, sigma, src.shape)
    bad = rng.permutation(K)[: int(round(outliers * K))]
    tlo, thi = dst.min(0), dst.max(0)
    dst[bad] = rng.uniform(tlo, thi, (len(bad), dim))
    return path, src, dst, g(path), bad


def main() -> None:
    from hila_lang.osila import imitate_detailed

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--pairs", type=int, default=40)
    args = ap.parse_args()
    print(f"K = {args.pairs} pairs, {args.seeds} seeded scenes per row; route RMS error in % of the extent")
    print(f"  {'D':>2} {'outliers':>8}  " + "  ".join(f"{m + ' med/p90':>16}" for m in METHODS)
          + "   lmeds: outliers cut / good kept")
    for dim in (2, 3):
        for frac in (0.0, 0.2, 0.3, 0.4):
            errs = {m: [] for m in METHODS}
            cut, kept = [], []
            for seed in range(args.seeds):
                rng = np.random.default_rng(1000 * dim + seed)
                path, src, dst, truth, bad = scene(rng, dim, args.pairs, frac)
                for m in METHODS:
                    res = imitate_detailed(path, src, dst, reject=m)
                    errs[m].append(100 * float(np.sqrt(((res.path - truth) ** 2).sum(1).mean())))
                    if m == "lmeds":
                        rej = set(res.pairs.rejected.tolist())
                        if len(bad):
                            cut.append(len(rej & set(bad.tolist())) / len(bad))
                        kept.append(1 - len(rej - set(bad.tolist())) / (args.pairs - len(bad)))
            row = "  ".join(f"{np.median(errs[m]):7.2f}/{np.percentile(errs[m], 90):7.2f}" + " " * 1 for m in METHODS)
            share = (f"{100 * np.mean(cut):5.1f} % / " if cut else "    - / ") + f"{100 * np.mean(kept):5.1f} %"
            print(f"  {dim:>2} {100 * frac:>7.0f}%  {row}   {share}", flush=True)


if __name__ == "__main__":
    main()
