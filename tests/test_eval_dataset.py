"""The stand-in dataset of Experiment A: structure, human-like variation, determinism, file format."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.evaluation.dataset import (
    RATE_HZ,
    SETUPS,
    generate,
    load_dataset,
    save_dataset,
    setups_of,
)


def test_structure_five_setups_named_icps():
    trials = generate(seed=3, trials_per_setup=4)
    assert len(trials) == 20
    assert setups_of(trials) == [s.name for s in SETUPS]
    for t in trials:
        base = ("hand", "object.1", "object.2", "object.3", "object.4")
        assert t.icp_names[:5] == base
        assert ("waypoint" in t.icp_names) == (t.setup == "exp5")
        assert t.icps.shape == (len(t.icp_names), 2)
        # sampled at 20 Hz for 1.6-3.2 s
        assert 1.6 * RATE_HZ - 1 <= len(t.path) <= 3.2 * RATE_HZ + 1
        # in the 320 x 240 image
        assert (t.path >= -20).all() and (t.path[:, 0] <= 340).all() and (t.path[:, 1] <= 260).all()


def test_paths_start_at_the_hand_and_end_at_the_approach_side():
    for t in generate(seed=5, trials_per_setup=6):
        assert np.linalg.norm(t.path[0] - t.icps[0]) < 5.0
        near_side_mid = t.icps[1:3].mean(0)
        assert np.linalg.norm(t.path[-1] - near_side_mid) < 12.0
        # the last stretch moves towards the object (into the approach side)
        centre = t.icps[1:5].mean(0)
        assert np.linalg.norm(t.path[-1] - centre) < np.linalg.norm(t.path[-6] - centre)


def test_waypoint_trials_pass_through_the_waypoint_area():
    for t in generate(seed=2, trials_per_setup=8):
        if t.setup == "exp5":
            wp = t.icps[t.icp_names.index("waypoint")]
            assert np.linalg.norm(t.path - wp, axis=1).min() < 14.0


def test_trials_vary_like_different_people():
    trials = [t for t in generate(seed=0) if t.setup == "exp1"]
    lengths = {len(t.path) for t in trials}
    assert len(lengths) > 5
    starts = np.array([t.path[0] for t in trials])
    assert starts.std(0).min() > 2.0


def test_same_seed_same_data_other_seed_other_data():
    a, b, c = generate(seed=11, trials_per_setup=3), generate(seed=11, trials_per_setup=3), generate(seed=12, trials_per_setup=3)
    for x, y in zip(a, b):
        assert np.array_equal(x.path, y.path) and np.array_equal(x.icps, y.icps)
    assert not all(len(x.path) == len(z.path) and np.allclose(x.path, z.path) for x, z in zip(a, c))


def test_setups_draw_from_independent_streams():
    few, more = generate(seed=4, trials_per_setup=2), generate(seed=4, trials_per_setup=3)
    for setup in ("exp1", "exp5"):
        f = [t for t in few if t.setup == setup]
        m = [t for t in more if t.setup == setup]
        assert all(np.array_equal(x.path, y.path) for x, y in zip(f, m))


def test_minimum_jerk_profile():
    from hila_lang.osila.motion import minimum_jerk

    tau = np.linspace(0, 1, 101)
    s = minimum_jerk(tau)
    assert s[0] == 0 and s[-1] == 1 and np.all(np.diff(s) >= 0)
    assert np.argmax(np.diff(s)) in (49, 50)  # bell-shaped speed, peak mid-way


def test_bad_trial_count():
    with pytest.raises(InputError, match="trials per set-up as an integer >= 1, got 0"):
        generate(trials_per_setup=0)


def test_folder_round_trip_is_lossless(tmp_path):
    trials = generate(seed=7, trials_per_setup=2)
    save_dataset(trials, tmp_path)
    assert (tmp_path / "exp5" / "trial01.csv").read_text().startswith("t,x,y\n0.0,")
    assert "waypoint:" in (tmp_path / "exp5" / "trial01.icps.yaml").read_text()
    back = load_dataset(tmp_path)
    assert [t.label for t in back] == [t.label for t in trials]
    for x, y in zip(trials, back):
        assert np.array_equal(x.path, y.path)
        assert x.icp_names == y.icp_names and np.array_equal(x.icps, y.icps)
