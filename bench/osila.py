"""Benchmark: ``hila_lang.osila.imitate`` against the cheapest exact TPS, measured in the same run.

Two parts, both printed by one run:

1. **Scaling** (issue 24, item 3): ``imitate / floor`` at K = 10, 50, 200, 1000 ICPs and
   T = 1000, 10000 stamps, 2-D and 3-D, in two scenes per size — one where OSILA chooses the
   similarity fallback (the task ICPs are a similarity of the template's plus noise of 1 % of
   the extent: a rigid placement) and one where the TPS wins (a smooth bend, exact ICPs).  The
   *floor* is the cheapest exact TPS fit plus evaluation in numpy: the kernel matrix, one
   symmetric (K + D + 1) solve (LAPACK ``sysv``), one T x K kernel evaluation and product.
   Goals: ``imitate / floor`` <= 4 where the fallback is chosen, <= 8 where the TPS wins, and
   K = 1000, T = 10000 under 1 s.  The template ICPs are a jittered grid over the path's box
   (scene features spread around the path), so the TPS's amplification stays small.
2. **The small case**: a 1000-point path with 8 noisy ICPs (2-D, then 3-D), ``imitate`` against
   scipy's ``RBFInterpolator(kernel="thin_plate_spline")`` on the same points (goal <= 3 in 2-D),
   twice: with the route at full cost (below) and as a user calls it, with default options (the
   threshold from the path's own noise, :func:`hila_lang.osila.noise.default_threshold`).  Issue
   38 found the two disagreeing (1.84 here, 3.6-5.1 measured by hand): the hand measurement ran
   with the BLAS's default threads (two here; now hila's policy is one, as this bench always
   used) and paid the default threshold's noise estimate, which the row with ``threshold`` given
   never did.  Both rows are printed now and both are held to the goal.

The route runs at its full cost: ``threshold`` = 1 % of the mapped path's size, a ball holding
all 17 (2-D) / 29 (3-D) candidates (OSILA's default, 2 σ of the path's noise, would be almost
nothing on these clean paths).  Times are medians of interleaved repeats (a busy moment hits all
alike; rows under 5 ms a call are repeated 8x ``--repeat``); the load average is printed.  Not
a test.

    python bench/osila.py [--repeat 5] [--small-repeat 200] [--sizes 10,50,200,1000] [--threads N|auto] [--numpy]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

TARGET_RATIO = 3.0
GOAL = {"fallback": 4.0, "tps": 8.0}


def case(dim: int, T: int = 1000, K: int = 8, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, T)
    cols = [np.cos(t) * (1 + 0.3 * np.sin(3 * t)), np.sin(t), 0.2 * np.sin(2 * t)][:dim]
    path = np.column_stack(cols)
    src = rng.uniform(-1.2, 1.2, (K, dim))
    dst = 1.1 * src + rng.normal(0, 0.05, (K, dim)) + 0.3
    return path, src, dst


def scene(dim: int, T: int, K: int, kind: str, seed: int = 0):
    """(path (T, D), template ICPs (K, D), task ICPs (K, D)) for a scaling row.

    ``kind`` "fallback": task = a similarity of the template ICPs + N(0, 1 % of the extent);
    "tps": task = a smooth bend of them (no noise).  Template ICPs: a jittered grid over the box
    of the path, K points.
    """
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, T)
    path = np.column_stack([np.cos(t) * (1 + 0.3 * np.sin(3 * t)), np.sin(t), 0.4 * np.sin(2 * t)][:dim])
    lo, hi = path.min(0) - 0.1, path.max(0) + 0.1
    n = int(np.ceil(K ** (1.0 / dim)))
    axes = [np.linspace(0, 1, n)] * dim
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    grid = grid[rng.permutation(len(grid))[:K]]
    src = lo + (hi - lo) * (grid + rng.uniform(-0.3, 0.3, grid.shape) / n)
    if kind == "fallback":
        ang = 0.4
        R = np.eye(dim)
        R[:2, :2] = [[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]]
        dst = 0.8 * src @ R.T + 0.3 + rng.normal(0, 0.01 * float(np.ptp(path, 0).max()), src.shape)
    else:
        dst = 1.1 * src + 0.15 * np.sin(1.5 * src[:, ::-1]) + 0.3
    return path, src, dst


def adjustment_scene(dim: int, T: int, K: int, seed: int = 0):
    """(path, template ICPs, task ICPs, threshold, obstacles) for plan adjustment over several rounds.

    The bending scene of :func:`scene` with its ICPs kept off the path (none within 5 % of the
    mapped path's size: an obstacle over an ICP the path passes would be a contradiction), and
    spheres of radius 6 % of that size centred on the mapped path every 150 stamps, which the
    route must leave: each round's repair pairs bend the warp, and the next round checks again.
    """
    from hila_lang.osila.tps import _dist_numpy, fit_warp

    path, src, dst = scene(dim, T, 3 * K, "tps", seed)
    size = float(np.linalg.norm(np.ptp(path, axis=0)))
    keep = _dist_numpy(src, path).min(1) > 0.05 * size
    src, dst = src[keep][:K], dst[keep][:K]
    mapped = fit_warp(src, dst)(path)
    size = float(np.linalg.norm(np.ptp(mapped, axis=0)))
    obstacles = np.array([np.append(mapped[t], 0.06 * size) for t in range(T // 10, T - T // 10, (15 * T) // 100)])
    return path, src, dst, 0.01 * size, obstacles


def floor_fn(path: np.ndarray, src: np.ndarray, dst: np.ndarray):
    """The cheapest exact TPS fit + evaluation in numpy (one symmetric solve, one T x K kernel)."""
    from scipy.linalg import solve

    from hila_lang.osila.tps import _dist_numpy as _dist, kernel

    def run():
        K, D = src.shape
        A = np.zeros((K + D + 1, K + D + 1))
        A[:K, :K] = kernel(_dist(src, src), D)
        A[:K, K] = A[K, :K] = 1.0
        A[:K, K + 1:] = src
        A[K + 1:, :K] = src.T
        rhs = np.zeros((K + D + 1, D))
        rhs[:K] = dst
        sol = solve(A, rhs, assume_a="sym", check_finite=False)
        return kernel(_dist(path, src), D) @ sol[:K] + sol[K] + path @ sol[K + 1:]

    return run


def median_ms(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        a = time.perf_counter()
        fn()
        times.append(time.perf_counter() - a)
    return float(np.median(times) * 1e3)


def scaling(sizes, stamps, repeat: int) -> None:
    from hila_lang.osila import imitate_detailed
    from hila_lang.osila.candidates import ball_offsets
    from hila_lang.osila.route import min_energy_route
    from hila_lang.osila.tps import fit_warp, forget

    print("scaling: imitate / floor (floor = exact TPS: kernel matrix + one symmetric solve + T x K evaluation);")
    print("  route/floor = the minimum-energy route alone on the mapped path (part of imitate, not of the floor);")
    print("  first call = imitate with nothing remembered from the call before (new pairs: the warp's inverses")
    print("  are taken again; repeated calls with the same pairs reuse them)")
    print(f"  {'D':>2} {'T':>6} {'K':>5}  {'scene':<8} {'chosen':<10} {'imitate ms':>11} {'floor ms':>9} {'ratio':>6}  "
          f"{'route/floor':>11}  {'first call':>10}  goal")
    for dim in (2, 3):
        for T in stamps:
            for K in sizes:
                for kind in ("fallback", "tps"):
                    path, src, dst = scene(dim, T, K, kind)
                    mapped = fit_warp(src, dst)(path)
                    threshold = 0.01 * float(np.linalg.norm(np.ptp(mapped, axis=0)))
                    floor = floor_fn(path, src, dst)
                    got = imitate_detailed(path, src, dst, threshold=threshold)  # also warms up
                    chosen, offsets = got.warp.kind, ball_offsets(dim, threshold)
                    floor()
                    # a busy moment hits a sub-millisecond row far more often than one repeat in
                    # five: the cheap rows are repeated 8x as often (a second or so each), so
                    # their medians hold on a shared machine; the large ones as given
                    a = time.perf_counter()
                    imitate_detailed(path, src, dst, threshold=threshold)
                    cheap = time.perf_counter() - a < 5e-3
                    reps = 8 * repeat if cheap else repeat if K * K * max(T, K) < 2e9 else max(2, repeat // 2)
                    t_im, t_fl, t_ro, t_first = [], [], [], []
                    for _ in range(reps):
                        t_im.append(median_ms(lambda: imitate_detailed(path, src, dst, threshold=threshold), 1))
                        t_fl.append(median_ms(floor, 1))
                        t_ro.append(median_ms(lambda: min_energy_route(got.mapped, offsets, pinned=[0, T - 1]), 1))
                        forget()
                        t_first.append(median_ms(lambda: imitate_detailed(path, src, dst, threshold=threshold), 1))
                    im, fl, ro = float(np.median(t_im)), float(np.median(t_fl)), float(np.median(t_ro))
                    first = float(np.median(t_first))
                    goal = GOAL["tps" if chosen == "tps" else "fallback"]
                    flag = "ok" if im / fl <= goal else "OVER"
                    flag_first = "ok" if first / fl <= goal else "OVER"
                    extra = ""
                    if K == 1000 and T == 10000:
                        extra = (f"; {im / 1e3:.2f} s, first call {first / 1e3:.2f} s "
                                 f"({'ok' if max(im, first) < 1e3 else 'OVER'} 1 s)")
                    print(f"  {dim:>2} {T:>6} {K:>5}  {kind:<8} {chosen:<10} {im:>11.1f} {fl:>9.1f} {im / fl:>6.2f}  "
                          f"{ro / fl:>11.2f}  {first / fl:>10.2f}  <= {goal:g} {flag}, first call {flag_first}{extra}",
                          flush=True)


def adjustment(sizes, repeat: int) -> None:
    """Plan adjustment over several rounds (:func:`adjustment_scene`), with the bordered update of
    the warp's inverses (:mod:`hila_lang.osila.bordered`) and refactorising every round, interleaved:
    the whole run, and the warp fits of all its rounds (the outlier screen, the same in both, not
    included)."""
    import importlib

    from hila_lang.osila import bordered, imitate_detailed

    modules = [importlib.import_module(f"hila_lang.osila.{m}") for m in ("adjust", "timing")]
    spent: list[float] = []
    real = modules[0].choose_warp  # OSILA's warp (the path warp where pairs hold the path's ends, else fit_warp)

    def timed(*args, **kwargs):
        a = time.perf_counter()
        try:
            return real(*args, **kwargs)
        finally:
            spent[-1] += time.perf_counter() - a

    print("plan adjustment: the warp's inverses bordered while the pairs grow vs refactorised every round "
          "(T = 1000, obstacles on the path)")
    print(f"  {'D':>2} {'K':>5} {'rounds':>6}  {'run, bordered':>13} {'refactorised':>12} {'ratio':>6}  "
          f"{'fits, bordered':>14} {'refactorised':>12} {'ratio':>6}")
    for m in modules:
        m.choose_warp = timed
    try:
        for dim in (2, 3):
            for K in sizes:
                path, src, dst, threshold, obstacles = adjustment_scene(dim, 1000, K)
                runs = {True: [], False: []}
                fits = {True: [], False: []}
                rounds = None
                for _ in range(repeat):
                    for reuse in (True, False):
                        bordered.REUSE = reuse
                        spent.append(0.0)
                        a = time.perf_counter()
                        got = imitate_detailed(path, src, dst, threshold=threshold, obstacles=obstacles, rounds=20)
                        runs[reuse].append(time.perf_counter() - a)
                        fits[reuse].append(spent[-1])
                        rounds = got.rounds
                run = {k: float(np.median(v)) * 1e3 for k, v in runs.items()}
                fit = {k: float(np.median(v)) * 1e3 for k, v in fits.items()}
                print(f"  {dim:>2} {K:>5} {rounds:>6}  {run[True]:>10.1f} ms {run[False]:>9.1f} ms "
                      f"{run[True] / run[False]:>6.2f}  {fit[True]:>11.1f} ms {fit[False]:>9.1f} ms "
                      f"{fit[True] / fit[False]:>6.2f}", flush=True)
    finally:
        for m in modules:
            m.choose_warp = real
        bordered.REUSE = True


def small(repeat: int, label: str) -> None:
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
        imitate(path, src, dst, threshold=threshold)  # warm-up
        # interleave the measurements so a busy moment hits all of them alike
        t_imitate, t_warp, t_rbf, t_route, t_default = [], [], [], [], []
        for _ in range(5):
            t_imitate.append(median_ms(lambda: imitate(path, src, dst, threshold=threshold), repeat // 5 + 1))
            t_warp.append(median_ms(lambda: fit_warp(src, dst)(path), repeat // 5 + 1))
            t_rbf.append(median_ms(lambda: RBFInterpolator(src, dst, kernel="thin_plate_spline")(path),
                                   repeat // 5 + 1))
            t_route.append(median_ms(lambda: min_energy_route(mapped, offsets), repeat // 5 + 1))
            t_default.append(median_ms(lambda: imitate(path, src, dst), repeat // 5 + 1))
        im, wa, rb, ro, de = (float(np.median(x)) for x in (t_imitate, t_warp, t_rbf, t_route, t_default))

        def verdict(ratio):
            return f" (target <= {TARGET_RATIO:g}: {'ok' if ratio <= TARGET_RATIO else 'OVER'})" if dim == 2 else ""

        print(f"{label} {dim}-D, T = {len(path)}, K = {len(src)}, M = {len(offsets)} candidates, route: {kernel}")
        print(f"  imitate {im:.3f} ms | bare warp {wa:.3f} ms | RBFInterpolator {rb:.3f} ms | route alone {ro:.3f} ms"
              f" | imitate with default options {de:.3f} ms")
        print(f"  imitate / RBFInterpolator = {im / rb:.2f}{verdict(im / rb)};  imitate / bare warp = {im / wa:.2f}")
        print(f"  default options: imitate / RBFInterpolator = {de / rb:.2f}{verdict(de / rb)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="repeats per scaling row (median)")
    ap.add_argument("--small-repeat", type=int, default=200, help="repeats of the small case (median)")
    ap.add_argument("--sizes", default="10,50,200,1000", help="K values of the scaling table")
    ap.add_argument("--stamps", default="1000,10000", help="T values of the scaling table")
    ap.add_argument("--adjust-sizes", default="200,1000",
                    help="K values of the plan-adjustment comparison (bordered vs refactorised; '' skips it)")
    ap.add_argument("--numpy", action="store_true", help="also measure the small case with numpy only (HILA_JIT=0)")
    ap.add_argument("--threads", default=None,
                    help="BLAS threads for both sides: a number, or 'auto' for the libraries' default "
                         "(default: hila's own policy, hila_lang.core.threads: one thread unless HILA_THREADS says otherwise)")
    args = ap.parse_args()
    from contextlib import nullcontext

    import hila_lang  # noqa: F401 -- hila's thread policy, as every user of hila gets it
    import scipy.linalg  # noqa: F401 -- scipy's own BLAS, loaded before any limit so that it applies to it too
    from threadpoolctl import threadpool_info, threadpool_limits

    from hila_lang.core.threads import parse

    # 'auto' (parse: None) is a thread per core, whatever hila set
    limits = nullcontext() if args.threads is None else threadpool_limits(parse(args.threads) or os.cpu_count())
    with limits:
        blas = sorted({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"})
        print(f"machine: {os.cpu_count()} cores (shared); load average {os.getloadavg()[0]:.2f} at start; "
              f"BLAS threads: {','.join(map(str, blas))} "
              f"({'hila default' if args.threads is None else '--threads ' + args.threads})")
        scaling([int(k) for k in args.sizes.split(",")], [int(t) for t in args.stamps.split(",")], args.repeat)
        adjustment([int(k) for k in args.adjust_sizes.split(",") if k], args.repeat)
        small(args.small_repeat, "imitate")
    if args.numpy:
        from hila_lang.core import jit

        os.environ["HILA_JIT"] = "0"
        jit.reset()
        small(max(args.small_repeat // 10, 10), "numpy fallback")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
