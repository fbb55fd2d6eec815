"""The studio's heavy work -- learning a template, processing a demonstration, OSILA for a scene --
in worker processes, so the server's event loop never computes: each call has a time budget
(:data:`BUDGET_S`) past which it is killed, a call cancelled by the server (its shutdown) kills
it too, and Ctrl-C (or SIGTERM) stops the studio within a second whatever a worker is doing
(:func:`stop` kills them).  A browser that goes away does not stop its request's work: the
budget does.

The workers are a :class:`concurrent.futures.ProcessPoolExecutor` of :data:`WORKERS` processes
started by a fork server (a fresh process with hila's OSILA modules imported once, not a fork
of the server with its threads).  A call past its budget, or cancelled, kills the pool; the next
call starts a new one.  The size budget is the door's (:mod:`.schema`: points, via points, ICPs).
"""

from __future__ import annotations

import asyncio
import multiprocessing
import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from ..core.errors import InputError

#: seconds one piece of heavy work may take.  The largest request the door lets in (a 10-minute
#: demonstration, 12 000 points, cut into 100 segments by change points) takes a few seconds on
#: one core (docs/limits.md); 60 s is that with the machine busy, and a person waits no longer.
BUDGET_S = 60.0
#: worker processes: two, so a long save does not hold up the Imitate page's redraws
WORKERS = 2
#: modules the fork server imports once, so a worker starts in milliseconds
PRELOAD = ["hila_lang.hierarchy.step", "hila_lang.hierarchy.explain", "hila_lang.hierarchy.learn",
           "hila_lang.osila.segmentation", "starlette.routing"]

_pool: ProcessPoolExecutor | None = None
_guard = threading.Lock()


def _executor() -> ProcessPoolExecutor:
    global _pool
    with _guard:
        if _pool is None:
            context = multiprocessing.get_context("forkserver")
            context.set_forkserver_preload(PRELOAD)
            _pool = ProcessPoolExecutor(WORKERS, mp_context=context)
        return _pool


def stop() -> None:
    """Kill the workers now (a call under way is lost: its request is answered or gone)."""
    global _pool
    with _guard:
        pool, _pool = _pool, None
    if pool is None:
        return
    for process in list(getattr(pool, "_processes", {}).values()):
        process.kill()
    pool.shutdown(wait=False, cancel_futures=True)


async def run(fn, *args, budget: float = BUDGET_S):
    """``fn(*args)`` in a worker process, awaited; past ``budget`` seconds the workers are
    killed and the request refused (an :class:`InputError` that says so)."""
    loop = asyncio.get_running_loop()
    future = loop.run_in_executor(_executor(), fn, *args)
    try:
        return await asyncio.wait_for(future, budget)
    except asyncio.TimeoutError:
        stop()
        raise InputError(f"refused: the work took longer than the studio's budget of {budget:g} s; "
                         "send less (fewer points or segments)") from None
    except asyncio.CancelledError:  # the request went away, or the studio is stopping
        stop()
        raise
    except BrokenProcessPool:
        stop()
        raise InputError("refused: the worker stopped (killed, or out of memory) before it finished") from None
