"""Issue 30's Done-when, as a person does it: in ``hila studio`` (Debian's chromium through
Playwright, headless) the test moves the pointer -- pen up onto the tic-tac-toe scene, pressed
for the mark's strokes, released, off the picture -- places the ICPs by clicking the cell's
corners and the path's start, types nothing the page does not show, and clicks **Save template**
with the name the docs give (``circle``, beside ``game.hila``: docs/studio.md's "Teach it your
own mark").  The game program is the docs' words: ``programs/game.hila`` copied into the folder.
Then the robot plays it on PyBullet (minimax, seed 0) and reads the paper with its own eyes: no
misread, every mark inside its cell, every one of its marks read as its own.

The marks are the test's own drawing code (:data:`SHAPES`, strokes in the cell's unit box), not
the pointer model the benchmark uses.  ``HILA_KEEP_MARKS=DIR`` keeps the templates the test
saved (``DIR/triangle.yaml`` ...) for ``python bench/vision_game.py --marks DIR/triangle.yaml,...
--only still --opponent both`` (the seeds 0-4 x minimax/random matrix, docs/benchmarks.md)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("starlette")

from studio_support import READY, ROOT, Studio, plane_to_pixel  # noqa: E402
from studio_support import browser  # noqa: E402,F401 - the fixture

#: each mark's strokes in the cell's unit box (x to the cell's right, y to its far side, as the
#: robot sees it): a person's triangle, tick and square, one pen-down stroke each
SHAPES = {
    "triangle": [(0.5, 0.8), (0.2, 0.25), (0.8, 0.25), (0.5, 0.8)],
    "tick": [(0.2, 0.5), (0.4, 0.25), (0.8, 0.8)],
    "square": [(0.25, 0.75), (0.25, 0.25), (0.75, 0.25), (0.75, 0.75), (0.25, 0.75)],
}
CELL = 5


@pytest.fixture()
def studio(tmp_path):
    """``hila studio`` on a folder holding the docs' program, ``game.hila`` copied from the clone."""
    folder = tmp_path / "mine"
    folder.mkdir()
    shutil.copy(ROOT / "programs" / "game.hila", folder / "game.hila")
    s = Studio(folder)
    yield s
    assert s.stop() == 130


def _route(corners: dict, shape: list) -> np.ndarray:
    """The shape's unit-box points on the paper: bilinear in the cell's corners (inside the cell)."""
    tl, tr, br, bl = (np.asarray(corners[k], float)[:2] for k in ("tl", "tr", "br", "bl"))
    return np.array([(1 - v) * ((1 - u) * bl + u * br) + v * ((1 - u) * tl + u * tr) for u, v in shape])


def teach(page, mark: str) -> dict:
    """Draw ``mark`` with the mouse on the tic-tac-toe scene, place its ICPs, save it as circle.yaml;
    returns what the page said it saved."""
    page.get_by_test_id("scene-select").select_option(label="tic-tac-toe (robot's eye)")
    page.wait_for_function("window.hilaStudio.demo.scene.name.startsWith('world:') && "
                           "window.hilaStudio.demo.image && window.hilaStudio.demo.image.complete")
    scene = page.evaluate("window.hilaStudio.demo.scene")
    H = scene["H"]
    feats = {f["name"]: f["point"] for f in scene["features"]}
    corners = {k: feats[f"cell{CELL}.{k}"] for k in ("tl", "tr", "br", "bl")}
    box = page.get_by_test_id("demo-canvas").bounding_box()
    sx, sy = box["width"] / scene["width"], box["height"] / scene["height"]

    def at(p):  # a point on the paper -> where the mouse goes (the page's own plane -> picture map)
        u, v = plane_to_pixel(page, H, p)
        return box["x"] + u * sx, box["y"] + v * sy

    def glide(a, b, n):  # a person's smooth move, one pointer event every ~16 ms
        for i in range(1, n + 1):
            s = i / n
            s = s * s * (3 - 2 * s)
            page.mouse.move(a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s)
            page.wait_for_timeout(16)

    stroke = [at(p) for p in _route(corners, SHAPES[mark])]
    centre = np.mean([np.asarray(c, float)[:2] for c in corners.values()], axis=0)
    # the hand comes from about 12 cm away on the paper and goes off elsewhere, as a person's does
    start, leave = at(centre + [-0.09, 0.08]), at(centre + [-0.10, -0.07])
    for x, y in (start, leave):
        assert box["x"] < x < box["x"] + box["width"] and box["y"] < y < box["y"] + box["height"]
    page.mouse.move(*start)   # onto the picture, pen up
    page.wait_for_timeout(16)
    glide(start, stroke[0], 40)
    page.wait_for_timeout(150)
    page.mouse.down()
    for a, b in zip(stroke, stroke[1:]):
        glide(a, b, 25)
        page.wait_for_timeout(60)   # a corner: the hand slows
    page.mouse.up()
    page.wait_for_timeout(150)
    glide(stroke[-1], leave, 40)
    page.get_by_role("button", name="Finish drawing").click()   # the pointer leaves the picture for it
    page.wait_for_function("window.hilaStudio.demo.path && window.hilaStudio.demo.cuts.length === 2")
    demo = page.evaluate("window.hilaStudio.demo")
    assert "now place the ICPs" in page.get_by_test_id("save-status").inner_text()

    page.get_by_role("button", name="Save template").click()   # too early: said, and cleared by the next step
    page.wait_for_function("document.querySelector('[data-testid=save-status]').dataset.kind === 'error'")
    assert "place at least one ICP" in page.get_by_test_id("save-status").inner_text()
    page.get_by_label("Place ICPs").check()
    for name, p in [*corners.items(), ("hand", demo["path"][0])]:
        page.get_by_test_id("icp-name").fill(name)
        x, y = at(p)
        page.mouse.click(x + 3, y - 2)   # near it: a click snaps to the crossing or the path's start
    icps = page.evaluate("window.hilaStudio.demo.icps")
    assert {k: icps[k] for k in corners} == corners and icps["hand"] == demo["path"][0]
    status = page.get_by_test_id("save-status")
    assert "5 ICPs placed" in status.inner_text() and "error" not in status.inner_text()  # the guide moved on
    assert page.get_by_test_id("segment-tags").input_value() == "reach,draw,retract"
    assert page.get_by_test_id("segment-contact").input_value() == "draw"
    page.get_by_test_id("template-name").fill("circle")
    page.get_by_role("button", name="Save template").click()
    page.wait_for_function("window.hilaStudio.demo.saved !== undefined")
    assert "saved circle.yaml" in page.get_by_test_id("save-status").inner_text()
    return dict(page.evaluate("window.hilaStudio.demo.saved"), path=demo["path"], pen=demo["pen"])


@pytest.mark.slow  # a browser, a server and a game on PyBullet (tests/conftest.py)
@pytest.mark.parametrize("mark", list(SHAPES))
def test_a_mark_taught_in_the_studio_plays_and_is_read_as_the_robots_own(browser, studio, tmp_path, mark):  # noqa: F811
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(studio.url)
    page.wait_for_function(READY)
    saved = teach(page, mark)
    page.screenshot(path=tmp_path / f"{mark}-saved.png")
    page.close()
    assert not errors, errors
    # cut where the pen touched and left the paper: the draw part is the pen-down part
    pen = np.asarray(saved["pen"], bool)
    draw = saved["segments"][1]
    assert saved["segments"][0]["tag"] == "reach" and draw["tag"] == "draw" and draw["contact"]
    assert pen[draw["start"]:draw["stop"]].mean() > 0.9 and not pen[:draw["start"]].any()
    assert not pen[draw["stop"]:].any()
    folder = studio.folder
    if os.environ.get("HILA_KEEP_MARKS"):
        keep = Path(os.environ["HILA_KEEP_MARKS"])
        keep.mkdir(parents=True, exist_ok=True)
        shutil.copy(folder / "circle.yaml", keep / f"{mark}.yaml")

    out = tmp_path / "game"
    r = subprocess.run([sys.executable, "-m", "hila_lang", "exec", "game.hila", "--backend", "pybullet",
                        "--opponent", "minimax", "--seed", "0", "--out", str(out)],
                       capture_output=True, text=True, cwd=folder, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:] + r.stdout[-2000:]
    report = json.loads((out / "report.json").read_text())
    vision = report["vision"]
    assert vision["board_read_by"] == "vision" and vision["robot_mark"] == ["circle.draw"]
    assert report["result"] == "draw"  # minimax against minimax
    assert vision["misreads"] == [] and vision["unclear"] == []
    assert report["marks_outside_cell"] == 0 and report["fouls"] == []
    robot = [m["cell"] for m in report["moves"] if m["player"] == "robot"]
    last = vision["per_look"][-1]["board"]
    assert len(robot) >= 4 and all(last[c - 1] == "O" for c in robot), (robot, last)  # its own, read as its own
