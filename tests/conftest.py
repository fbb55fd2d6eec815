"""The suite's budget: slow tests are marked, a plain ``pytest`` leaves them out, and a test that
grew slow without a mark is named at the end of the run.

- ``@pytest.mark.slow`` (or ``pytestmark = pytest.mark.slow`` for a whole file) marks a test that
  costs more than :data:`SLOW_CPU_S` seconds of CPU, its own and its child processes' (a whole
  game in PyBullet, a browser, a compile, an evaluation).  A plain ``pytest`` (or ``pytest
  tests/``: folders only) leaves them out and says how many; ``pytest -m slow`` runs only them
  (``-n 2``: on two processes, pytest-xdist), ``pytest -m "slow or not slow"`` everything, and
  naming a file or a test (``pytest tests/test_robot_backend.py``) runs what it names, slow or
  not.  ``.ci/run`` runs both parts.
- CPU time, not wall time, decides: it does not grow when the machine is shared.  After a run,
  every unmarked test over the budget is listed with its CPU seconds ("mark it slow"), so the
  default run stays inside its time as tests are added (README: how long each part takes).
"""

from __future__ import annotations

import os
import resource
import time

import pytest

#: CPU seconds (this process and its children) above which a test belongs in the slow part
SLOW_CPU_S = 3.0

_OVER: list[tuple[float, str]] = []


def _cpu() -> float:
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _names_files(config) -> bool:
    """True when the command line names a file or a test (not only folders)."""
    for arg in config.args:
        path = arg.split("::")[0]
        if "::" in arg or os.path.isfile(path):
            return True
    return False


def pytest_collection_modifyitems(config, items):
    if config.option.markexpr or _names_files(config):
        return  # -m decides, or the person named what to run
    slow = [item for item in items if item.get_closest_marker("slow") is not None]
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = [item for item in items if item.get_closest_marker("slow") is None]


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    start = _cpu()
    yield
    spent = _cpu() - start
    if spent > SLOW_CPU_S and item.get_closest_marker("slow") is None:
        _OVER.append((spent, item.nodeid))


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if not _OVER or os.environ.get("PYTEST_XDIST_WORKER"):
        return
    terminalreporter.section("tests over the budget of the default run")
    terminalreporter.write_line(f"{len(_OVER)} unmarked test(s) took more than {SLOW_CPU_S:g} s of CPU "
                                "(their own and their child processes'): mark them @pytest.mark.slow "
                                "(tests/conftest.py, docs/benchmarks.md)")
    for spent, nodeid in sorted(_OVER, reverse=True):
        terminalreporter.write_line(f"  {spent:6.1f} s  {nodeid}")
