"""``--dask``: the grid on a Dask distributed LocalCluster gives exactly the local numbers."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.cli import main
from hila_lang.evaluation.dataset import generate
from hila_lang.evaluation.run import run_grid

distributed = pytest.importorskip("distributed")

OPTIONS = {"threshold": 2.0}


@pytest.fixture(scope="module")
def address():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    try:
        yield cluster.scheduler_address
    finally:
        cluster.close()


@pytest.mark.slow
def test_dask_equals_local(address):
    trials = generate(seed=2, trials_per_setup=2)
    local = run_grid(trials, methods=("osila", "tps"), options=OPTIONS, progress=False)
    remote = run_grid(trials, methods=("osila", "tps"), options=OPTIONS, dask=address, progress=False)
    assert remote.backend == f"dask({address})"
    for m in ("osila", "tps"):
        assert np.array_equal(remote.r[m], local.r[m])
        assert np.array_equal(remote.msd[m], local.msd[m])
    assert not np.isnan(remote.r["osila"]).any()


@pytest.mark.slow
def test_cli_on_dask(address, tmp_path, capsys):
    assert main(["eval", "--out", str(tmp_path), "--trials-per-setup", "1", "--dask", address, "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert f"dask({address})" in out and "TABLE II" in out


def test_unreachable_scheduler_is_a_clear_error(tmp_path, capsys, monkeypatch):
    from hila_lang.evaluation import run

    monkeypatch.setattr(run, "CONNECT_TIMEOUT", "1s")
    status = main(["eval", "--out", str(tmp_path), "--trials-per-setup", "1", "--no-progress",
                   "--dask", "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert status == 2
    assert "cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'" in err and "Traceback" not in err


@pytest.mark.parametrize("address, message", [
    ("nonsense", "expected --dask ADDRESS as tcp://HOST:PORT, got 'nonsense'"),
    ("tcp://127.0.0.1:x", "expected --dask ADDRESS as tcp://HOST:PORT"),
    ("inproc://x", "an in-process scheduler"),
])
def test_malformed_address_fails_before_any_work(tmp_path, capsys, address, message):
    import time

    t0 = time.perf_counter()
    status = main(["eval", "--out", str(tmp_path / "o"), "--trials-per-setup", "1", "--no-progress",
                   "--dask", address])
    err = capsys.readouterr().err
    assert status == 2 and message in err and "Traceback" not in err
    assert time.perf_counter() - t0 < 5
    assert not (tmp_path / "o").exists()  # nothing generated or written
