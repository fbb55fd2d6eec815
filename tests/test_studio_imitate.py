"""hila studio's Imitate page: the scene as a ``.hila`` program ``hila check`` accepts, with the
person's names for its points; then in a real browser: drag an ICP and read OSILA's new path from
the page (THE HILA step's), add an avoid disc, draw the controls, export the scene."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("starlette")

from hila_lang.core.errors import InputError  # noqa: E402
from hila_lang.studio import imitate  # noqa: E402
from studio_support import click_at, plane_to_pixel  # noqa: E402
from studio_support import browser, page, studio  # noqa: F401 - the fixtures


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


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_drag_an_icp_and_read_osilas_new_path(page, studio, tmp_path):
    from hila_lang.hierarchy.step import hila_step
    from hila_lang.osila.template import load_template

    page.get_by_test_id("tab-imitate").click()
    page.get_by_test_id("imitate-template").select_option("reach.yaml")
    page.wait_for_function("window.hilaStudio.imitate.path && window.hilaStudio.imitate.shown >= 1")
    before = np.array(page.evaluate("window.hilaStudio.imitate.path"))
    handle = page.get_by_test_id("icp-object")
    box = handle.bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for i in range(1, 11):
        page.mouse.move(x + 15 * i, y + 9 * i)
    page.mouse.up()
    page.wait_for_function("window.hilaStudio.imitate.shown === window.hilaStudio.imitate.seq")
    task = page.evaluate("window.hilaStudio.imitate.task")
    after = np.array(page.evaluate("window.hilaStudio.imitate.path"))
    template = load_template(studio.folder / "reach.yaml")
    assert np.linalg.norm(np.array(task["object"]) - template.icps["object"]) > 0.005  # it moved
    expected = hila_step(template, {k: np.array(v) for k, v in task.items()}).path
    assert np.allclose(after, expected, atol=1e-9)  # the page shows THE HILA step's path
    assert np.abs(after - before).max() > 0.01
    assert np.linalg.norm(after - np.array(task["object"]), axis=1).min() < 1e-3  # it reaches the new object
    reason = page.get_by_test_id("imitate-reason").inner_text()
    assert "map:" in reason and "plan adjustment" in reason
    page.get_by_test_id("add-avoid").click()
    mid = after[len(after) // 4]
    u, v = plane_to_pixel(page, page.evaluate("window.hilaStudio.imitate.H"), mid)
    click_at(page, "imitate-canvas", u, v)
    page.wait_for_function("window.hilaStudio.imitate.shown === window.hilaStudio.imitate.seq")
    page.get_by_test_id("show-controls").check()
    page.wait_for_function("window.hilaStudio.imitate.controls && window.hilaStudio.imitate.shown === window.hilaStudio.imitate.seq")
    assert "avoid 1" in page.get_by_test_id("imitate-reason").inner_text()
    page.get_by_test_id("name-icp-object").fill("cup")  # rename the task's point
    page.get_by_test_id("name-icp-object").dispatch_event("change")
    page.get_by_test_id("export").click()
    page.wait_for_function("document.querySelector('[data-testid=export-text]').value.includes('import reach')")
    snippet = page.get_by_test_id("export-text").input_value().split("# --- path")[0]
    assert "point cup = " in snippet and "object = cup" in snippet, snippet
    (studio.folder / "snippet.hila").write_text(snippet)
    r = subprocess.run([sys.executable, "-m", "hila_lang", "check", "snippet.hila"], capture_output=True, text=True,
                       cwd=studio.folder)
    assert r.returncode == 0, r.stdout + r.stderr + snippet
    page.screenshot(path=tmp_path / "imitate.png")
