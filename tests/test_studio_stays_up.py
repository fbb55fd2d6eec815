"""Issue 32, the studio's last part: it stops at once, keeps answering, reads what it checked,
drops the work of a page that went away, and cleans up after a crash.

- Ctrl-C or SIGTERM in the first 0.2 s after the URL line stops the studio within a second (the
  server's loop is woken by the signal; uvicorn's imports happen before the URL line; the fork
  server still importing is killed);
- a large JSON body is bounded (:data:`hila_lang.studio.schema.MAX_JSON`) and parsed and
  checked off the event loop: another request is answered meanwhile;
- a program started, a program reloaded and a recording opened are read through the file
  opened once (``O_NOFOLLOW``/``openat``): a symlink swapped in after a check gives nothing
  outside the folder;
- a request or a websocket whose page goes away stops its worker job;
- the staging folders a killed studio left are removed at the next start (only hila's own)."""

from __future__ import annotations

import asyncio
import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from studio_support import request, Studio

pytest.importorskip("starlette")

from hila_lang.core.fileio import remove_stale_staging, staging_name  # noqa: E402
from hila_lang.language.environment import Environment  # noqa: E402
from hila_lang.studio import files, page, run, schema, worker  # noqa: E402
from hila_lang.studio.page import Studio as StudioState  # noqa: E402

INSIDE = "main {\n    let a = 1\n}\n"
OUTSIDE = "main {\n    let secret = 1\n    let more = 2\n    let most = 3\n}\n"


# ----------------------------------------------------------------------------- 1. Ctrl-C at once


def test_a_signal_wakes_the_servers_loop_at_once(monkeypatch):
    """uvicorn's main loop looks for a stop every 0.1 s; the studio's is woken by the signal.
    Five signals, each 20 ms into a wait: every one ends the loop within 50 ms (uvicorn's own
    loop took 80 ms on average, up to 100)."""
    uvicorn = pytest.importorskip("uvicorn")
    from hila_lang.studio import app

    monkeypatch.setattr(worker, "stop", lambda final=False: None)  # this process's workers are the tests'
    took = []
    for _ in range(5):
        config = uvicorn.Config(lambda scope, receive, send: None, lifespan="off", log_level="warning")
        config.load()
        server = app._server_class()(config)

        async def go():
            loop = asyncio.create_task(server.main_loop())
            await asyncio.sleep(0.02)
            start = time.perf_counter()
            server.handle_exit(signal.SIGINT, None)
            await loop
            return time.perf_counter() - start

        took.append(asyncio.run(go()))
    assert max(took) < 0.05, took


def _stop_after(folder, sig, delay):
    proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "studio", str(folder), "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().startswith("hila studio: http://127.0.0.1:")
        time.sleep(delay)
        start = time.monotonic()
        proc.send_signal(sig)
        proc.wait(timeout=30)
        return time.monotonic() - start, proc.returncode
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.slow
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_ctrl_c_and_sigterm_right_after_start_stop_the_studio_within_a_second(tmp_path, sig, code):
    """Before: 0.83-1.4 s at load 9 when the signal came in the first 0.2 s (the workers' fork
    server importing, uvicorn importing its protocols, the loop's 0.1 s ticks)."""
    for delay in (0.0, 0.1, 0.2):
        took, rc = _stop_after(tmp_path, sig, delay)
        assert rc == code and took < 1.0, f"signal {delay} s after the URL line: stopped after {took:.2f} s"


# ----------------------------------------------------------------------------- 2. large JSON


def test_a_json_body_past_the_limit_is_refused_before_it_is_parsed():
    """MAX_JSON holds the largest body the door's limits allow (a program of MAX_TEXT non-ASCII
    characters escaped, a demonstration of MAX_SAMPLES samples), and no more."""
    largest = json.dumps(dict(path="a.hila", text="\u00e9" * schema.MAX_TEXT))
    rng = np.random.default_rng(0)
    samples = [dict(x=float(x), y=float(y), t=1.7e12 + i / 60, down=True, p=float(p)) for i, (x, y, p) in
               enumerate(rng.uniform(-1e5, 1e5, (schema.MAX_SAMPLES, 3)) * [1, 1, 5e-6] + [0, 0, 0.5])]
    demonstration = json.dumps(dict(samples=samples, k=schema.MAX_SEGMENTS, method="speed", seed=0))
    assert len(largest) <= schema.MAX_JSON and len(demonstration) <= schema.MAX_JSON
    assert page.checked_json(demonstration, schema.DEMONSTRATION)["k"] == schema.MAX_SEGMENTS
    with pytest.raises(Exception, match=f"at most {schema.MAX_JSON} bytes of JSON"):
        page.checked_json("[" + " " * schema.MAX_JSON + "]", schema.CHECK)  # refused unparsed (else: not an object)


def test_a_json_body_is_parsed_and_checked_off_the_event_loop(monkeypatch):
    """read_json and a socket's message: the parse and the check run in another thread than the
    event loop's (before: on the loop, 4 s for a 20 MB body at load 10, every request waiting)."""
    threads = []
    real = page.checked_json

    def spy(text, shape):
        threads.append(threading.get_ident())
        return real(text, shape)

    monkeypatch.setattr(page, "checked_json", spy)

    class Request:
        url = type("URL", (), {"path": "/api/check"})()
        headers: dict = {}

        async def stream(self):
            yield json.dumps(dict(path="a.hila", text="main {\n}\n")).encode()

    async def go():
        return threading.get_ident(), await page.read_json(Request())

    loop_thread, doc = asyncio.run(go())
    assert doc == dict(path="a.hila", text="main {\n}\n") and threads and threads[0] != loop_thread


@pytest.mark.slow
def test_another_request_is_answered_while_a_large_body_is_checked(tmp_path):
    """A body past MAX_JSON is refused before it is read; one under it (3 MB, checked for a
    fraction of a second, then refused for its last field) is checked while GETs are answered."""
    s = Studio(tmp_path)
    try:
        conn = http.client.HTTPConnection("127.0.0.1", s.port, timeout=60)
        conn.putrequest("POST", f"/api/demonstration?token={s.token}", skip_host=True)
        conn.putheader("Host", f"127.0.0.1:{s.port}")
        conn.putheader("Content-Length", str(schema.MAX_JSON + 1))
        conn.endheaders()  # no body sent: the length alone is refused
        r = conn.getresponse()
        assert r.status == 403 and f"at most {schema.MAX_JSON} bytes" in r.read().decode()
        rng = np.random.default_rng(0)
        n, m = schema.MAX_SAMPLES, schema.MAX_POINTS
        big = json.dumps(dict(samples=[dict(x=float(x), y=float(y), t=float(i)) for i, (x, y) in
                                       enumerate(rng.uniform(-1e3, 1e3, (n, 2)))],
                              path=rng.uniform(-1, 1, (m, 2)).tolist(), times=np.linspace(0, 600, m).tolist(),
                              k="many"))
        assert 2.5e6 < len(big) < schema.MAX_JSON
        sent, answered = threading.Event(), {}

        def post():
            c = http.client.HTTPConnection("127.0.0.1", s.port, timeout=120)
            c.request("POST", f"/api/demonstration?token={s.token}", body=big, headers={"Host": f"127.0.0.1:{s.port}"})
            sent.set()
            r = c.getresponse()
            answered["at"], answered["status"], answered["text"] = time.monotonic(), r.status, r.read().decode()

        thread = threading.Thread(target=post)
        thread.start()
        sent.wait(60)
        gets = []
        while thread.is_alive() and len(gets) < 200:
            assert request(s, "GET", "/api/pages")[0] == 200
            gets.append(time.monotonic())
        thread.join(120)
        assert answered["status"] == 400 and "k: expected" in answered["text"]
        assert [g for g in gets if g < answered["at"]], "no GET was answered while the large body was checked"
    finally:
        s.stop()


# ----------------------------------------------------------------------------- 3. opened once


class _Swap:
    """``os.path.realpath`` that, the first time it resolves ``name`` (a check), then swaps that
    file for a symbolic link to ``target`` outside the folder: the worst moment of a race."""

    def __init__(self, monkeypatch, folder: Path, name: str, target: Path) -> None:
        self.file, self.target, self.done = folder / name, target, False
        real = os.path.realpath

        def realpath(path, *args, **kwargs):
            out = real(path, *args, **kwargs)
            if not self.done and str(path).endswith("/" + name):
                self.done = True
                self.file.unlink()
                self.file.symlink_to(self.target)
            return out

        monkeypatch.setattr(os.path, "realpath", realpath)


class _Page:
    """The Run page's socket without a server: its messages' answers in ``out``."""

    def __init__(self, folder: Path) -> None:
        self.ws = type("WS", (), {})()
        self.ws.app = type("App", (), {})()
        self.ws.app.state = type("State", (), {"studio": StudioState(folder.resolve())})()
        self.sock = run.RunSocket({"type": "websocket"}, None, None)
        self.out: list = []
        self.sock.session, self.sock.folder, self.sock.emit = None, folder.resolve(), self.out.append

    def send(self, doc: dict) -> dict:
        asyncio.run(self.sock.on_message(self.ws, doc))
        return next(m for m in self.out if m.get("type") == "fsm")


def test_a_program_swapped_for_a_link_after_its_check_runs_as_it_was(tmp_path, monkeypatch):
    """Before: Start checked the path (inside), then read it twice by name: swapped for a link
    in between, the run was the program outside the folder."""
    folder, outside = tmp_path / "folder", tmp_path / "outside.hila"
    folder.mkdir()
    (folder / "swap.hila").write_text(INSIDE)
    outside.write_text(OUTSIDE)
    swap = _Swap(monkeypatch, folder, "swap.hila", outside)
    p = _Page(folder)
    try:
        graph = p.send(dict(cmd="start", path="swap.hila", backend="dry"))["graph"]
        assert swap.done  # the swap happened during the start
        compiled = {}
        for name, text in (("in", INSIDE), ("out", OUTSIDE)):
            (tmp_path / f"{name}.hila").write_text(text)
            compiled[name] = run.fsm_graph(Environment.default().load(tmp_path / f"{name}.hila")[1])["nodes"]
        assert compiled["in"] != compiled["out"] and graph["nodes"] == compiled["in"]
        # reload reads it again the same way: the link now in its place is refused, the run goes on
        p.sock.session.repl.onecmd("reload")
        said = "".join(m.get("text", "") for m in p.out if m.get("type") == "out")
        assert "symbolic link" in said and "reload failed" in said
    finally:
        if p.sock.session is not None:
            p.sock.session.close()


def test_a_recording_swapped_for_a_link_after_its_check_is_not_read(tmp_path, monkeypatch):
    """Before: Open checked the recording's path, then read_record read it by name (the link)."""
    from hila_lang.cli import main

    folder = tmp_path / "folder"
    folder.mkdir()
    (tmp_path / "secret.hila").write_text(OUTSIDE)
    assert main(["exec", str(tmp_path / "secret.hila"), "--backend", "dry", "--record", str(tmp_path / "secret.hilarec"),
                 "--out", str(tmp_path / "o1")]) == 0
    (folder / "mine.hila").write_text(INSIDE)
    assert main(["exec", str(folder / "mine.hila"), "--backend", "dry", "--record", str(folder / "mine.hilarec"),
                 "--out", str(tmp_path / "o2")]) == 0
    swap = _Swap(monkeypatch, folder, "mine.hilarec", tmp_path / "secret.hilarec")
    p = _Page(folder)
    try:
        fsm = p.send(dict(cmd="open", path="mine.hilarec"))
        assert "secret" not in (fsm["program"] or "") and fsm["program"] == INSIDE
    finally:
        if p.sock.session is not None:
            p.sock.session.close()
    if not swap.done:  # nothing checked it by name (opened once): the link comes now
        (folder / "mine.hilarec").unlink()
        (folder / "mine.hilarec").symlink_to(tmp_path / "secret.hilarec")
    with pytest.raises(Exception, match="symbolic link"):  # and opening it refuses the link
        files.read_recording(folder, "mine.hilarec")


def test_a_template_swapped_for_a_link_after_its_check_is_not_imported(tmp_path, monkeypatch):
    """Before: the studio's template loader checked an import's path (inside FOLDER), then read it
    by name: swapped for a link in between, the program got the template outside the folder."""
    from hila_lang.osila.template import load_template, save_template
    from hila_lang.studio.security import folder_templates

    folder = tmp_path / "folder"
    folder.mkdir()
    shipped = load_template(Path(__file__).resolve().parents[1] / "primitives" / "circle.yaml")
    save_template(shipped, folder / "mine.yaml")
    secret = shipped.__class__(**{**shipped.__dict__, "icps": {"secret_" + k: v for k, v in shipped.icps.items()}})
    save_template(secret, tmp_path / "secret.yaml")
    loader = folder_templates(folder)
    found = loader.find("mine", False, str(folder / "game.hila"))
    assert found is not None and loader.load(found).icps.keys() == shipped.icps.keys()  # read as it is
    loader = folder_templates(folder)  # nothing remembered
    swap = _Swap(monkeypatch, folder, "mine.yaml", tmp_path / "secret.yaml")
    try:
        got = loader.load(found)
    except Exception as exc:  # the link refused
        assert "symbolic link" in str(exc)
    else:
        assert not any(k.startswith("secret_") for k in got.icps)
    assert swap.done


# ----------------------------------------------------------------------------- 4. a page that goes away


def _descendants(pid: int) -> set[int]:
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            children.setdefault(int(stat.rsplit(")", 1)[1].split()[1]), []).append(int(entry))
    found, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.add(child)
            todo.append(child)
    return found


def _cpu(pid: int) -> int:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return -1
    return int(fields[11]) + int(fields[12])


def _busy(pids, seconds=30.0):
    """The one of ``pids`` that is computing (its CPU time grows), waited for."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        before = {p: _cpu(p) for p in pids}
        time.sleep(0.3)
        busy = [p for p in pids if _cpu(p) - before[p] >= 10]  # 0.1 s of CPU in 0.3 s
        if busy:
            return busy[0]
    raise AssertionError("no worker computed")


@pytest.mark.slow
def test_a_request_whose_page_went_away_stops_its_work(tmp_path):
    """Before: a dropped request's learning ran to its end (or its 60 s budget) in a worker.
    Now the worker computing it is killed when the connection closes; the studio answers on."""
    s = Studio(tmp_path)
    try:
        t = np.arange(12_000) / 20.0
        path = np.column_stack([np.cos(t / 7) * t, np.sin(t / 5) * 3])
        body = json.dumps(dict(path=path.tolist(), times=t.tolist(), k=100, method="kmeans"))  # seconds of work
        small = json.dumps(dict(path=[[i, i % 2] for i in range(8)], times=list(range(8)), k=1))
        assert request(s, "POST", "/api/demonstration", small)[0] == 200  # the workers are up
        workers = _descendants(s.proc.pid)
        conn = http.client.HTTPConnection("127.0.0.1", s.port, timeout=60)
        conn.request("POST", f"/api/demonstration?token={s.token}", body=body, headers={"Host": f"127.0.0.1:{s.port}"})
        busy = _busy(workers)
        conn.sock.shutdown(socket.SHUT_RDWR)  # the tab closed
        conn.close()
        end = time.monotonic() + 10
        while os.path.exists(f"/proc/{busy}") and time.monotonic() < end:
            time.sleep(0.1)
        assert not os.path.exists(f"/proc/{busy}") or _cpu(busy) < 0, "the worker went on computing"
        assert request(s, "GET", "/api/pages")[0] == 200
        status, answer = request(s, "POST", "/api/demonstration", small)
        assert status == 200 and answer["path"], answer  # a new worker took the next request
    finally:
        s.stop()


def test_a_websocket_closed_during_its_work_cancels_it():
    """A socket's answer under way (here 30 s of work in a worker) is cancelled when the page
    closes the socket: the worker is killed, the socket's handler ends at once.  Before: the
    handler read the close only after the answer, at the work's end (or its budget)."""
    started, results = threading.Event(), {}

    class Slow(page.JSONSocket):
        async def on_message(self, websocket, doc):
            started.set()
            try:
                await worker.run(time.sleep, 30)
            except asyncio.CancelledError:
                results["cancelled"] = True
                raise

        async def on_error(self, websocket, doc, text):
            results["error"] = text

    async def go():
        gone = asyncio.Event()
        messages = [{"type": "websocket.connect"}, {"type": "websocket.receive", "text": '{"template": "t"}'}]

        async def receive():
            if messages:
                return messages.pop(0)
            await gone.wait()
            return {"type": "websocket.disconnect", "code": 1001}

        async def send(message):
            pass

        scope = {"type": "websocket", "path": "/ws/imitate", "headers": [], "query_string": b""}
        handler = asyncio.create_task(Slow(scope, receive, send).dispatch())
        while not started.is_set():
            await asyncio.sleep(0.05)
        await asyncio.sleep(1.0)  # the work is under way
        start = time.monotonic()
        gone.set()
        await asyncio.wait_for(handler, 10)
        return time.monotonic() - start

    took = []
    thread = threading.Thread(target=lambda: took.append(asyncio.run(go())))
    try:
        thread.start()
        thread.join(60)
        assert took and took[0] < 2.0 and results.get("cancelled"), (took, results)
    finally:
        worker.stop()


def test_a_run_whose_page_closed_stops_before_its_next_state():
    """The Run page's socket closes its session when the page goes away: a game running on
    stops after the step under way (before: close waited for the whole game to be played)."""
    from studio_support import ROOT

    out: list = []
    session = run.RunSession(ROOT / "programs" / "game.hila", out.append, backend="dry", settings={"opponent": "minimax"})
    run.COMMANDS["run"](session, {})
    end = time.monotonic() + 60
    while session.interp.trace.total < 2 and time.monotonic() < end:  # a step played, the game going on
        time.sleep(0.005)
    start = time.monotonic()
    session.close()
    steps = session.interp.trace.total
    assert time.monotonic() - start < 5 and not session.interp.done
    time.sleep(0.5)
    assert session.interp.trace.total == steps  # nothing runs on


def test_a_call_killed_for_another_is_computed_again():
    """Giving up one call kills its pool; the other call under way there is handed to a new pool
    and still answered (not lost to another page's going away)."""
    async def go():
        slow = asyncio.create_task(worker.run(time.sleep, 30, budget=1.0))
        other = asyncio.create_task(worker.run(sum, [1, 2, 3]))
        kept = await other
        with pytest.raises(Exception, match="budget of 1 s"):
            await slow
        third = asyncio.create_task(worker.run(time.sleep, 0.5))
        await asyncio.sleep(0.1)
        doomed = asyncio.create_task(worker.run(time.sleep, 30, budget=1.5))
        await third  # survives doomed's kill: computed again
        with pytest.raises(Exception, match="budget"):
            await doomed
        return kept

    out = []
    thread = threading.Thread(target=lambda: out.append(asyncio.run(go())))
    try:
        thread.start()
        thread.join(120)
        assert out == [6]
    finally:
        worker.stop()


# ----------------------------------------------------------------------------- 5. staging left by a crash


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_only_hilas_own_stale_staging_folders_are_removed(tmp_path):
    folder, outside = tmp_path / "folder", tmp_path / "outside"
    folder.mkdir()
    outside.mkdir()
    (outside / "0").write_text("the user's")
    dead = _dead_pid()
    stale = folder / f".hila-staging-{dead}-0a1b2c3d4e5f"
    stale.mkdir(mode=0o700)
    (stale / "0").write_text("half a save")
    live = folder / f".hila-staging-{os.getpid()}-0a1b2c3d4e5f"  # a studio beside this one, saving now
    live.mkdir()
    (live / "0").write_text("being written")
    with_folder = folder / f".hila-staging-{dead}-abcdef"  # hila stages files only: not one of its own
    (with_folder / "sub").mkdir(parents=True)
    link = folder / f".hila-staging-{dead}-123456"
    link.symlink_to(outside, target_is_directory=True)
    lookalike = folder / ".hila-staging-notes"
    lookalike.mkdir()
    (lookalike / "0").write_text("mine")
    a_file = folder / f".hila-staging-{dead}-fedcba"
    a_file.write_text("a file, not a folder")
    assert remove_stale_staging(folder) == [stale.name]
    assert not stale.exists() and (live / "0").exists() and (with_folder / "sub").is_dir()
    assert link.is_symlink() and (outside / "0").read_text() == "the user's"
    assert (lookalike / "0").exists() and a_file.read_text() == "a file, not a folder"
    assert staging_name().startswith(f".hila-staging-{os.getpid()}-")


@pytest.mark.slow
def test_a_save_killed_halfway_leaves_nothing_after_the_next_start(tmp_path):
    """A process killed while its save was staged (SIGKILL: nothing runs after it) leaves its
    staging folder; the next ``hila studio`` on the folder removes it and says so.  Before, the
    folder stayed for good."""
    code = ("import os, sys; from pathlib import Path; from hila_lang.studio.files import Transaction\n"
            "t = Transaction(Path(sys.argv[1]), overwrite=False); t.stage('a.hila', 'half')\n"
            "os.kill(os.getpid(), 9)")
    subprocess.run([sys.executable, "-c", code, str(tmp_path)], timeout=60)
    left = [p.name for p in tmp_path.iterdir() if p.name.startswith(".hila-staging-")]
    assert len(left) == 1 and not (tmp_path / "a.hila").exists()
    s = Studio(tmp_path)
    try:
        assert request(s, "GET", "/api/files")[0] == 200
        assert not [p for p in tmp_path.iterdir() if p.name.startswith(".hila-staging-")]
    finally:
        s.stop()
    assert f"removed {left[0]}" in s.proc.stderr.read()


def test_every_lazy_scipy_or_opencv_import_is_made_before_the_studio_serves():
    """The studio's threads (a check, a scene image, a run) import SciPy and OpenCV lazily; two
    threads doing it for the first time at once can find each other's module half imported (a CI
    run's page: "partially initialized module 'scipy._lib._testutils'").  ``serve`` imports
    :data:`THREAD_IMPORTS` first: every package hila imports lazily must be among them (only
    ``hila eval``'s statistics, never run by the studio, are left out)."""
    import re

    from hila_lang.studio import app

    root = Path(__file__).resolve().parents[1] / "hila_lang"
    lazy = set()
    for path in root.rglob("*.py"):
        for m in re.finditer(r"^[ \t]+(?:from\s+(scipy[\w.]*)\s+import|import\s+(cv2|scipy[\w.]*))", path.read_text(), re.M):
            lazy.add(m.group(1) or m.group(2))
    assert {"scipy.spatial", "cv2"} <= lazy  # the scan sees them
    assert lazy - set(app.THREAD_IMPORTS) <= {"scipy.stats"}, lazy - set(app.THREAD_IMPORTS)
    code = (f"import sys\nsys.path.insert(0, {str(root.parent)!r})\n"
            "import threading, importlib\nfrom hila_lang.studio import app\napp.import_for_threads()\n"
            "errors = []\nbarrier = threading.Barrier(len(app.THREAD_IMPORTS))\n"
            "def go(name):\n    barrier.wait()\n    try:\n        importlib.import_module(name)\n"
            "    except Exception as exc:\n        errors.append(repr(exc))\n"
            "threads = [threading.Thread(target=go, args=(n,)) for n in app.THREAD_IMPORTS]\n"
            "[t.start() for t in threads]; [t.join() for t in threads]\nprint(errors)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stdout + out.stderr
