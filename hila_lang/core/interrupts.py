"""Ctrl-C (SIGINT) where it can be acted on cleanly.

- :func:`guarded`: around one step of the engine.  Ctrl-C stops the step at once while it
  computes or moves (``KeyboardInterrupt``), but once the step has started changing the world
  (told it what the robot did, taken an opponent's move) it is held until the step is recorded,
  then raised: a step is never half-recorded, so the session can go on.  Around saving a run's
  outputs too, so a Ctrl-C at the end of a game does not lose the game.  A second Ctrl-C is
  never held.
- :func:`start_ignoring_sigint`: worker processes that ignore Ctrl-C, so only the parent reacts
  (``hila eval --jobs N``): no traceback from every worker, and no pool left half-started.
- :func:`handle_termination`: SIGTERM (what ``timeout``, systemd, Docker and CI runners send)
  and SIGHUP (the terminal closed) are handled like Ctrl-C (issue 20): they raise
  :class:`Terminated`, a ``KeyboardInterrupt``, so a run stops the same way -- the step
  finishes being recorded, the world saves what was done, ``--trace`` and ``--record`` are
  written, temporary files removed, worker pools stopped -- and the process exits with
  128 + the signal's number (143, 129), as a shell reports a process the signal ended.

Only the main thread handles signals, and only when Python's own handler is installed (an
ignored SIGINT, or an embedding application's handler, is left alone).
"""

from __future__ import annotations

import os
import signal
import threading
from multiprocessing import resource_tracker

try:  # the C functions: the engine installs its handler twice per step, and the wrappers in
    # ``signal`` (enum conversions) cost more than a ``let`` step itself
    from _signal import getsignal as _getsignal, signal as _setsignal
except ImportError:  # pragma: no cover - not CPython
    _getsignal, _setsignal = signal.getsignal, signal.signal


#: the signals handled like Ctrl-C (:func:`handle_termination`)
TERMINATING = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class Terminated(KeyboardInterrupt):
    """A stop asked by a signal other than SIGINT (SIGTERM, SIGHUP): handled as Ctrl-C is."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _stop(signum: int) -> KeyboardInterrupt:
    return KeyboardInterrupt() if signum == signal.SIGINT else Terminated(signum)


def cause(stop: BaseException) -> str:
    """What stopped a run, as a message says it: ``"Ctrl-C"``, ``"SIGTERM"``, ``"SIGHUP"``."""
    if isinstance(stop, Terminated):
        return signal.Signals(stop.signum).name
    return "Ctrl-C"


def exit_code(stop: BaseException) -> int:
    """The exit status of a run ``stop`` ended: 130 for Ctrl-C, 128 + N for signal N."""
    return 128 + (stop.signum if isinstance(stop, Terminated) else int(signal.SIGINT))


#: the guards entered and not yet left, innermost last (a terminating signal consults it)
_active: list = []


class Guard:
    """What :func:`guarded` yields: :meth:`hold` marks the start of the part that must finish."""

    __slots__ = ("holding", "pending", "_previous")

    def __init__(self) -> None:
        self.holding = False
        self.pending = 0  # the signal held, 0 for none
        self._previous = None

    def hold(self) -> None:
        """From now on, a Ctrl-C (or SIGTERM, SIGHUP) waits until the guarded block ends (a
        second one does not)."""
        self.holding = True

    def _handler(self, signum, frame) -> None:
        if self.holding and not self.pending:  # the first Ctrl-C waits; a second one does not
            self.pending = signum
        else:
            raise _stop(signum)

    def __enter__(self) -> "Guard":
        if _ours():
            self._previous = _setsignal(signal.SIGINT, self._handler)
        _active.append(self)
        return self

    def __exit__(self, kind, exc, tb) -> bool:
        if _active and _active[-1] is self:
            _active.pop()
        if self._previous is not None:
            _setsignal(signal.SIGINT, self._previous)
            self._previous = None
        if self.pending and exc is None:
            raise _stop(self.pending)
        return False


def _terminate(signum, frame) -> None:
    """The handler of SIGTERM and SIGHUP: held by the innermost guard that holds, else raised."""
    if _active:
        _active[-1]._handler(signum, frame)
    else:
        raise Terminated(signum)


def handle_termination() -> None:
    """Handle SIGTERM and SIGHUP like Ctrl-C from now on (see the module docstring).  A signal
    that is ignored (``nohup``) or handled by an embedding application stays as it is; only the
    main thread can install handlers."""
    if threading.current_thread() is not threading.main_thread():
        return
    for signum in TERMINATING:
        if signal.getsignal(signum) is signal.SIG_DFL:
            signal.signal(signum, _terminate)


def _ours() -> bool:
    return (threading.current_thread() is threading.main_thread()
            and _getsignal(signal.SIGINT) is signal.default_int_handler)


def guarded() -> Guard:
    """A context manager yielding a :class:`Guard`; a Ctrl-C held by ``guard.hold()`` is raised
    as ``KeyboardInterrupt`` when the block ends (unless the block raised)."""
    return Guard()


def start_ignoring_sigint(start_workers):
    """Call ``start_workers()`` so that the processes it starts ignore SIGINT (an ignored signal
    stays ignored across ``exec``), then give Ctrl-C back to this process; returns what
    ``start_workers`` returns.  A Ctrl-C pressed meanwhile is kept pending (blocked, not ignored)
    and raised as soon as the workers are up.
    """
    if not _ours() or not hasattr(signal, "pthread_sigmask"):
        return start_workers()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        return start_workers()
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a pending Ctrl-C is delivered here


def joblib_workers_ignoring_sigint(jobs: int) -> None:
    """Start joblib's worker processes now, ignoring SIGINT (:func:`start_ignoring_sigint`);
    the next ``joblib.Parallel(n_jobs=jobs)`` reuses them (loky keeps one pool).  Then Ctrl-C
    reaches this process only: it stops the work and the pool, with no traceback from the
    workers, and never while the pool is half-started (loky then hung).

    Call it before numpy is imported: threads started before (numpy's BLAS pool) would take a
    Ctrl-C pressed meanwhile and drop it; threads started inside inherit the block and leave it
    pending for this one.
    """

    def start() -> None:
        # lazy: loads numpy, joblib, which importing this module does not
        from joblib import Parallel, delayed

        Parallel(n_jobs=jobs)(delayed(os.getpid)() for _ in range(max(jobs, 2)))

    # started first: starting it unblocks SIGINT (bpo-33613's SIG_UNBLOCK), which would drop a
    # Ctrl-C pressed meanwhile instead of keeping it pending
    resource_tracker.ensure_running()
    start_ignoring_sigint(start)
