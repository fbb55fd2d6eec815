"""Every compiled kernel of OSILA and the metrics, compiled into numba's cache in one go.

``python -m hila_lang.osila.warm STAMP`` is the process :func:`hila_lang.core.jit.warm_in_background`
starts at the first run after an install: it asks for each kernel the way a run does (so numba
caches the same signatures) and writes ``STAMP`` when all compiled.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from .. import metrics
from ..core import jit
from . import imitate, robust, route, tps


def compile_all() -> None:
    """Ask for every kernel (compiled, or loaded from numba's cache), then run small ``imitate``
    calls in 2-D and 3-D, few and many pairs, inside :func:`~hila_lang.core.jit.batch`: a real
    call hands some kernels arrays a kernel's own example does not (the route's candidate
    offsets are read-only, a signature of their own), and numba caches per signature."""
    tps._dist_compiled()
    tps._rank_compiled()
    tps._kernel()
    route._compiled_route()
    robust._trials_compiled()
    path = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.5]])
    metrics.frechet(path, path)
    metrics.dtw(path, path)
    rng = np.random.default_rng(0)
    with jit.batch():
        for dim in (2, 3):
            t = np.linspace(0.0, 1.0, 60)
            demo = np.column_stack([t, np.sin(3 * t), 0.5 * t * t][:dim])
            for k in (4, 12):  # the warp's choice alone; with the outlier screen (10 pairs or more)
                src = demo[:: 60 // k][:k] + rng.normal(0.0, 0.05, (k, dim))
                dst = 1.1 * src + 0.2 + rng.normal(0.0, 0.01, (k, dim))
                imitate(demo, src, dst)
                imitate(demo, src, dst, obstacles=np.append(1.1 * demo[30] + 0.2, 0.05)[None, :])


if __name__ == "__main__":
    jit.warmed(Path(sys.argv[1]), compile_all)
