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
from . import robust, route, tps


def compile_all() -> None:
    """Ask for every kernel (compiled, or loaded from numba's cache)."""
    tps._dist_compiled()
    tps._rank_compiled()
    tps._kernel()
    route._compiled_route()
    robust._trials_compiled()
    path = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.5]])
    metrics.frechet(path, path)
    metrics.dtw(path, path)


if __name__ == "__main__":
    jit.warmed(Path(sys.argv[1]), compile_all)
