"""The studio's heavy work -- learning a template, processing a demonstration, OSILA for a scene --
in worker processes, so the server's event loop never computes: each call has a time budget
(:data:`BUDGET_S`) past which it is killed; a call whose page went away (the request's
connection closed, the websocket closed: ``gone``) is killed too; and Ctrl-C (or SIGTERM) stops
the studio within a second whatever a worker is doing (:func:`stop` kills them).

The workers are a :class:`concurrent.futures.ProcessPoolExecutor` of :data:`WORKERS` processes
started by a fork server (a fresh process with hila's OSILA modules imported once, not a fork
of the server with its threads).  A pool runs its calls to the end or dies whole, so one call is
given up (:func:`give_up`) by killing the pool: the other calls under way in it are handed to a
new pool and computed again (they are deterministic: the same answer, later), not lost.  The
size budget is the door's (:mod:`.schema`: points, via points, ICPs).
"""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import signal
import threading
from concurrent.futures import Future, InvalidStateError, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import forkserver

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
        if _pool is None or getattr(_pool, "_broken", False):  # none yet, or a worker died (out of memory)
            context = multiprocessing.get_context("forkserver")
            context.set_forkserver_preload(PRELOAD)
            _pool = ProcessPoolExecutor(WORKERS, mp_context=context)
        return _pool


def _kill(pool: ProcessPoolExecutor) -> None:
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.kill()


def stop(final: bool = False) -> None:
    """Kill the workers now, every call under way answered at once with
    :class:`BrokenProcessPool` (its request is answered or gone); ``final`` (the studio stops):
    no new pool is started after, and a worker a hand-over was still starting is killed as it
    appears."""
    global _closed
    with _guard:
        _closed = _closed or final
    if final:  # first: a hand-over waiting for the fork server to start a worker fails now
        _kill_fork_server()
    for future in list(_waiting):  # every call waiting is answered now, not when its worker dies
        _fail(future, BrokenProcessPool("the studio is stopping" if final else "the workers were killed"))
    _kill_pool()


def give_up(call: Future) -> None:
    """Stop the one call ``call`` (:func:`run`'s, past its budget or its page gone): its pool is
    killed, and every other call under way there is handed over again to a new pool."""
    call.cancel()  # its awaiting request is told by whoever gave it up
    for other in list(_waiting):
        if other is not call:
            other.again = True  # type: ignore[attr-defined] - read by _submit's copy
    _kill_pool()


def _kill_pool() -> None:
    global _pool
    with _guard:
        pool, _pool = _pool, None
    if pool is not None:
        _kill(pool)
        # in a thread: shutdown takes the pool's lock, which a hand-over holds while the fork server
        # starts a worker (0.65-0.78 s measured at load 13 when Ctrl-C came 0.2 s after the start)
        threading.Thread(target=pool.shutdown, kwargs=dict(wait=False, cancel_futures=True), daemon=True).start()


def _kill_fork_server() -> None:
    """Kill the fork server (the studio is stopping): one that is still importing :data:`PRELOAD`
    (the first second after start) would otherwise take a core from the exit, and a hand-over
    waiting for it fails now instead of starting a worker after the stop."""
    pid = getattr(getattr(forkserver, "_forkserver", None), "_forkserver_pid", None)
    if pid:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass  # gone already


def _submit(fn, *args) -> Future:
    """``fn(*args)`` handed to the pool from a daemon thread: the first hand-over waits for the
    fork server to start (seconds on a busy machine), which must hold up neither the event loop
    nor the process's exit.  A call whose pool was killed for another call (:func:`give_up`) is
    handed over again, once per kill."""
    outer: Future = Future()
    outer.again = False  # type: ignore[attr-defined]
    _waiting.add(outer)
    outer.add_done_callback(_waiting.discard)

    def copy(inner: Future) -> None:
        if outer.done():
            return  # given up, or the studio stopping
        if inner.cancelled() or isinstance(inner.exception(), BrokenProcessPool):
            if outer.again and not _closed:  # killed for another call: computed again
                outer.again = False
                threading.Thread(target=hand_over, name="hila-studio-submit", daemon=True).start()
            elif inner.cancelled():
                outer.cancel()
            else:
                _fail(outer, inner.exception())
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
            if outer.again and not _closed:
                outer.again = False
                hand_over()
            else:
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


class Gone(InputError):
    """The page that asked for the work went away before it was done (answered to nobody)."""


async def run(fn, *args, budget: float = BUDGET_S, gone=None):
    """``fn(*args)`` in a worker process, awaited.  Past ``budget`` seconds it is killed and the
    request refused (an :class:`InputError` that says so); when the awaitable ``gone`` finishes
    first (the page went away: :func:`.page.gone`) it is killed and :class:`Gone` raised; a
    cancelled await (the websocket closed, the studio stopping) kills it too."""
    call = _submit(fn, *args)
    future = asyncio.wrap_future(call)
    watch = asyncio.ensure_future(gone) if gone is not None else None
    try:
        done, _ = await asyncio.wait([f for f in (future, watch) if f is not None], timeout=budget,
                                     return_when=asyncio.FIRST_COMPLETED)
    except asyncio.CancelledError:  # the websocket went away, or the studio is stopping
        future.cancel()
        give_up(call)
        raise
    finally:
        if watch is not None:
            watch.cancel()
    if future in done:
        try:
            return future.result()
        except (BrokenProcessPool, asyncio.CancelledError):  # killed meanwhile, or shut down (Ctrl-C) before it began
            raise InputError("refused: the worker stopped (killed, or out of memory) before it finished") from None
    future.cancel()
    give_up(call)
    if watch in done:
        raise Gone("the page went away: its work was stopped")
    raise InputError(f"refused: the work took longer than the studio's budget of {budget:g} s; "
                     "send less (fewer points or segments)")

