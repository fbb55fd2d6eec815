"""The thread policy (hila_lang.core.threads): one thread per numeric library unless HILA_THREADS
says otherwise, set when hila is imported -- before numpy loads, or on the loaded libraries when
a script imported numpy first -- and a library's own variable set by the person wins."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from hila_lang.core import threads

CORES = os.cpu_count() or 1

#: prints the threads of every BLAS / OpenMP copy loaded (numpy's and scipy's OpenBLAS, and with
#: "all" scikit-learn's libgomp and OpenCV's pool), after importing hila (numpy first if asked)
PROBE = """
import json, os, sys
order, which = sys.argv[1:]
if order == "numpy-first":
    import numpy, scipy.linalg, cv2
import hila_lang
import numpy, scipy.linalg
if which == "all":
    import sklearn.cluster, cv2
from threadpoolctl import threadpool_info
print(json.dumps({"libs": sorted({(i["internal_api"], i["num_threads"]) for i in threadpool_info()}),
                  "cv2": sys.modules["cv2"].getNumThreads() if "cv2" in sys.modules else None,
                  "env": os.environ.get("OPENBLAS_NUM_THREADS")}))
"""


def probe(order: str = "hila-first", which: str = "blas", **env: str) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in threads.LIBRARY_VARIABLES and k != threads.ENV}
    out = subprocess.run([sys.executable, "-c", PROBE, order, which], capture_output=True, text=True,
                         env={**clean, **env}, check=True)
    return json.loads(out.stdout)


@pytest.mark.parametrize("order", ["hila-first", "numpy-first"])
def test_every_library_runs_one_thread_by_default(order):
    got = probe(order, "all")
    assert {api for api, _ in got["libs"]} >= {"openblas", "openmp"}  # the probe saw them
    assert [n for _, n in got["libs"]] == [1] * len(got["libs"]), got
    assert got["cv2"] == 1


def test_the_libraries_would_start_a_thread_per_core_without_it():
    """The policy is what makes the difference (on a machine with more than one core)."""
    if CORES < 2:
        pytest.skip("one core: a library's default is one thread anyway")
    got = probe(HILA_THREADS="auto")
    assert got["env"] is None
    assert max(n for _, n in got["libs"]) == CORES


def test_hila_threads_sets_every_library():
    got = probe(HILA_THREADS="2")
    assert [n for _, n in got["libs"]] == [min(2, CORES)] * len(got["libs"])
    assert got["env"] == "2"


def test_a_library_variable_the_person_set_wins_over_the_default():
    got = probe(OPENBLAS_NUM_THREADS=str(min(2, CORES)))
    assert {n for api, n in got["libs"] if api == "openblas"} == {min(2, CORES)}


def test_child_processes_inherit_the_policy():
    code = "import hila_lang, os, subprocess, sys; print(subprocess.run([sys.executable, '-c', " \
           "'import os; print(os.environ.get(\"OMP_NUM_THREADS\"))'], capture_output=True, text=True).stdout)"
    clean = {k: v for k, v in os.environ.items() if k not in threads.LIBRARY_VARIABLES and k != threads.ENV}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=clean, check=True)
    assert out.stdout.strip() == "1"


@pytest.mark.parametrize("value, expected", [("1", 1), ("4", 4), (" 2 ", 2), ("auto", None), ("AUTO", None),
                                             ("0", None)])
def test_parse(value, expected):
    assert threads.parse(value) == expected


@pytest.mark.parametrize("value", ["x", "-1", "1.5", ""])
def test_parse_refuses_with_the_variable_named(value):
    with pytest.raises(ValueError, match=r"HILA_THREADS=.*expected a whole number of threads >= 1, or 'auto'"):
        threads.parse(value)


def test_a_bad_setting_is_bad_input_for_the_command(tmp_path):
    env = {**os.environ, "HILA_THREADS": "many"}
    out = subprocess.run([sys.executable, "-m", "hila_lang", "check", "nothing.hila"], capture_output=True,
                         text=True, env=env, cwd=tmp_path)
    assert out.returncode == 2
    assert "HILA_THREADS='many'" in out.stderr and "Traceback" not in out.stderr
