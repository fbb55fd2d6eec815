"""``hila eval --jobs 2`` stopped by Ctrl-C ends promptly with exit status 130: no hang, no
traceback from the workers, whenever the signal comes -- while the workers start (loky used to
hang there: 'Popen' object has no attribute 'kill') or while they work (issue 13)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest


@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.3, 1.0, 2.0, 3.5])
def test_sigint_ends_eval_with_130_and_no_traceback(tmp_path, delay):
    # the paper protocol's whole grid (tens of seconds): still working when the signal comes
    argv = [sys.executable, "-m", "hila_lang", "eval", "--jobs", "2", "--protocol", "paper",
            "--out", str(tmp_path / "ev"), "--no-progress"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: the parent and its workers
    sent = time.monotonic()
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # pragma: no cover - the hang this guards against
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("hila eval hung after SIGINT")
    took = time.monotonic() - sent
    if proc.returncode == 0:  # pragma: no cover - only on a machine fast enough to finish first
        pytest.skip(f"the grid finished within {delay} s")
    # 130, or ended by SIGINT itself after printing 'interrupted' (a shell shows both as 130):
    # on this machine 2-5 of 12 runs interrupted 1 s in end the second way, before and after
    # issue 13's merges; the interpreter's shutdown with loky's pool is the suspect (not found)
    assert proc.returncode in (130, -signal.SIGINT), err
    assert "Traceback" not in err and "Error" not in err, err
    assert err.rstrip().endswith("interrupted") and took < 15, (took, err)


EXIT_WITH_SIGINT = """
import os, signal, threading, time
from hila_lang import cli

def finished_work(argv=None):
    # what joblib's pool does at exit: a thread joined in threading._shutdown; Ctrl-C comes then
    threading._register_atexit(lambda: (os.kill(os.getpid(), signal.SIGINT), time.sleep(2)))
    print("done", flush=True)
    return 0

cli.main = finished_work
cli.entry()
"""


def test_ctrl_c_while_python_exits_after_the_work_prints_no_traceback():
    """The work is done and written; a Ctrl-C while Python shuts joblib's pool down at exit
    (its manager thread joined in threading._shutdown) printed 'Exception ignored in: <module
    'threading'> ... KeyboardInterrupt' with exit status 0.  It now ends at once, quietly, with
    the work's status."""
    proc = subprocess.run([sys.executable, "-c", EXIT_WITH_SIGINT], capture_output=True, text=True, timeout=60)
    assert proc.stdout == "done\n"
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr


@pytest.mark.parametrize("signum, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_stopped_eval_keeps_the_rows_done_marked_incomplete(tmp_path, signum, code):
    """SIGTERM (or Ctrl-C) once some rows are done: the files hold those rows, marked incomplete,
    and the exit status is the signal's (issue 32: SIGTERM used to keep nothing)."""
    import json

    out = tmp_path / "ev"
    argv = [sys.executable, "-m", "hila_lang", "eval", "--trials-per-setup", "8", "--methods", "osila,tps",
            "--protocol", "paper", "--out", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = []
    for line in proc.stderr:  # the progress bar: a line every 10 % of the rows
        seen.append(line)
        if "/40 rows" in line and not line.split("] ")[1].startswith("0/"):
            break
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    err = "".join(seen) + err
    if proc.returncode == 0:  # pragma: no cover - only on a machine fast enough to finish first
        pytest.skip("the grid finished before the signal")
    assert proc.returncode == code, err
    assert "Traceback" not in err and "internal error" not in err, err
    assert (out / "results.json").exists(), err
    facts = json.loads((out / "results.json").read_text())["run"]
    assert facts["complete"] is False and facts["stopped_by"] == ("SIGTERM" if code == 143 else "Ctrl-C")
    assert 0 < facts["rows_done"] < facts["rows"] == 40
    assert (out / "tables.txt").read_text().startswith(f"INCOMPLETE: stopped by {facts['stopped_by']} after "
                                                        f"{facts['rows_done']} of 40 template rows")
    pairs = (out / "pairs.csv").read_text().splitlines()[1:]
    assert pairs and len(pairs) < 2 * 3 * 40 * 39  # some pairs, not the whole grid
