"""hila studio in a real browser (Debian's chromium through Playwright, headless): draw a
demonstration with synthesized pointer events and save it (the same file as ``hila learn``),
play ``game.hila`` with it, drag an ICP and read OSILA's new path from the page, run a game to
its end by clicks, open a recording and scrub it.  Screenshots of each view go to the test's
output folder (``tmp_path``)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest

from studio_support import BROWSER_ARGS, ROOT, Studio, chromium_or_skip

pytest.importorskip("starlette")
pytestmark = pytest.mark.slow  # a browser and a server per test (tests/conftest.py)

#: a person's reach, circle and retract over cell 5 of the tic-tac-toe sheet, as pointer events
#: with their own time stamps: hover in from the lower left, pause, pen down, one circle, pen up,
#: pause, hover out to the upper right and off the canvas
DRAW_JS = """
async ({cell}) => {
  const S = window.hilaStudio.demo, c = document.querySelector('[data-testid=demo-canvas]');
  const box = c.getBoundingClientRect();
  const px = (p) => { const H = S.H, w = H[2][0]*p[0] + H[2][1]*p[1] + H[2][2];
    return [(H[0][0]*p[0] + H[0][1]*p[1] + H[0][2]) / w, (H[1][0]*p[0] + H[1][1]*p[1] + H[1][2]) / w]; };
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


#: docs/studio.md's walk-through: a straight stroke across the tic-tac-toe grid, corner to corner
SWIPE_JS = """
async () => {
  const S = window.hilaStudio.demo, c = document.querySelector('[data-testid=demo-canvas]'), box = c.getBoundingClientRect();
  const px = (p) => { const H = S.H, w = H[2][0]*p[0] + H[2][1]*p[1] + H[2][2];
    return [(H[0][0]*p[0] + H[0][1]*p[1] + H[0][2]) / w, (H[1][0]*p[0] + H[1][1]*p[1] + H[1][2]) / w]; };
  const f = (n) => S.scene.features.find(x => x.name === n).point;
  const a = f('cell1.tl'), b = f('cell9.br');
  const sleep = (ms) => new Promise(res => setTimeout(res, ms));
  const fire = (type, p, down) => { const [u, v] = px(p); c.dispatchEvent(new PointerEvent(type, {bubbles: true,
      clientX: box.left + u, clientY: box.top + v, pointerId: 3, pointerType: 'mouse', buttons: down ? 1 : 0})); };
  const sm = (s) => s * s * (3 - 2 * s);
  const leg = async (p, q, n, down) => { for (let i = 1; i <= n; i++) { const s = sm(i / n);
      fire('pointermove', [p[0] + (q[0] - p[0]) * s, p[1] + (q[1] - p[1]) * s], down); await sleep(16); } };
  const start = [a[0] - 0.08, a[1] + 0.08], end = [b[0] + 0.06, b[1] - 0.08];
  fire('pointermove', start, false); await leg(start, a, 30, false);
  for (let i = 0; i < 8; i++) { fire('pointermove', a, false); await sleep(16); }
  fire('pointerdown', a, true); await leg(a, b, 50, true); fire('pointerup', b, false);
  for (let i = 0; i < 8; i++) { fire('pointermove', b, false); await sleep(16); }
  await leg(b, end, 30, false);
  c.dispatchEvent(new PointerEvent('pointerleave', {pointerId: 3}));
}
"""


@pytest.fixture(scope="module")
def browser():
    exe, sync_api = chromium_or_skip()
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=exe, headless=True, args=BROWSER_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    folder = tmp_path_factory.mktemp("studio")
    shutil.copy(ROOT / "programs" / "game.hila", folder / "game.hila")
    shutil.copy(ROOT / "primitives" / "reach.yaml", folder / "reach.yaml")
    s = Studio(folder)
    yield s
    assert s.stop() == 130


@pytest.fixture()
def page(browser, studio):
    p = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = []
    p.on("pageerror", lambda e: errors.append(str(e)))
    p.goto(studio.url)
    p.wait_for_function("window.hilaStudio.demo.scene !== undefined")
    yield p
    p.close()
    assert not errors, errors


def click_at(page, testid, u, v):
    box = page.get_by_test_id(testid).bounding_box()
    page.mouse.click(box["x"] + u, box["y"] + v)


def test_draw_save_equals_hila_learn_and_plays_the_game(page, studio, tmp_path):
    page.get_by_test_id("scene-select").select_option("tictactoe")
    page.wait_for_function("window.hilaStudio.demo.scene.name === 'tictactoe' && window.hilaStudio.demo.image.complete")
    page.evaluate(DRAW_JS, {"cell": 5})
    page.wait_for_function("window.hilaStudio.demo.path && window.hilaStudio.demo.cuts.length === 2")
    demo = page.evaluate("window.hilaStudio.demo")
    path = np.array(demo["path"])
    assert path.shape[1] == 3 and 60 < len(path) < 140
    z = demo["scene"]["z"]
    assert abs(path[:, 2].min() - z) < 1e-9 and path[0, 2] > z + 0.05 and path[-1, 2] > z + 0.05  # lifted while up
    page.get_by_test_id("mode-icp").check()
    H = np.array(demo["H"])
    feats = {f["name"]: f["point"] for f in demo["scene"]["features"]}

    def px(p):
        q = H @ [p[0], p[1], 1.0]
        return q[0] / q[2], q[1] / q[2]

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
    page.wait_for_function("window.hilaStudio.saved !== undefined")
    saved = page.evaluate("window.hilaStudio.saved")
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


def test_drag_an_icp_and_read_osilas_new_path(page, studio, tmp_path):
    from hila_lang.hierarchy.step import hila_step
    from hila_lang.osila.template import load_template

    page.get_by_test_id("tab-imitate").click()
    page.get_by_test_id("imitate-template").select_option("reach.yaml")
    page.wait_for_function("window.hilaStudio.imit.path && window.hilaStudio.imit.shown >= 1")
    before = np.array(page.evaluate("window.hilaStudio.imit.path"))
    handle = page.get_by_test_id("icp-object")
    box = handle.bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for i in range(1, 11):
        page.mouse.move(x + 15 * i, y + 9 * i)
    page.mouse.up()
    page.wait_for_function("window.hilaStudio.imit.shown === window.hilaStudio.imit.seq")
    task = page.evaluate("window.hilaStudio.imit.task")
    after = np.array(page.evaluate("window.hilaStudio.imit.path"))
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
    H = np.array(page.evaluate("window.hilaStudio.imit.H"))
    q = H @ [mid[0], mid[1], 1.0]
    click_at(page, "imitate-canvas", q[0] / q[2], q[1] / q[2])
    page.wait_for_function("window.hilaStudio.imit.shown === window.hilaStudio.imit.seq")
    page.get_by_test_id("show-controls").check()
    page.wait_for_function("window.hilaStudio.imit.controls && window.hilaStudio.imit.shown === window.hilaStudio.imit.seq")
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


def _wait_status(page, predicate: str, timeout=60000):
    page.wait_for_function(f"(() => {{ const s = window.hilaStudio.run.state; return s && ({predicate}); }})()",
                           timeout=timeout)


def test_run_game_to_its_end_by_clicks(page, studio, tmp_path):
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-select").select_option("game.hila")
    page.wait_for_function("document.querySelector('[data-testid=program-editor]').value.includes('world tictactoe')")
    page.wait_for_selector("#problems li")
    assert page.locator("#problems li").first.inner_text() == "no problems"
    page.get_by_test_id("backend").select_option("dry")
    page.get_by_test_id("opponent").select_option("human")
    page.get_by_test_id("start").click()
    _wait_status(page, "s.current === 'main/until#1'")
    page.get_by_test_id("step").click()
    _wait_status(page, "s.steps === 1")
    assert page.get_by_test_id("fsm-current").get_attribute("data-state") == page.evaluate("window.hilaStudio.run.state.current")
    page.locator('#fsm g[data-state="main/mark/draw"]').click()  # a breakpoint
    _wait_status(page, "s.breakpoints.includes('main/mark/draw')")
    page.get_by_test_id("run").click()
    _wait_status(page, "s.current === 'main/mark/draw' && s.steps === 5")  # stopped before entering it
    page.get_by_test_id("back").click()
    _wait_status(page, "s.steps === 4")
    page.locator('#fsm g[data-state="main/mark/draw"]').click()  # cleared
    _wait_status(page, "s.breakpoints.length === 0")
    page.get_by_test_id("run").click()
    moves = 0
    while True:  # the page's board shows every cross played so far when it asks for the next
        _wait_status(page, f"s.done || (s.waiting && s.board.filter(m => m === 'X').length === {moves})")
        state = page.evaluate("window.hilaStudio.run.state")
        if state["done"]:
            break
        if moves == 0:
            page.screenshot(path=tmp_path / "run-your-move.png")
        free = [i + 1 for i, m in enumerate(state["board"]) if not m]
        page.get_by_test_id(f"cell-{free[0]}").click()
        moves += 1
    board = page.evaluate("window.hilaStudio.run.state.board")
    assert moves >= 2 and board.count("X") == moves and board.count("O") >= moves
    assert "finished" in page.get_by_test_id("run-status").inner_text()
    assert "result:" in page.get_by_test_id("trace").inner_text() or "end" in page.get_by_test_id("trace").inner_text()
    page.screenshot(path=tmp_path / "run-finished.png")


def test_open_a_recording_and_scrub(page, studio, tmp_path):
    rec = studio.folder / "game.hilarec"
    r = subprocess.run([sys.executable, "-m", "hila_lang", "exec", "game.hila", "--backend", "dry", "--opponent", "minimax",
                        "--record", str(rec), "--out", str(tmp_path / "out")], capture_output=True, text=True,
                       cwd=studio.folder, timeout=120)
    assert r.returncode == 0, r.stderr
    from hila_lang.session.recording import read_record

    steps = read_record(rec)["steps"]
    page.reload()
    page.wait_for_function("window.hilaStudio.demo.scene !== undefined")
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("recording-select").select_option("game.hilarec")
    _wait_status(page, "s.length > 0")
    scrub = page.get_by_test_id("scrub")
    for n in (len(steps) // 2, 5, len(steps)):
        scrub.evaluate("(el, n) => { el.value = n; el.dispatchEvent(new Event('input')); }", n)
        _wait_status(page, f"s.steps === {n}")
        state = page.evaluate("window.hilaStudio.run.state")
        if n < len(steps):
            assert state["current"] == steps[n]["state"]
            assert page.get_by_test_id("fsm-current").get_attribute("data-state") == steps[n]["state"]
        else:
            assert state["done"]
        assert f"step {n} of {len(steps)}" in page.get_by_test_id("scrub-at").inner_text()
    page.screenshot(path=tmp_path / "recording.png")


def test_the_robot_menu_runs_the_chosen_arm(page, studio, tmp_path):
    """The Run page's robot choice (issue 33) reaches the run: the Panda moves, and the 3-D view shows it."""
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-select").select_option("game.hila")
    page.get_by_test_id("backend").select_option("pybullet")
    page.get_by_test_id("robot-choice").select_option("panda")
    page.get_by_test_id("opponent").select_option("minimax")
    page.get_by_test_id("start").click()
    _wait_status(page, "s.robot && s.steps === 0 && s.arm === 'panda'", timeout=120000)
    assert page.get_by_test_id("robot-view").get_attribute("src").startswith("data:image/png")
    page.screenshot(path=tmp_path / "run-panda.png")
    page.get_by_test_id("stop").click()


def test_pybullet_run_shows_the_icub_and_its_eye(page, studio, tmp_path):
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-select").select_option("game.hila")
    page.get_by_test_id("backend").select_option("pybullet")
    page.get_by_test_id("opponent").select_option("minimax")
    page.get_by_test_id("start").click()
    _wait_status(page, "s.robot && s.steps === 0", timeout=120000)
    first = page.get_by_test_id("robot-view").get_attribute("src")
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    _wait_status(page, "s.steps === 5 && s.eye", timeout=120000)  # reach ran: the robot looked
    assert page.get_by_test_id("robot-view").get_attribute("src") != first  # the arm moved
    assert page.get_by_test_id("eye").is_visible()
    page.screenshot(path=tmp_path / "run-pybullet.png")
    page.get_by_test_id("stop").click()


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
    x = plot["x"] + 4 + (plot["width"] - 8) * cuts[0] / (T - 1)
    page.mouse.move(x, plot["y"] + 60)
    page.mouse.down()
    page.mouse.move(x + 5 * (plot["width"] - 8) / (T - 1), plot["y"] + 60)
    page.mouse.up()
    moved = page.evaluate("window.hilaStudio.demo.cuts")
    assert moved[0] == cuts[0] + 5
    page.get_by_test_id("template-name").fill("reach2")
    page.get_by_test_id("save-template").click()
    page.wait_for_function("window.hilaStudio.saved && window.hilaStudio.saved.template === 'reach2.yaml'")
    saved = load_template(studio.folder / "reach2.yaml")
    assert [s.start for s in saved.segments[1:]] == moved
    assert np.allclose(saved.path, original.path) and saved.icps.keys() == original.icps.keys()


def test_the_docs_walk_through_swipe_save_two_line_program_run(page, studio, tmp_path):
    page.on("dialog", lambda d: d.accept("mine.hila"))
    page.get_by_test_id("scene-select").select_option("tictactoe")
    page.wait_for_function("window.hilaStudio.demo.scene.name === 'tictactoe' && window.hilaStudio.demo.image.complete")
    page.get_by_test_id("segment-tags").fill("reach,stroke,retract")
    page.get_by_test_id("segment-contact").fill("stroke")
    page.evaluate(SWIPE_JS)
    page.wait_for_function("window.hilaStudio.demo.path && window.hilaStudio.demo.cuts.length === 2")
    demo = page.evaluate("window.hilaStudio.demo")
    H = np.array(demo["H"])
    feats = {f["name"]: f["point"] for f in demo["scene"]["features"]}
    page.get_by_test_id("mode-icp").check()
    for name, corner in (("from", "cell1.tl"), ("to", "cell9.br")):
        page.get_by_test_id("icp-name").fill(name)
        q = H @ [feats[corner][0], feats[corner][1], 1.0]
        click_at(page, "demo-canvas", q[0] / q[2] + 3, q[1] / q[2] - 3)
    page.get_by_test_id("template-name").fill("swipe")
    page.get_by_test_id("save-template").click()
    page.wait_for_function("window.hilaStudio.saved && window.hilaStudio.saved.template === 'swipe.yaml'")
    assert [s["contact"] for s in page.evaluate("window.hilaStudio.saved.segments")] == [False, True, False]
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-editor").fill(
        "import swipe\nmain { run swipe(from = (0.25, -0.02, 0.571), to = (0.38, -0.16, 0.571)) }\n")
    page.wait_for_function("document.querySelector('#problems').innerText.includes('no problems')")
    assert page.get_by_test_id("opponent").is_disabled()  # the scripted world has no opponent
    page.get_by_test_id("program-save").click()
    page.wait_for_function("document.querySelector('[data-testid=program-select]').value === 'mine.hila'")
    page.get_by_test_id("backend").select_option("dry")
    page.get_by_test_id("start").click()
    _wait_status(page, "s.current === 'main/swipe'")
    page.get_by_test_id("run").click()
    _wait_status(page, "s.done")
    assert "finished after 2 steps" in page.get_by_test_id("run-status").inner_text()
    page.screenshot(path=tmp_path / "walk-through.png")
