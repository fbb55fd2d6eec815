"""hila studio's Run page in a real browser: run a game to its end by clicks on the board its
world offers, breakpoints and Back on the way; open a recording and scrub it; a PyBullet run shows
the iCub and its eye; the docs' walk-through (draw a swipe, save it, a two-line program, run it)."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("starlette")

from hila_lang.core.errors import InputError  # noqa: E402
from hila_lang.studio.run import COMMANDS, ReplaySession, RunSession, analyse, plugins  # noqa: E402
from studio_support import READY, ROOT, click_at, plane_to_pixel, wait_status  # noqa: E402
from studio_support import browser, page, studio  # noqa: F401 - the fixtures

#: a program that fails at run time at its line 9 (an obstacle's radius below zero), on any back end
FAILING = """import reach
point home = (0.18, -0.25, 0.75)
point cup = (0.30, -0.18, 0.60)
point lamp = (0.211, -0.219, 0.735)
hand at home
main {
    run reach.reach(object = cup, home = home)
    let r = 0 - 0.01
    run reach.back(object = cup, home = home) avoid lamp radius r
}
"""


def _until(out, predicate, seconds=60.0):
    """The first snapshot the session sent to the page (``out``) that satisfies ``predicate`` (read
    from its messages, as the page does: a snapshot taken from another thread could read the game's
    record while the robot decides, which the referee forbids)."""
    import time

    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        found = [m for m in list(out) if m.get("type") in ("state", "step") and predicate(m)]
        if found:
            return found[0]
        time.sleep(0.05)
    raise AssertionError(f"not reached in {seconds} s: {out[-1:]}")


def test_a_failed_step_is_said_with_its_state_line_and_message(tmp_path):
    """The snapshot names the state that failed, its program line and why, until the next step;
    before, the page only had 'at main/back (step 3)'."""
    import shutil

    shutil.copy(ROOT / "primitives" / "reach.yaml", tmp_path / "reach.yaml")
    (tmp_path / "fail.hila").write_text(FAILING)
    out = []
    run = RunSession(tmp_path / "fail.hila", out.append, backend="dry")
    try:
        assert run.snapshot()["failed"] is None
        COMMANDS["run"](run, {})
        snap = _until(out, lambda s: s["failed"] is not None)
        assert snap["failed"]["state"] == "main/back" and snap["failed"]["line"] == 9
        assert "an obstacle's radius must be a number of metres > 0, got -0.01" in snap["failed"]["message"]
        assert snap["current"] == "main/back" and not snap["done"] and snap["outcome"] is None
        assert any(m.get("type") == "step" and m["failed"] for m in out)  # the step message carries it too
        out.clear()
        COMMANDS["back"](run, {})  # gone back a step: the failure is history
        _until(out, lambda s: s["failed"] is None and s["current"] == "main/let#1")
    finally:
        run.close()


def test_a_bug_in_a_step_is_lit_as_failed_too(tmp_path, monkeypatch):
    """A step that fails by a bug (not a HilaError: hila's ``internal error``, exit 3 on the command
    line) is lit like a failed step, at its state and line, with the first line of what the CLI says."""
    import shutil

    shutil.copy(ROOT / "primitives" / "reach.yaml", tmp_path / "reach.yaml")
    (tmp_path / "fail.hila").write_text(FAILING)
    out = []
    run = RunSession(tmp_path / "fail.hila", out.append, backend="dry")
    try:
        def broken():
            raise IndexError("list index out of range")
        monkeypatch.setattr(run.interp, "step", broken)
        COMMANDS["step"](run, {})
        snap = _until(out, lambda s: s["failed"] is not None)
        assert snap["failed"] == {"state": "main/reach", "line": 7,
                                  "message": "internal error: IndexError: list index out of range"}
        assert any(m.get("type") == "out" and "This is a bug in hila" in m["text"] for m in out)
    finally:
        run.close()


def test_a_finished_game_says_who_won():
    """The page's words at the end are the world's result (the report's ``result``), not a count of steps."""
    from hila_lang.worlds.tictactoe.world import RESULT_WORDS

    out = []
    run = RunSession(ROOT / "programs" / "game.hila", out.append, backend="dry", settings={"opponent": "minimax"})
    try:
        assert run.snapshot()["outcome"] is None
        COMMANDS["run"](run, {})
        snap = _until(out, lambda s: s["done"])
        result = run.interp.world.result()
        assert result is not None and snap["outcome"] == RESULT_WORDS[result]
        assert [c["label"] for c in snap["board"]["cells"]] == list(run.interp.world.referee.paper_marks())
    finally:
        run.close()


def test_the_board_shows_the_paper_and_notes_what_the_robot_read_otherwise():
    """Labels are what the paper holds (a mark drawn out of turn too, noted as not counted); a cell
    misread or unclear at the robot's latest look carries a note; an older look's misread does not;
    only cells free in the game's record are answers."""
    from types import SimpleNamespace

    from hila_lang.worlds.tictactoe.studio import board

    record = ("O", "", "", "", "X", "", "", "", "")
    paper = ("O", "", "O", "", "X", "", "", "", "")  # cell 3: the robot drew out of turn
    referee = SimpleNamespace(paper_marks=lambda: paper, looks=[{"look": 1}, {"look": 2}],
                              misreads=[{"look": 1, "cell": 9, "seen": "X", "true": ""},
                                        {"look": 2, "cell": 1, "seen": "X", "true": "O"}],
                              unclear=[{"look": 2, "cell": 5, "true": "X"}])
    b = board(SimpleNamespace(referee=referee, board=record)).to_json()
    cells = b["cells"]
    assert [c["label"] for c in cells] == list(paper)
    assert [c["answer"] for c in cells] == [None, "2", "3", "4", None, "6", "7", "8", "9"]
    assert "does not count" in cells[2]["note"] and "read X here at look 2" in cells[0]["note"]
    assert "could not tell" in cells[4]["note"] and cells[8]["note"] is None  # look 1 is not the latest


def test_the_plug_ins_are_the_pages_menus(monkeypatch):
    """Back ends, robots and worlds come from the registry: a back end it declares is listed,
    with its doc, and the default robot comes first."""
    from hila_lang.plugins import registry

    listed = plugins()
    assert {"dry", "pybullet"} <= {b["name"] for b in listed["backends"]}
    assert listed["robots"][0]["name"] == "icub" and "tictactoe" in {w["name"] for w in listed["worlds"]}
    fake = registry.BackendInfo("toyarm", "x:y", "a made-up arm")
    real = registry.declarations
    monkeypatch.setattr(registry, "declarations", lambda kind: real(kind) + ([fake] if kind == "back end" else []))
    assert {"name": "toyarm", "doc": "a made-up arm"} in plugins()["backends"]

def test_checking_says_what_the_programs_world_offers():
    game = ROOT / "programs" / "game.hila"
    doc = analyse(game, game.read_text())
    assert [p["severity"] for p in doc["problems"]] == ["note"] and "opponent" in doc["settings"]
    assert doc["problems"][0]["message"].startswith("the end of 'circle.retract' is free")  # said, not a problem
    assert doc["offered"] == {"opponent": {"human": "you (click a cell)", "minimax": "minimax", "random": "random"}}
    assert "crosses" in doc["hint"]
    abc = ROOT / "programs" / "abc.hila"
    assert analyse(abc, abc.read_text())["offered"] == {}  # the scripted world offers nothing here
    broken = analyse(abc, "main {\n  run nothing.x()\n}\n")
    assert broken["problems"][0]["line"] == 1 and broken["problems"][0]["severity"] == "error"


def test_the_page_sends_only_what_a_session_understands():
    import re

    script = (ROOT / "hila_lang" / "studio" / "static" / "run.js").read_text()
    sent = set(re.findall(r'cmd: "(\w+)"', script)) | {c for c in ("step", "run", "back", "reload", "stop")
                                                         if f'"{c}"' in script}
    assert sent - {"start", "open"} <= set(COMMANDS) and {"start", "open", "answer", "scrub", "view"} <= sent


def test_one_session_protocol_for_a_run_and_a_recording(tmp_path):
    """The same messages drive both; what one cannot do it says (no hasattr between them)."""
    import time

    from hila_lang.cli import main

    out = []
    run = RunSession(ROOT / "programs" / "game.hila", out.append, backend="dry", settings={"opponent": "minimax"})
    try:
        board = run.snapshot()["board"]  # the world's board, from its plug-in
        assert board["columns"] == 3 and [c["answer"] for c in board["cells"]] == [str(i) for i in range(1, 10)]
        with pytest.raises(InputError, match="only a recording scrubs"):
            COMMANDS["scrub"](run, {"n": 3})
        COMMANDS["step"](run, {"n": 2})
        for _ in range(200):
            if run.snapshot()["steps"] == 2:
                break
            time.sleep(0.05)
        assert run.snapshot()["steps"] == 2 and any(m.get("type") == "step" for m in out)
    finally:
        run.close()
    rec = tmp_path / "g.hilarec"
    assert main(["exec", str(ROOT / "programs" / "game.hila"), "--backend", "dry", "--opponent", "minimax",
                 "--record", str(rec), "--out", str(tmp_path / "o")]) == 0
    replay = ReplaySession(tmp_path, "g.hilarec", out.append)
    with pytest.raises(InputError, match="a recording takes no answers"):
        COMMANDS["answer"](replay, {"text": "5"})
    COMMANDS["view"](replay, {"azimuth": 90})  # a recording has no 3-D view: nothing to turn
    COMMANDS["stop"](replay, {})
    COMMANDS["scrub"](replay, {"n": 4})
    assert replay.snapshot()["steps"] == 4 and replay.length > 4 and replay.snapshot()["board"] is None


def _start_and_run(page, first: str, until: str) -> None:
    """Start the chosen program on the dry back end, see it at state ``first``, Run it until the
    page's snapshot ``s`` satisfies ``until`` (JavaScript)."""
    page.get_by_test_id("backend").select_option("dry")
    page.get_by_test_id("start").click()
    wait_status(page, f"s.current === '{first}'")
    page.get_by_test_id("run").click()
    wait_status(page, until)


#: docs/studio.md's walk-through: a straight stroke across the tic-tac-toe grid, corner to corner
SWIPE_JS = """
async () => {
  const S = window.hilaStudio.demo, c = document.querySelector('[data-testid=demo-canvas]'), box = c.getBoundingClientRect();
  const { applyH } = await import('/static/common.js');
  const px = (p) => applyH(S.H, p[0], p[1]);
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



@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_run_game_to_its_end_by_clicks(page, studio, tmp_path):
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-select").select_option("game.hila")
    page.wait_for_function("document.querySelector('[data-testid=program-editor]').value.includes('world tictactoe')")
    page.wait_for_selector("#problems li")
    assert page.locator("#problems li").first.inner_text() == "no problems"
    page.get_by_test_id("backend").select_option("dry")
    page.get_by_test_id("opponent").select_option("human")
    page.get_by_test_id("start").click()
    wait_status(page, "s.current === 'main/until#1'")
    page.get_by_test_id("step").click()
    wait_status(page, "s.steps === 1")
    assert page.get_by_test_id("fsm-current").get_attribute("data-state") == page.evaluate("window.hilaStudio.run.state.current")
    page.locator('#fsm g[data-state="main/mark/draw"]').click()  # a breakpoint
    wait_status(page, "s.breakpoints.includes('main/mark/draw')")
    page.get_by_test_id("run").click()
    wait_status(page, "s.current === 'main/mark/draw' && s.steps === 5")  # stopped before entering it
    page.get_by_test_id("back").click()
    wait_status(page, "s.steps === 4")
    page.locator('#fsm g[data-state="main/mark/draw"]').click()  # cleared
    wait_status(page, "s.breakpoints.length === 0")
    page.get_by_test_id("run").click()
    moves = 0
    while True:  # the page's board shows every cross played so far when it asks for the next
        wait_status(page, f"s.done || (s.waiting && s.board.cells.filter(c => c.label === 'X').length === {moves})")
        state = page.evaluate("window.hilaStudio.run.state")
        if state["done"]:
            break
        if moves == 0:
            page.screenshot(path=tmp_path / "run-your-move.png")
        free = [i + 1 for i, c in enumerate(state["board"]["cells"]) if c["answer"] is not None]
        page.get_by_test_id(f"cell-{free[0]}").click()
        moves += 1
    board = [c["label"] for c in page.evaluate("window.hilaStudio.run.state.board.cells")]
    assert moves >= 2 and board.count("X") == moves and board.count("O") >= moves
    outcome = page.evaluate("window.hilaStudio.run.state.outcome")  # who won, the world's words
    assert outcome in ("the robot wins", "the opponent wins", "a draw")
    assert page.get_by_test_id("run-status").inner_text().startswith(f"finished: {outcome}")
    assert "done" in page.get_by_test_id("run-status").get_attribute("class")
    assert "result:" in page.get_by_test_id("trace").inner_text() or "end" in page.get_by_test_id("trace").inner_text()
    page.screenshot(path=tmp_path / "run-finished.png")


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_open_a_recording_and_scrub(page, studio, tmp_path):
    rec = studio.folder / "game.hilarec"
    r = subprocess.run([sys.executable, "-m", "hila_lang", "exec", "game.hila", "--backend", "dry", "--opponent", "minimax",
                        "--record", str(rec), "--out", str(tmp_path / "out")], capture_output=True, text=True,
                       cwd=studio.folder, timeout=120)
    assert r.returncode == 0, r.stderr
    from hila_lang.session.recording import read_record

    steps = read_record(rec)["steps"]
    page.reload()
    page.wait_for_function(READY)
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("recording-select").select_option("game.hilarec")
    wait_status(page, "s.length > 0")
    assert page.get_by_test_id("program-editor").input_value() == (studio.folder / "game.hila").read_text()
    assert page.get_by_test_id("program-dirty").is_hidden()  # the recording's program, shown as it ran
    scrub = page.get_by_test_id("scrub")
    for n in (len(steps) // 2, 5, len(steps)):
        scrub.evaluate("(el, n) => { el.value = n; el.dispatchEvent(new Event('input')); }", n)
        wait_status(page, f"s.steps === {n}")
        state = page.evaluate("window.hilaStudio.run.state")
        if n < len(steps):
            assert state["current"] == steps[n]["state"]
            assert page.get_by_test_id("fsm-current").get_attribute("data-state") == steps[n]["state"]
        else:
            assert state["done"]
        label = page.get_by_test_id("scrub-at").inner_text()  # the step replayed, then the state lit: next
        assert label.startswith(f"after step {n} of {len(steps)}: ") and steps[n - 1]["state"] in label
        assert label.endswith(" (the end)" if n == len(steps) else f"next: {steps[n]['state']}")
    page.screenshot(path=tmp_path / "recording.png")


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_the_robot_menu_runs_the_chosen_arm(page, studio, tmp_path):
    """The Run page's robot choice (issue 33), listed from the registry, reaches the run: the Panda
    moves, and the 3-D view shows it."""
    page.get_by_test_id("tab-run").click()
    # the list is filled from /api/plugins after the page loads: wait for it, then the default first
    page.wait_for_function("document.querySelector('[data-testid=robot-choice]').options.length > 0")
    assert page.get_by_test_id("robot-choice").input_value() == "icub"
    page.get_by_test_id("program-select").select_option("game.hila")
    page.get_by_test_id("backend").select_option("pybullet")
    page.get_by_test_id("robot-choice").select_option("panda")
    page.get_by_test_id("opponent").select_option("minimax")
    page.get_by_test_id("start").click()
    wait_status(page, "s.robot && s.steps === 0 && s.arm === 'panda'", timeout=120000)
    assert page.get_by_test_id("robot-view").get_attribute("src").startswith("data:image/png")
    page.screenshot(path=tmp_path / "run-panda.png")
    page.get_by_test_id("stop").click()


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_pybullet_run_shows_the_icub_and_its_eye(page, studio, tmp_path):
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-select").select_option("game.hila")
    page.get_by_test_id("backend").select_option("pybullet")
    page.get_by_test_id("opponent").select_option("minimax")
    page.get_by_test_id("start").click()
    wait_status(page, "s.robot && s.steps === 0", timeout=120000)
    first = page.get_by_test_id("robot-view").get_attribute("src")
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    page.get_by_test_id("step").click()
    wait_status(page, "s.steps === 5 && s.eye", timeout=120000)  # reach ran: the robot looked
    assert page.get_by_test_id("robot-view").get_attribute("src") != first  # the arm moved
    assert page.get_by_test_id("eye").is_visible()
    page.screenshot(path=tmp_path / "run-pybullet.png")
    page.get_by_test_id("stop").click()


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_the_docs_walk_through_swipe_save_two_line_program_run(page, studio, tmp_path):
    page.on("dialog", lambda d: d.accept("mine.hila"))
    page.get_by_test_id("scene-select").select_option("world:tictactoe")
    page.wait_for_function("window.hilaStudio.demo.scene.name === 'world:tictactoe' && window.hilaStudio.demo.image.complete")
    page.get_by_test_id("segment-tags").fill("reach,stroke,retract")
    page.get_by_test_id("segment-contact").fill("stroke")
    page.evaluate(SWIPE_JS)
    page.wait_for_function("window.hilaStudio.demo.path && window.hilaStudio.demo.cuts.length === 2")
    demo = page.evaluate("window.hilaStudio.demo")
    feats = {f["name"]: f["point"] for f in demo["scene"]["features"]}
    page.get_by_test_id("mode-icp").check()
    for name, corner in (("from", "cell1.tl"), ("to", "cell9.br")):
        page.get_by_test_id("icp-name").fill(name)
        u, v = plane_to_pixel(page, demo["H"], feats[corner])
        click_at(page, "demo-canvas", u + 3, v - 3)
    page.get_by_test_id("template-name").fill("swipe")
    page.get_by_test_id("save-template").click()
    page.wait_for_function("window.hilaStudio.demo.saved && window.hilaStudio.demo.saved.template === 'swipe.yaml'")
    assert [s["contact"] for s in page.evaluate("window.hilaStudio.demo.saved.segments")] == [False, True, False]
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-editor").fill(
        "import swipe\nmain { run swipe(from = (0.25, -0.02, 0.571), to = (0.38, -0.16, 0.571)) }\n")
    page.wait_for_function("document.querySelector('#problems').innerText.includes('no problems')")
    assert page.get_by_test_id("opponent").count() == 0  # the scripted world offers no opponent
    page.get_by_test_id("program-save").click()
    page.wait_for_function("document.querySelector('[data-testid=program-select]').value === 'mine.hila'")
    _start_and_run(page, "main/swipe", "s.done")
    assert "finished after 2 steps" in page.get_by_test_id("run-status").inner_text()
    page.screenshot(path=tmp_path / "walk-through.png")


def _dialogs(page, answers):
    """Answer the page's dialogs in order from ``answers`` (text for a prompt, True/False for a
    confirm; the list may grow later); returns the dialogs seen, each (type, message)."""
    seen = []

    def on(d):
        seen.append((d.type, d.message))
        a = answers.pop(0) if answers else False
        d.accept(a) if isinstance(a, str) else (d.accept() if a else d.dismiss())
    page.on("dialog", on)
    return seen


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_save_never_replaces_another_file_without_asking(page, studio):
    """Save writes the file the editor opened; Save As asks a name and asks again before replacing
    another file (no: nothing written); the tab and the toolbar show unsaved changes; leaving, or
    opening another program, asks first."""
    (studio.folder / "mine.hila").write_text("main {\n}\n")
    (studio.folder / "other.hila").write_text("# someone else's\nmain {\n}\n")
    page.reload()
    page.wait_for_function(READY)
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-select").select_option("mine.hila")
    page.wait_for_function("window.hilaStudio.run.open === 'mine.hila'")
    assert page.get_by_test_id("program-dirty").is_hidden()
    page.get_by_test_id("program-editor").fill("main {\n    # mine, edited\n}\n")
    assert page.get_by_test_id("program-dirty").is_visible()
    assert "dirty" in page.get_by_test_id("tab-run").get_attribute("class")
    answers = ["other.hila", False, False]  # Save As other.hila; replace it? no; (later) discard? no
    seen = _dialogs(page, answers)
    page.get_by_test_id("program-save-as").click()
    page.wait_for_function("document.querySelector('[data-testid=program-save-status]').textContent.includes('not saved')")
    assert [t for t, _ in seen] == ["prompt", "confirm"] and "other.hila exists" in seen[1][1]
    assert (studio.folder / "other.hila").read_text() == "# someone else's\nmain {\n}\n"
    assert page.get_by_test_id("program-dirty").is_visible()
    page.get_by_test_id("program-select").select_option("other.hila")  # discard the changes? no
    page.wait_for_timeout(300)
    assert seen[2][0] == "confirm" and "unsaved changes" in seen[2][1]
    assert page.get_by_test_id("program-select").input_value() == "mine.hila"
    assert "# mine, edited" in page.get_by_test_id("program-editor").input_value()
    page.get_by_test_id("program-save").click()  # the open file: written without a question
    page.wait_for_function("document.querySelector('[data-testid=program-save-status]').textContent === 'saved mine.hila'")
    assert page.get_by_test_id("program-save-status").is_visible()  # on the Run page, beside Save
    assert len(seen) == 3 and (studio.folder / "mine.hila").read_text() == "main {\n    # mine, edited\n}\n"
    assert page.get_by_test_id("program-dirty").is_hidden() and "dirty" not in page.get_by_test_id("tab-run").get_attribute("class")
    page.get_by_test_id("program-editor").fill("main {\n    # copied\n}\n")
    answers.append("copy")
    page.get_by_test_id("program-save-as").click()
    page.wait_for_function("window.hilaStudio.run.open === 'copy.hila'")
    assert len(seen) == 4 and seen[3][0] == "prompt"  # a new name (".hila" added): no second question
    assert (studio.folder / "copy.hila").read_text() == "main {\n    # copied\n}\n"
    assert (studio.folder / "mine.hila").read_text() == "main {\n    # mine, edited\n}\n"
    assert page.get_by_test_id("program-select").input_value() == "copy.hila"
    page.get_by_test_id("program-editor").press("End")
    page.keyboard.type(" # typed, not saved")  # keys a person types (a browser asks on leaving only then)
    assert page.get_by_test_id("program-dirty").is_visible()
    with pytest.raises(Exception):  # leaving with unsaved changes asks; the answer is "stay": no navigation
        page.goto(studio.url, timeout=10000)
    assert seen[-1][0] == "beforeunload" and "# typed, not saved" in page.get_by_test_id("program-editor").input_value()


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_a_file_that_appeared_meanwhile_is_replaced_only_when_the_person_says_so(page, studio):
    """The server's refusal (409: the file exists, written by someone since the page listed the
    folder) is asked about; the page sends overwrite only after a yes."""
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-editor").fill("main {\n}\n")
    sent = []

    def route(r):
        sent.append(r.request.url)
        if "overwrite=1" in r.request.url:
            r.continue_()
        else:
            r.fulfill(status=409, content_type="application/json",
                      body='{"error": "late.hila exists: choose another name or replace it", "exists": true}')
    page.route("**/api/file?path=late.hila*", route)
    seen = _dialogs(page, ["late.hila", False, "late.hila", True])
    page.get_by_test_id("program-save").click()  # the list is on "choose...": a name is asked
    page.wait_for_function("document.querySelector('[data-testid=program-save-status]').textContent.startsWith('not saved')")
    assert "late.hila" in page.get_by_test_id("program-save-status").inner_text()
    assert [t for t, _ in seen] == ["prompt", "confirm"] and not (studio.folder / "late.hila").exists()
    assert len(sent) == 1 and "overwrite" not in sent[0]
    page.get_by_test_id("program-save").click()
    page.wait_for_function("window.hilaStudio.run.open === 'late.hila'")
    assert "overwrite=1" in sent[-1] and (studio.folder / "late.hila").read_text() == "main {\n}\n"


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_a_failed_run_is_lit_at_the_top_and_in_the_editor(page, studio):
    (studio.folder / "fail.hila").write_text(FAILING)
    page.reload()
    page.wait_for_function(READY)
    page.get_by_test_id("tab-run").click()
    page.get_by_test_id("program-select").select_option("fail.hila")
    page.wait_for_function("document.querySelector('#problems').innerText.includes('no problems')")
    _start_and_run(page, "main/reach", "s.failed")
    status = page.get_by_test_id("run-status")
    assert "failed" in status.get_attribute("class")
    assert status.inner_text().startswith("failed in main/back (line 9): an obstacle's radius must be")
    assert page.locator('#fsm g.node.failed').get_attribute("data-state") == "main/back"
    problem = page.get_by_test_id("run-problem")
    assert problem.inner_text().startswith("9: run failed in main/back") and "no problems" not in page.locator("#problems").inner_text()
    assert status.bounding_box()["y"] < page.get_by_test_id("trace").bounding_box()["y"]  # above the trace
    problem.click()  # the editor shows the line
    picked = page.evaluate("(() => { const e = document.querySelector('[data-testid=program-editor]'); "
                           "return e.value.slice(e.selectionStart, e.selectionEnd); })()")
    assert picked.strip().startswith("run reach.back(object = cup, home = home) avoid lamp radius r")
    page.get_by_test_id("back").click()  # back: the failure is history
    wait_status(page, "!s.failed && s.current === 'main/let#1'")
    assert "failed" not in status.get_attribute("class") and page.get_by_test_id("run-problem").count() == 0
    seen = _dialogs(page, [False])  # Start with unsaved changes: save them first? no -- the file as saved runs
    page.get_by_test_id("program-editor").press("End")
    page.keyboard.type("# an edit")
    page.get_by_test_id("start").click()
    wait_status(page, "s.steps === 0 && s.current === 'main/reach'")
    assert seen[0][0] == "confirm" and "without the editor's unsaved changes" in seen[0][1]
    assert (studio.folder / "fail.hila").read_text() == FAILING and page.get_by_test_id("program-dirty").is_visible()


@pytest.mark.slow  # a browser and a server (tests/conftest.py)
def test_an_installed_back_end_is_on_the_pages_menu(browser, tmp_path):
    """A back end installed as a plug-in (a throwaway distribution's entry point) is on the Run
    page's back-end menu, as it is in ``hila exec --backend``; nothing is written into the page."""
    from studio_support import Studio

    site = tmp_path / "site"
    (site / "toyarm-0.1.dist-info").mkdir(parents=True)
    (site / "toyarm-0.1.dist-info" / "METADATA").write_text("Metadata-Version: 2.1\nName: toyarm\nVersion: 0.1\n")
    (site / "toyarm-0.1.dist-info" / "entry_points.txt").write_text("[hila.backends]\ntoyarm = toyarm:BACKEND\n")
    (site / "toyarm.py").write_text("from hila_lang.plugins.registry import BackendInfo\n"
                                    "BACKEND = BackendInfo('toyarm', 'toyarm:make', 'a made-up arm for the test')\n")
    folder = tmp_path / "folder"
    folder.mkdir()
    studio = Studio(folder, env={"PYTHONPATH": str(site)})
    try:
        p = browser.new_page()
        p.goto(studio.url)
        p.wait_for_function("window.hilaStudio && window.hilaStudio.run")
        p.get_by_test_id("tab-run").click()
        p.wait_for_function("document.querySelectorAll('[data-testid=backend] option').length > 1")
        options = p.locator("[data-testid=backend] option")
        names = options.evaluate_all("os => os.map(o => [o.value, o.title])")
        assert ["toyarm", "a made-up arm for the test"] in names and "dry" in [n for n, _ in names]
        assert "tictactoe" in p.get_by_test_id("world-list").inner_text()
        p.close()
    finally:
        assert studio.stop() == 130
