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
from concurrent.futures import Future, InvalidStateError, ProcessPoolExecutor
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
_closed = False  # the studio is stopping: no new pool
_waiting: set[Future] = set()  # calls handed over and not answered yet


def _fail(future: Future, exc: BaseException) -> None:
    try:
        future.set_exception(exc)
    except InvalidStateError:
        pass  # answered meanwhile


def _executor() -> ProcessPoolExecutor:
    global _pool
    with _guard:
        if _closed:
            raise BrokenProcessPool("the studio is stopping")
        if _pool is None:
            context = multiprocessing.get_context("forkserver")
            context.set_forkserver_preload(PRELOAD)
            _pool = ProcessPoolExecutor(WORKERS, mp_context=context)
        return _pool


def _kill(pool: ProcessPoolExecutor) -> None:
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.kill()


def stop(final: bool = False) -> None:
    """Kill the workers now (a call under way is lost: its request is answered or gone);
    ``final`` (the studio stops): no new pool is started after, and a worker a hand-over was
    still starting is killed as it appears."""
    global _pool, _closed
    with _guard:
        pool, _pool = _pool, None
        _closed = _closed or final
    for future in list(_waiting):  # every call waiting is answered now, not when its worker dies
        _fail(future, BrokenProcessPool("the studio is stopping" if final else "the workers were killed"))
    if pool is None:
        return
    _kill(pool)
    pool.shutdown(wait=False, cancel_futures=True)


def _submit(fn, *args) -> Future:
    """``fn(*args)`` handed to the pool from a daemon thread: the first hand-over waits for the
    fork server to start (seconds on a busy machine), which must hold up neither the event loop
    nor the process's exit."""
    outer: Future = Future()
    _waiting.add(outer)
    outer.add_done_callback(_waiting.discard)

    def copy(inner: Future) -> None:
        if inner.cancelled():
            outer.cancel()
        elif inner.exception() is not None:
            _fail(outer, inner.exception())
        else:
            try:
                outer.set_result(inner.result())
            except InvalidStateError:
                pass  # given up meanwhile (its request cancelled, or the studio stopping)

    def hand_over() -> None:
        try:
            pool = _executor()
            pool.submit(fn, *args).add_done_callback(copy)
            if _closed:  # stopped while this hand-over waited for the fork server
                _kill(pool)
        except RuntimeError as exc:  # the pool was shut down meanwhile (Ctrl-C, or a kill)
            _fail(outer, BrokenProcessPool(str(exc)))
        except BaseException as exc:  # noqa: BLE001 - said by the awaiting call
            _fail(outer, exc)

    threading.Thread(target=hand_over, name="hila-studio-submit", daemon=True).start()
    return outer


def warm() -> None:
    """Start the fork server and the workers now, in the background (``hila studio`` calls it as
    it starts), so the first heavy request does not wait for them."""
    for _ in range(WORKERS):
        _submit(abs, 0)


async def run(fn, *args, budget: float = BUDGET_S):
    """``fn(*args)`` in a worker process, awaited; past ``budget`` seconds the workers are
    killed and the request refused (an :class:`InputError` that says so)."""
    future = asyncio.wrap_future(_submit(fn, *args))
    try:
        return await asyncio.wait_for(future, budget)
    except asyncio.TimeoutError:
        stop()
        raise InputError(f"refused: the work took longer than the studio's budget of {budget:g} s; "
                         "send less (fewer points or segments)") from None
    except asyncio.CancelledError:  # the request went away, or the studio is stopping
        stop()
        raise
    except BrokenProcessPool:  # killed meanwhile, or shut down (Ctrl-C) before it began
        stop()
        raise InputError("refused: the worker stopped (killed, or out of memory) before it finished") from None
