"""First use (issue 38): the first run after an install compiles the kernels into numba's cache
in a detached background process, once; later runs find the cache warm."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hila_lang import cli
from hila_lang.core import jit


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("HILA_JIT", "1")
    return tmp_path


def test_the_stamp_lives_beside_numbas_cache_and_names_these_sources(cache):
    stamp = jit.warm_stamp()
    assert stamp.parent == cache and stamp.name.startswith("hila-kernels-") and stamp.suffix == ".warm"
    assert jit.warm_stamp() == stamp  # the same sources: the same stamp


def test_a_cold_cache_starts_one_detached_process_and_a_second_run_does_not(cache, monkeypatch):
    started = []

    class Popen:
        def __init__(self, argv, **kwargs):
            started.append((argv, kwargs))

    monkeypatch.setattr(subprocess, "Popen", Popen)
    assert jit.warm_in_background("hila_lang.osila.warm") is True
    argv, kwargs = started[0]
    stamp = jit.warm_stamp()
    assert argv == [sys.executable, "-m", "hila_lang.osila.warm", str(stamp)]
    assert kwargs["start_new_session"] and kwargs["stdin"] is subprocess.DEVNULL
    assert stamp.with_suffix(".running").exists()  # the lock: a second run leaves it to the first
    assert jit.warm_in_background("hila_lang.osila.warm") is False and len(started) == 1
    old = time.time() - jit.STALE_LOCK_S - 60  # a compile that died long ago is started again
    os.utime(stamp.with_suffix(".running"), (old, old))
    assert jit.warm_in_background("hila_lang.osila.warm") is True and len(started) == 2
    stamp.write_text("warm\n")
    stamp.with_suffix(".running").unlink()
    assert jit.warm_in_background("hila_lang.osila.warm") is False and len(started) == 2


def test_nothing_starts_with_numba_disabled(cache, monkeypatch):
    monkeypatch.setenv("HILA_JIT", "0")
    monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: pytest.fail("started"))
    assert jit.warm_in_background("hila_lang.osila.warm") is False


def test_the_command_line_warms_for_the_commands_that_run_osila_only(monkeypatch, tmp_path):
    asked = []
    monkeypatch.setattr(jit, "warm_in_background", lambda module: asked.append(module))
    program = tmp_path / "p.hila"
    program.write_text("world scripted\n")
    cli.main(["check", str(program)])
    assert asked == []
    assert cli.main(["explain", str(tmp_path / "missing.hila")]) == 2  # bad input, after the warm-up started
    assert asked == ["hila_lang.osila.warm"]


@pytest.mark.slow
def test_the_background_process_fills_the_cache_a_later_run_loads(cache):
    """The real thing: the process compiles every kernel into a fresh NUMBA_CACHE_DIR and writes
    the stamp; a new process then gets every kernel from the cache (numba's own hit counts)."""
    assert jit.warm_in_background("hila_lang.osila.warm") is True
    stamp = jit.warm_stamp()
    deadline = time.time() + 900
    while not stamp.exists() and time.time() < deadline:
        time.sleep(1)
    assert stamp.exists() and not stamp.with_suffix(".running").exists()
    code = ("from hila_lang.core import jit\nfrom hila_lang.osila import warm\nwarm.compile_all()\n"
            "print(sorted(sum(k.stats.cache_misses.values()) for k in jit._DONE.values()))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
    misses = eval(out.stdout)
    assert misses and set(misses) == {0}  # nothing compiled: everything loaded from the cache


def test_the_warm_stamp_follows_every_module_that_holds_a_kernel():
    """A module with a numba kernel missing from KERNEL_SOURCES would leave the stamp 'warm' after
    its kernels changed (tps.py's loops moved to tps_loops.py: it was missing)."""
    from hila_lang.core import jit as jit_module

    package = Path(jit_module.__file__).resolve().parent.parent
    holders = {p.relative_to(package).as_posix() for p in package.rglob("*.py")
               if "# pragma: no cover - compiled by numba" in p.read_text(encoding="utf-8")}
    assert holders and holders <= set(jit_module.KERNEL_SOURCES), sorted(holders - set(jit_module.KERNEL_SOURCES))
