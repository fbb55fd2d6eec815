"""The whole cross-mapping grid, run locally, with joblib processes, or on a Dask cluster.

Work is cut into chunks of template rows (:func:`hila_lang.evaluation.grid.evaluate_rows`);
every backend computes the same rows with the same deterministic code and the results are put
back by row index, so the numbers do not depend on the backend or the order chunks finish in.
A progress bar (rows done) goes to stderr.
"""

from __future__ import annotations

import socket
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import InputError
from .dataset import Trial, setups_of
from .grid import SEGMENTS, RowResult, evaluate_rows, metric_names

#: how long ``--dask`` waits for the scheduler before giving up
CONNECT_TIMEOUT = "10s"
#: how long :func:`check_scheduler` waits for a TCP connection to the scheduler, seconds
PROBE_TIMEOUT = 3.0


@dataclass
class GridResult:
    """Scores of the full grid.

    Attributes
    ----------
    labels : list of str
        ``setup/trial`` per trial, in dataset order (rows = templates/input, columns = tasks/output).
    trial_setup : ndarray of int, shape (J,)
        Set-up index of each trial.
    setups : list of str
        Set-up names.
    segments : tuple of int
        Segment counts N.
    methods : tuple of str
        Methods run (``osila`` first).
    protocol : str
        Constraint protocol (:mod:`.protocols`).
    metrics : tuple of str
        Score names (:func:`~hila_lang.evaluation.grid.metric_names`), the last axis of ``scores``.
    mask : ndarray of bool, shape (J, J)
        The pairs evaluated.
    scores : dict of str to ndarray, shape (S, J, J, M)
        Per method: ``[s, i, j, m]`` is metric m of template i mapped onto task j with
        ``segments[s]`` segments (NaN: not evaluated or failed).
    seconds : dict of str to ndarray, shape (S, J, J)
        Per method: generation time per path (s).
    failures : dict of str to list of str
        Failed pairs per method.
    wall_seconds : float
        Wall-clock time of the grid.
    backend : str
        ``local``, ``joblib(N)`` or ``dask(ADDRESS)``.
    stopped : KeyboardInterrupt or None
        What stopped the grid before every row was done (Ctrl-C, SIGTERM, SIGHUP), or None.
        A stopped grid keeps the rows done: ``mask`` is narrowed to them, so every table and
        test is over the pairs evaluated (issue 32).
    rows_done : int
        Template rows evaluated (all ``J`` unless stopped).
    """

    labels: list[str]
    trial_setup: np.ndarray
    setups: list[str]
    segments: tuple[int, ...]
    methods: tuple[str, ...]
    protocol: str
    metrics: tuple[str, ...]
    mask: np.ndarray
    scores: dict[str, np.ndarray] = field(default_factory=dict)
    seconds: dict[str, np.ndarray] = field(default_factory=dict)
    failures: dict[str, list[str]] = field(default_factory=dict)
    wall_seconds: float = 0.0
    backend: str = "local"
    stopped: KeyboardInterrupt | None = None
    rows_done: int = 0

    def metric(self, method: str, name: str) -> np.ndarray:
        """One metric of one method, shape (S, J, J)."""
        return self.scores[method][..., self.metrics.index(name)]

    @property
    def r(self) -> dict[str, np.ndarray]:
        """R per method, (S, J, J) (the paper's Tables I and II)."""
        return {m: self.metric(m, "r") for m in self.methods}

    @property
    def msd(self) -> dict[str, np.ndarray]:
        """MSD per method, (S, J, J) (the paper's Table III)."""
        return {m: self.metric(m, "msd") for m in self.methods}


class Progress:
    """A text progress bar on a stream: redrawn in place on a terminal, every 10 % otherwise."""

    def __init__(self, total: int, label: str = "eval", stream=None, enabled: bool = True) -> None:
        self.total, self.label, self.done = total, label, 0
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled and total > 0
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self._last_decile = -1

    def update(self, k: int = 1) -> None:
        """Advance by ``k`` units and redraw."""
        self.done += k
        if not self.enabled:
            return
        frac = self.done / self.total
        elapsed = time.perf_counter() - self.start
        eta = elapsed / frac * (1 - frac) if frac > 0 else 0.0
        bar = "#" * int(30 * frac) + "-" * (30 - int(30 * frac))
        text = f"{self.label} [{bar}] {self.done}/{self.total} rows  {elapsed:5.1f} s  eta {eta:5.1f} s"
        if self.tty:
            self.stream.write("\r" + text + ("\n" if self.done >= self.total else ""))
            self.stream.flush()
        elif int(frac * 10) > self._last_decile:
            self._last_decile = int(frac * 10)
            self.stream.write(text + "\n")
            self.stream.flush()


def _chunks(n_rows: int, n_chunks: int) -> list[list[int]]:
    n_chunks = max(1, min(n_rows, n_chunks))
    return [list(range(k, n_rows, n_chunks)) for k in range(n_chunks)]


def _run_local(trials, chunks, args):
    for rows in chunks:
        yield evaluate_rows(trials, rows, *args)


def _run_joblib(trials, chunks, args, jobs):
    # lazy: loads joblib, which importing this module does not
    from joblib import Parallel, delayed

    try:
        parallel = Parallel(n_jobs=jobs, return_as="generator_unordered")  # joblib >= 1.4
    except (TypeError, ValueError):  # older joblib: results in submission order
        parallel = Parallel(n_jobs=jobs)
    yield from parallel(delayed(evaluate_rows)(trials, rows, *args) for rows in chunks)


def _unreachable(address: str, reason: object) -> InputError:
    return InputError(f"cannot reach the Dask scheduler at {address!r}: {reason}",
                      hint="start one with 'dask scheduler' and 'dask worker ADDRESS', or omit --dask")


def check_scheduler(address: str) -> None:
    """Fail fast on a ``--dask`` address that cannot work: :class:`InputError` when ``distributed``
    is missing, the address does not parse, or nothing listens at it.

    Only a plain TCP connection is tried (within :data:`PROBE_TIMEOUT`); the Dask handshake is left
    to the client.  Without this, a malformed address makes ``distributed`` hang at exit and a
    closed port costs the whole :data:`CONNECT_TIMEOUT`.
    """
    try:
        # lazy: loads distributed, dask, yaml, which importing this module does not
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise InputError("--dask needs the optional package 'distributed', which is not installed",
                         hint="pip install 'hila-lang[dask]'") from None
    try:
        scheme, location = parse_address(address)
        if scheme == "inproc":
            raise ValueError("an in-process scheduler lives in another process's memory")
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise InputError(f"expected --dask ADDRESS as tcp://HOST:PORT, got {address!r} ({exc})") from None
    if scheme == "ucx":  # not a plain TCP socket: left to the client
        return
    try:
        socket.create_connection((host, port), timeout=PROBE_TIMEOUT).close()
    except OSError as exc:
        raise _unreachable(address, exc.strerror or exc) from None


def _connect(address: str):
    check_scheduler(address)
    # lazy: loads distributed, dask, yaml, which importing this module does not
    from distributed import Client

    try:
        return Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise _unreachable(address, exc) from None


def _run_dask(trials, chunks, args, address):
    # lazy: loads distributed, dask, yaml, which importing this module does not
    from distributed import as_completed

    client = _connect(address)
    try:
        [shared] = client.scatter([trials], broadcast=True)
        futures = [client.submit(evaluate_rows, shared, rows, *args, pure=False) for rows in chunks]
        for fut in as_completed(futures, loop=client.loop):
            yield fut.result()
    finally:
        client.close()


def run_grid(
    trials: list[Trial],
    *,
    segments: tuple[int, ...] = SEGMENTS,
    methods: tuple[str, ...] = ("osila",),
    options: dict[str, Any] | None = None,
    protocol: str = "paper",
    mask: np.ndarray | None = None,
    jobs: int = 1,
    dask: str | None = None,
    progress: bool = True,
    stream=None,
) -> GridResult:
    """Evaluate every template against its tasks (see :mod:`.grid`) and collect the scores.

    Parameters
    ----------
    trials : list of Trial
        The dataset, grouped by set-up.
    segments, methods, options, protocol
        As :func:`hila_lang.evaluation.grid.evaluate_row`.
    mask : ndarray of bool, shape (J, J), optional
        Pairs to evaluate (:func:`~hila_lang.evaluation.protocols.pair_mask`); default all.
    jobs : int
        Worker processes for joblib (1 = in this process; -1 = all cores).
    dask : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); overrides ``jobs``.
    progress : bool
        Draw a progress bar on ``stream`` (stderr by default).

    Returns
    -------
    GridResult
    """
    if any(m in methods for m in ("dmp", "dmp-aligned", "promp", "promp+retime")):
        # lazy: only this branch needs it
        from .controls import require_dmp

        require_dmp()
    n = len(trials)
    mask = np.ones((n, n), bool) if mask is None else np.asarray(mask, bool)
    setups = setups_of(trials)
    names = metric_names(trials[0].path.shape[1])
    result = GridResult(
        labels=[t.label for t in trials],
        trial_setup=np.array([setups.index(t.setup) for t in trials]),
        setups=setups,
        segments=tuple(segments),
        methods=tuple(methods),
        protocol=protocol,
        metrics=names,
        mask=mask,
    )
    for m in methods:
        result.scores[m] = np.full((len(segments), n, n, len(names)), np.nan)
        result.seconds[m] = np.full((len(segments), n, n), np.nan)
        result.failures[m] = []
    args = (tuple(segments), tuple(methods), dict(options or {}), protocol, mask)
    bar = Progress(n, stream=stream, enabled=progress)
    t0 = time.perf_counter()
    if dask:
        result.backend = f"dask({dask})"
        stream_of_results = _run_dask(trials, _chunks(n, 4 * n), args, dask)
    elif jobs != 1:
        result.backend = f"joblib({jobs})"
        stream_of_results = _run_joblib(trials, _chunks(n, 4 * max(jobs, 2)), args, jobs)
    else:
        stream_of_results = _run_local(trials, _chunks(n, n), args)
    rows: list[RowResult] = []
    try:
        for chunk in stream_of_results:
            rows.extend(chunk)
            bar.update(len(chunk))  # after the rows are kept: a stop after the bar moves keeps them
    except KeyboardInterrupt as stop:  # Ctrl-C, SIGTERM, SIGHUP: keep what was done
        stream_of_results.close()  # the workers stop now, not at exit
        if not rows:
            raise
        result.stopped = stop
        done = np.zeros(n, bool)
        done[[row.row for row in rows]] = True
        result.mask = mask & done[:, None]
    result.rows_done = len(rows)
    result.wall_seconds = time.perf_counter() - t0
    for row in sorted(rows, key=lambda r: r.row):
        for m in methods:
            result.scores[m][:, row.row] = row.scores[m]
            result.seconds[m][:, row.row] = row.seconds[m]
            result.failures[m].extend(row.failures[m])
    return result
