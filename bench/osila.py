"""Benchmark: ``hila_lang.osila.imitate`` against the bare warp, measured in the same run.

A 1000-point path with 8 ICPs (2-D, then 3-D).  Prints the median wall time of ``imitate`` (warp
with its amplification check, minimum-energy route, plan-adjustment check), of the bare warp
(``fit_warp(src, dst)(path)``: the TPS alone, what the ``tps`` control of ``hila eval`` does) and
of scipy's ``RBFInterpolator(kernel="thin_plate_spline")`` on the same points, and the ratio
``imitate / bare warp`` (target <= 3 in 2-D), for the compiled route kernel and, with
``--numpy``, for the numpy fallback too.  The path is clean, so OSILA's default ball (2 σ of the
path's noise, :mod:`hila_lang.osila.noise`) would be almost nothing and the route trivial: the
benchmark passes ``threshold`` = 1 % of the mapped path's size, a ball holding all 17 (2-D) / 29
(3-D) candidates, so the route is timed at its full cost.  Not a test.

    python bench/osila.py [--repeat 200] [--numpy]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

TARGET_RATIO = 3.0


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


def measure(repeat: int, label: str) -> None:
    from scipy.interpolate import RBFInterpolator

    from hila_lang.osila import imitate
    from hila_lang.osila.candidates import ball_offsets
    from hila_lang.osila.route import _compiled_route, min_energy_route
    from hila_lang.osila.tps import fit_warp

    kernel = "numba kernel" if _compiled_route() is not None else "numpy"
    for dim in (2, 3):
        path, src, dst = case(dim)
        mapped = fit_warp(src, dst)(path)
        threshold = 0.01 * float(np.linalg.norm(np.ptp(mapped, axis=0)))
        offsets = ball_offsets(dim, threshold)
        # interleave the measurements so a busy moment hits all of them alike
        t_imitate, t_warp, t_rbf, t_route = [], [], [], []
        for _ in range(5):
            t_imitate.append(median_ms(lambda: imitate(path, src, dst, threshold=threshold), repeat // 5 + 1))
            t_warp.append(median_ms(lambda: fit_warp(src, dst)(path), repeat // 5 + 1))
            t_rbf.append(median_ms(lambda: RBFInterpolator(src, dst, kernel="thin_plate_spline")(path),
                                   repeat // 5 + 1))
            t_route.append(median_ms(lambda: min_energy_route(mapped, offsets), repeat // 5 + 1))
        im, wa, rb, ro = (float(np.median(x)) for x in (t_imitate, t_warp, t_rbf, t_route))
        target = f" (target <= {TARGET_RATIO:g})" if dim == 2 else ""
        print(f"{label} {dim}-D, T = {len(path)}, K = {len(src)}, M = {len(offsets)} candidates, route: {kernel}")
        print(f"  imitate {im:.3f} ms | bare warp {wa:.3f} ms | RBFInterpolator {rb:.3f} ms | route alone {ro:.3f} ms")
        print(f"  imitate / bare warp = {im / wa:.2f}{target};  imitate / RBFInterpolator = {im / rb:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=200)
    ap.add_argument("--numpy", action="store_true", help="also measure with the numpy route (HILA_JIT=0)")
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} cores (shared); medians of {args.repeat} runs")
    measure(args.repeat, "imitate")
    if args.numpy:
        from hila_lang import jit

        os.environ["HILA_JIT"] = "0"
        jit.reset()
        measure(max(args.repeat // 10, 10), "numpy fallback")


if __name__ == "__main__":
    main()
