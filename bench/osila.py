"""Benchmark: ``hila_lang.osila.imitate`` on a 1000-point 2-D path with 8 ICPs.

Prints the median wall time over repeated runs (target <= 5 ms on the 2-core project machine),
plus the split between the warp and the route search, and the same for 3-D.  Not a test.

    /work/venv/bin/python bench/osila.py [--repeat 50]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hila_lang.osila import imitate
from hila_lang.osila.adjust import default_threshold
from hila_lang.osila.candidates import ball_offsets
from hila_lang.osila.route import min_energy_route
from hila_lang.osila.tps import fit_warp


def case(dim: int, T: int = 1000, K: int = 8, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, T)
    cols = [np.cos(t) * (1 + 0.3 * np.sin(3 * t)), np.sin(t), 0.2 * np.sin(2 * t)][:dim]
    path = np.column_stack(cols)
    src = rng.uniform(-1.2, 1.2, (K, dim))
    dst = 1.1 * src + rng.normal(0, 0.05, (K, dim)) + 0.3
    return path, src, dst


def median_ms(fn, repeat: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeat):
        a = time.perf_counter()
        fn()
        times.append(time.perf_counter() - a)
    return float(np.median(times) * 1e3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=50)
    args = ap.parse_args()
    for dim in (2, 3):
        path, src, dst = case(dim)
        total = median_ms(lambda: imitate(path, src, dst), args.repeat)
        warp = fit_warp(src, dst)
        mapped = warp(path)
        offsets = ball_offsets(dim, default_threshold(mapped))
        t_warp = median_ms(lambda: fit_warp(src, dst)(path), args.repeat)
        t_route = median_ms(lambda: min_energy_route(mapped, offsets), args.repeat)
        label = " (target <= 5 ms)" if dim == 2 else ""
        print(f"imitate {dim}-D, T = {len(path)}, K = {len(src)}, M = {len(offsets)} candidates: "
              f"median {total:.2f} ms{label}  [warp {t_warp:.2f} ms, route {t_route:.2f} ms]")


if __name__ == "__main__":
    main()
