"""Optional compilation of a few hot loops with numba, never required for a run.

Three loops cannot be vectorised with numpy because every step depends on the previous one: the
minimum-energy route (a Viterbi pass over time stamps, :mod:`hila_lang.osila.route`) and the
dynamic programmes of the discrete Fréchet distance and DTW (:mod:`hila_lang.metrics`).  Each has
a numpy version; :func:`compiled` returns a numba-compiled twin when it can, or ``None``, and the
caller then uses the numpy version.  The results are the same (tests compare both with a slow,
obvious reference).

What can go wrong, and what happens:

- numba is not installed, or ``HILA_JIT=0`` is set: ``None`` (numpy).
- The on-disk cache cannot be used (read-only install, no writable cache folder, a stale or broken
  cache file): numba is asked to compile without a cache; if compiling fails as well, ``None``.
- Compilation happens once per process (about a second); with a usable cache (numba's own: the
  package's ``__pycache__`` or ``NUMBA_CACHE_DIR``) a later process loads it in milliseconds.

Every kernel is compiled and run once on a tiny example (``warm``) before it is handed out, so a
failure shows up here, not in the middle of a run.

Starting numba costs about 0.7 s and 100 MB in a fresh process here (importing it and loading
the first kernel from the cache).  The OSILA kernels are therefore used only for paths of at
least :data:`MIN_STAMPS` stamps: the numpy route takes about 4.6 µs per stamp (2-D, 17
candidates), so a 200-stamp path costs about 1 ms in numpy and 0.05 ms compiled, while a program
of a few short sub-templates (``hila exec``: tens of stamps each) never pays the start-up.  Which
implementation runs is a function of the input alone, so a run is deterministic.  Batch work that maps thousands of paths (``hila eval``)
runs inside :func:`batch`, where every path uses the kernels.

**First use** (issue 38).  Compiling every kernel takes 25-40 s on this machine (the TPS choice
kernel most of it); numba caches the result beside the sources, so only the first run after an
install pays -- a first ``hila eval`` took 169 s against 11.5 s for the second (load 22).  So the
first run of a ``hila`` command that may use them (:func:`warm_in_background`, called by the
command line) starts one detached process at the lowest priority that compiles them all into
numba's cache and leaves a stamp; the run itself goes on as before (the same kernels at the same
places, so the same results).  A later run finds the cache warm.  A run that needs a kernel while
that process still compiles compiles it itself, as before.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import time
import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator

from .interrupts import guarded

_DONE: dict[Callable, Callable | None] = {}
#: shortest path (stamps) for which OSILA uses its compiled kernels (module docstring)
MIN_STAMPS = 200
_min_stamps = [MIN_STAMPS]


def min_stamps() -> int:
    """The current shortest path for the OSILA kernels: :data:`MIN_STAMPS`, or 0 inside :func:`batch`."""
    return _min_stamps[0]


@contextmanager
def batch() -> Iterator[None]:
    """Within the block every OSILA path, however short, uses the compiled kernels (when available)."""
    old = _min_stamps[0]
    _min_stamps[0] = 0
    try:
        yield
    finally:
        _min_stamps[0] = old


def enabled() -> bool:
    """False when the environment variable ``HILA_JIT`` is ``0`` (or ``false``/``no``/``off``)."""
    return os.environ.get("HILA_JIT", "1").strip().lower() not in ("0", "false", "no", "off")


def _compile(func: Callable, warm: tuple[Any, ...], cache: bool) -> Callable:
    # lazy: loads numba, scipy, numpy, which importing this module does not
    import numba

    kernel = numba.njit(cache=cache, nogil=True)(func)
    kernel(*warm)  # compiles (or loads the cache) for the argument types used at run time
    return kernel


def compiled(func: Callable, *warm: Any) -> Callable | None:
    """``func`` compiled by numba (cached on disk when possible), or ``None`` if that cannot be done.

    Parameters
    ----------
    func : callable
        A function in numba's nopython subset.
    *warm
        Example arguments with the types of the real calls; the kernel is run on them once.

    Returns
    -------
    callable or None
        Memoised per ``func`` for the life of the process.
    """
    if func in _DONE:
        return _DONE[func]
    # A Ctrl-C or SIGTERM while numba compiles waits until it is done (a second or two): numba
    # stopped half-way fails on the next call ("no compiled object yet"), which would turn a
    # stopped run into an internal error instead of one that saves what it did (issue 32).
    with guarded() as guard:
        guard.hold()
        _DONE[func] = _build(func, warm)
    return _DONE[func]


def _build(func: Callable, warm: tuple[Any, ...]) -> Callable | None:
    if not enabled():
        return None
    try:
        # lazy: loads numba, scipy, numpy, which importing this module does not
        import numba  # noqa: F401
    except ImportError:
        return None
    for cache in (True, False):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # e.g. NumbaWarning: cannot cache
                return _compile(func, warm, cache)
        except Exception:  # noqa: BLE001 -- any numba failure means: use numpy
            pass
    return None


#: the modules holding kernels, under ``hila_lang/``: the warm stamp hashes their sources' times
#: and sizes (a new install or an edit writes them anew, and numba's cache is then stale too)
KERNEL_SOURCES = ("osila/route.py", "osila/tps.py", "osila/tps_loops.py", "osila/robust.py", "metrics.py")
#: a background compile older than this is taken for dead and may be started again, seconds
STALE_LOCK_S = 1800.0


def warm_stamp() -> Path | None:
    """Where the stamp of a warm kernel cache for these sources lives (beside numba's own cache:
    ``hila_lang/osila/__pycache__``, or ``NUMBA_CACHE_DIR``), or None if that cannot be said."""
    root = Path(__file__).resolve().parent.parent
    try:
        stats = [(root / name).stat() for name in KERNEL_SOURCES]
    except OSError:
        return None
    key = hashlib.sha256(repr(([(s.st_mtime_ns, s.st_size) for s in stats], sys.version,
                               sys.executable)).encode()).hexdigest()[:12]
    folder = Path(os.environ["NUMBA_CACHE_DIR"]) if os.environ.get("NUMBA_CACHE_DIR") else root / "osila" / "__pycache__"
    return folder / f"hila-kernels-{key}.warm"


def warm_in_background(module: str) -> bool:
    """Start ``python -m module STAMP`` detached at the lowest priority, once, when the kernels'
    cache is not known to be warm (module docstring); True if it was started.

    ``module`` compiles every kernel and writes ``STAMP``; a lock file beside the stamp keeps a
    second run from starting another one meanwhile.  Nothing is started when numba is disabled
    (``HILA_JIT=0``) or the cache's folder is not writable.
    """
    if not enabled():
        return False
    stamp = warm_stamp()
    if stamp is None or stamp.exists():
        return False
    lock = stamp.with_suffix(".running")
    try:
        stamp.parent.mkdir(parents=True, exist_ok=True)
        if lock.exists() and time.time() - lock.stat().st_mtime > STALE_LOCK_S:
            lock.unlink()
        os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644))
    except OSError:  # another run is warming it, or the folder is not writable
        return False
    try:
        subprocess.Popen([sys.executable, "-m", module, str(stamp)], stdin=subprocess.DEVNULL,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
                         close_fds=True)
    except OSError:
        lock.unlink(missing_ok=True)
        return False
    return True


def warmed(stamp: Path, compile_all: Callable[[], None]) -> None:
    """The background process's work: lowest priority, ``compile_all()``, then ``stamp`` written
    (only if every kernel compiled) and the lock removed."""
    lock = stamp.with_suffix(".running")
    try:
        try:
            os.nice(19)
        except OSError:
            pass
        compile_all()
        if all(kernel is not None for kernel in _DONE.values()):
            stamp.write_text("numba's cache holds hila's kernels for these sources (hila_lang.core.jit)\n")
    finally:
        lock.unlink(missing_ok=True)


def reset() -> None:
    """Forget compiled kernels (tests use it with ``HILA_JIT`` to exercise both paths)."""
    _DONE.clear()
