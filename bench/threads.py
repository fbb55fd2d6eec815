"""Benchmark: each kind of work hila does, with one thread per library and with every core, in one run.

The measurement behind hila's thread policy (:mod:`hila_lang.core.threads`, ``docs/benchmarks.md``
"Threads").  Each row is timed with 1 thread and with ``os.cpu_count()`` threads per library
(``threadpoolctl`` for the BLAS and OpenMP copies, ``cv2.setNumThreads`` for OpenCV), the two
settings interleaved repeat by repeat so a busy moment of a shared machine hits both alike;
medians.  Rows, small to large:

- ``imitate`` of the issue's small case (1000-point 2-D path, 8 ICPs; ``bench/osila.py``'s);
- ``imitate`` 3-D, T = 1000, K = 200, and 2-D, T = 10000, K = 1000 (a bend: the TPS is chosen),
  each repeated (the warp's inverses remembered) and as a first call (nothing remembered);
- plan adjustment, 2-D, K = 200 and 1000 (``bench/osila.py``'s obstacle scene, several rounds);
- one row of ``hila eval``'s paper protocol (what one worker process does: a template mapped
  onto all 75 tasks at N = 1..4);
- perception: one eye calibrated from 20 rendered chessboard views (OpenCV's corner finder and
  ``calibrateCamera``).

The last line: ``threads best=<1|N|-> worst_ratio=<max of N-thread time / 1-thread time>``
(``best``: the setting no row lost by more than 10 %, ``-`` if each lost somewhere).
Not a test.

    python bench/threads.py [--repeat 5] [--quick]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import time
from pathlib import Path

import numpy as np

import hila_lang  # noqa: F401 -- the policy is applied first, as for any hila user

HERE = Path(__file__).resolve().parent


def _bench_osila():
    spec = importlib.util.spec_from_file_location("bench_osila", HERE / "osila.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _set(n: int):
    from threadpoolctl import threadpool_limits

    limits = threadpool_limits(n)
    if "cv2" in sys.modules:
        sys.modules["cv2"].setNumThreads(n)
    return limits


def rows(quick: bool):
    """(label, callable) per kind of work, each set up once."""
    from hila_lang.osila import imitate, imitate_detailed
    from hila_lang.osila.tps import fit_warp, forget

    b = _bench_osila()
    out = []
    path, src, dst = b.case(2)
    thr = 0.01 * float(np.linalg.norm(np.ptp(fit_warp(src, dst)(path), axis=0)))
    out.append(("imitate 2-D T=1000 K=8 (the small case)", lambda: imitate(path, src, dst, threshold=thr)))
    sizes = [(3, 1000, 200)] + ([] if quick else [(2, 10000, 1000)])
    for dim, T, K in sizes:
        p, s, d = b.scene(dim, T, K, "tps")
        th = 0.01 * float(np.linalg.norm(np.ptp(fit_warp(s, d)(p), axis=0)))
        out.append((f"imitate {dim}-D T={T} K={K}, repeated",
                    lambda p=p, s=s, d=d, th=th: imitate_detailed(p, s, d, threshold=th)))

        def first(p=p, s=s, d=d, th=th):
            forget()
            imitate_detailed(p, s, d, threshold=th)

        out.append((f"imitate {dim}-D T={T} K={K}, first call", first))
    for K in [200] + ([] if quick else [1000]):
        p, s, d, th, obstacles = b.adjustment_scene(2, 1000, K)
        out.append((f"plan adjustment 2-D T=1000 K={K}",
                    lambda p=p, s=s, d=d, th=th, o=obstacles: imitate_detailed(p, s, d, threshold=th,
                                                                                obstacles=o, rounds=20)))
    from hila_lang.core.jit import batch
    from hila_lang.evaluation.dataset import generate
    from hila_lang.evaluation.grid import evaluate_row

    trials = generate(seed=0)

    def eval_row():
        with batch():
            evaluate_row(trials, 0, (1, 2, 3, 4), ("osila",), {}, "paper")

    out.append(("hila eval: one row of the paper protocol (75 tasks x N = 1..4)", eval_row))
    from hila_lang.perception.calibration import calibrate, chessboard_views
    from hila_lang.robot.lens import true_lens

    views = chessboard_views(true_lens(2), 20, seed=0)
    out.append(("perception: one eye calibrated from 20 chessboard views", lambda: calibrate(views)))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="interleaved repeats per row (median)")
    ap.add_argument("--quick", action="store_true", help="skip the K = 1000 rows")
    args = ap.parse_args(argv)
    many = os.cpu_count() or 1
    print(f"machine: {many} cores (shared); load average {os.getloadavg()[0]:.2f} at start; "
          f"1 thread vs {many} per library", flush=True)
    work = rows(args.quick)
    print(f"  {'work':<66} {'1 thread':>10} {f'{many} threads':>10} {'ratio':>6}  best")
    worst, best = 0.0, set()
    for label, fn in work:
        times = {1: [], many: []}
        for n in (1, many):  # warm-up: compiled kernels, caches
            with _set(n):
                a = time.perf_counter()
                fn()
                took = time.perf_counter() - a
        calls = max(1, int(0.02 / max(took, 1e-6)))  # a sample of a fast row is several calls: >= 20 ms
        for _ in range(args.repeat if calls == 1 else 4 * args.repeat):
            for n in (1, many):
                with _set(n):
                    a = time.perf_counter()
                    for _ in range(calls):
                        fn()
                    times[n].append((time.perf_counter() - a) / calls)
        one, all_ = (float(np.median(times[n])) * 1e3 for n in (1, many))
        ratio = all_ / one
        worst = max(worst, ratio)
        winner = "1" if ratio > 1.1 else (str(many) if ratio < 0.9 else "-")  # within 10 %: a draw
        best.add(winner)
        print(f"  {label:<66} {one:>8.1f}ms {all_:>8.1f}ms {ratio:>6.2f}  {winner}", flush=True)
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    verdict = "1" if str(many) not in best else ("-" if "1" in best else str(many))
    print(f"threads best={verdict} worst_ratio={worst:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
