"""How many threads the numeric libraries may use: one by default, set once when hila is imported.

numpy and scipy each carry their own OpenBLAS, scikit-learn its OpenMP, OpenCV its own pool, and
each starts one thread per core.  hila's work is many small products (OSILA: K + D + 1 systems,
T x K evaluations, one row of an evaluation per worker process), where a threaded BLAS gains
nothing and, on a machine someone else also uses, threads spinning for each other cost a lot:
``python bench/threads.py`` measures every kind of work hila does with one thread and with every
core, in the same run (``docs/benchmarks.md``, "Threads", has the figures and the rule).

**The rule.**  Every library runs one thread, for small and large work alike (OSILA at K = 8 or
K = 1000, plan adjustment, the evaluation's worker processes, perception's OpenCV calls), because
that is what measured best here: more threads never gained more than they lost as soon as the
machine was shared.  A person with a quiet many-core machine and large systems can ask for more.

**The setting.**  The environment variable ``HILA_THREADS``: a whole number >= 1, or ``auto`` for
the libraries' own default (a thread per core).  Unset, hila uses 1 -- unless a library's own
variable (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ...) is already set, which then wins:
whoever set it chose.  A value that is neither is refused by the ``hila`` command with exit 2
(:func:`problem`); imported as a library, hila then uses the default.

**Where it is set.**  :func:`startup` runs once, from ``hila_lang/__init__.py``, before anything
heavy is imported: it writes the libraries' variables into ``os.environ``, which each library
reads when it loads -- free, and it holds for a library loaded later (scipy's OpenBLAS loads
only with ``scipy.linalg``) and for child processes (the evaluation's workers).  Libraries
already loaded (a script that imported numpy before hila) are limited through ``threadpoolctl``
(a scikit-learn dependency) at that moment; ``hila --help`` imports none of them.
"""

from __future__ import annotations

import os
import sys

#: the setting
ENV = "HILA_THREADS"
#: threads per library when ``HILA_THREADS`` is unset
DEFAULT = 1
#: what each library reads when it loads: OpenBLAS (numpy's and scipy's copies), OpenMP
#: (scikit-learn, libgomp), MKL, BLIS, Apple's Accelerate, numexpr, OpenCV's pthreads pool
LIBRARY_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                     "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS", "OPENCV_FOR_THREADS_NUM")
#: modules whose threads are already running when they are in ``sys.modules``
_LOADED = ("numpy", "scipy", "sklearn", "cv2")

_state: dict = {"threads": None, "problem": None, "source": None, "started": False}


def parse(value: str) -> int | None:
    """``HILA_THREADS``'s value as a thread count (None: ``auto``, the libraries' own default).

    Raises ``ValueError`` naming the variable, what came and what is expected.
    """
    text = value.strip().lower()
    if text in ("auto", "0"):
        return None
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 1:
        raise ValueError(f"{ENV}={value!r}: expected a whole number of threads >= 1, or 'auto' "
                         f"(the libraries' own default: a thread per core)")
    return n


def startup() -> None:
    """Apply the policy once per process (module docstring); later calls do nothing."""
    if _state["started"]:
        return
    _state["started"] = True
    given = os.environ.get(ENV)
    threads: int | None = DEFAULT
    if given is not None:
        try:
            threads = parse(given)
        except ValueError as exc:
            _state["problem"] = str(exc)  # the hila command refuses it (exit 2); a library keeps 1
    elif any(v in os.environ for v in LIBRARY_VARIABLES):
        _state["source"] = "library variables"
        return  # whoever set OPENBLAS_NUM_THREADS & co. chose; hila does not override them
    _state["source"] = ENV if given is not None and _state["problem"] is None else "default"
    _state["threads"] = threads
    if threads is None:
        return
    for var in LIBRARY_VARIABLES:
        os.environ[var] = str(threads)
    if any(m in sys.modules for m in _LOADED):
        limit(threads)


def limit(threads: int) -> None:
    """Limit the libraries loaded in this process to ``threads`` each, now (``threadpoolctl``,
    and OpenCV's own pool); a library loaded later reads the variables :func:`startup` set."""
    try:
        # lazy: loads threadpoolctl, which importing this module does not
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - a scikit-learn dependency
        pass
    else:
        threadpool_limits(threads)
    if "cv2" in sys.modules:
        sys.modules["cv2"].setNumThreads(threads)


def threads() -> int | None:
    """Threads per library set by :func:`startup` (None: left to the libraries or their variables)."""
    return _state["threads"]


def problem() -> str | None:
    """What was wrong with ``HILA_THREADS`` (the ``hila`` command reports it, exit 2), or None."""
    return _state["problem"]
