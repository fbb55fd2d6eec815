"""Shared helpers of the studio tests: a ``hila studio`` process on a folder, a browser on it.

The browser tests of each page (``tests/test_studio_NAME.py``) take the fixtures :func:`browser`
(Debian's chromium through Playwright, headless, one per module), :func:`studio` (``hila studio``
on a folder holding ``game.hila`` and ``reach.yaml``, one per module) and :func:`page` (a fresh
page on it, loaded, that must end without a script error)."""

from __future__ import annotations

import http.client
import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BROWSER_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                "--disable-sync", "--no-first-run"]


class Studio:
    """``hila studio FOLDER`` in a child process (``env``: more environment, e.g. a PYTHONPATH
    with a plug-in); ``url`` is its first line's URL."""

    def __init__(self, folder: Path, env: dict | None = None) -> None:
        pytest.importorskip("starlette", reason="hila studio needs the 'studio' extra (starlette, uvicorn)")
        self.folder = folder
        self.proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "studio", str(folder)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})})
        self.first_line = self.proc.stdout.readline()
        assert self.first_line.startswith("hila studio: http://127.0.0.1:"), (self.first_line, self.proc.stderr.read())
        self.url = self.first_line.split(": ", 1)[1].strip()
        self.base, self.token = self.url.split("/?token=")
        self.port = int(self.base.rsplit(":", 1)[1])

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        return self.proc.returncode


def request(s: Studio, method: str, path: str, body=None, headers=None, timeout: float = 60):
    """(status, the answer as JSON, or its text) of one request to the studio ``s`` with its token."""
    conn = http.client.HTTPConnection("127.0.0.1", s.port, timeout=timeout)
    sep = "&" if "?" in path else "?"
    conn.request(method, f"{path}{sep}token={s.token}", body=body,
                 headers={"Host": f"127.0.0.1:{s.port}", **(headers or {})})
    r = conn.getresponse()
    text = r.read().decode("utf-8", "replace")
    try:
        return r.status, json.loads(text)
    except ValueError:
        return r.status, text


def chromium_or_skip():
    exe = shutil.which("chromium")
    if exe is None:
        pytest.skip("Debian's chromium is not installed (apt-get install chromium); .ci/run installs it")
    sync_api = pytest.importorskip("playwright.sync_api", reason="the Python package playwright is not installed")
    return exe, sync_api


#: the page has loaded its pages (their modules) and the Demonstrate page its first scene
READY = "window.hilaStudio && window.hilaStudio.demo && window.hilaStudio.demo.scene !== undefined"


def launched(extra_args=()):
    """Debian's chromium, headless, with BROWSER_ARGS and ``extra_args`` (a generator: yields it, then closes it)."""
    exe, sync_api = chromium_or_skip()
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=exe, headless=True, args=BROWSER_ARGS + list(extra_args))
        yield b
        b.close()


def opened(browser, studio, height=1000):
    """A fresh page on ``studio``, loaded (a generator: yields it; then it must have had no script error)."""
    p = browser.new_page(viewport={"width": 1400, "height": height})
    errors = []
    p.on("pageerror", lambda e: errors.append(str(e)))
    p.goto(studio.url)
    p.wait_for_function(READY)
    yield p
    p.close()
    assert not errors, errors


@pytest.fixture(scope="module")
def browser():
    yield from launched()


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
    yield from opened(browser, studio)


def plane_to_pixel(page, H, p):
    """The page's own map from the plane to the picture (common.js's applyH), not a copy of it."""
    return page.evaluate("async ([H, p]) => (await import('/static/common.js')).applyH(H, p[0], p[1])", [H, list(p)])


def click_at(page, testid, u, v):
    box = page.get_by_test_id(testid).bounding_box()
    page.mouse.click(box["x"] + u, box["y"] + v)


def wait_status(page, predicate: str, timeout=60000):
    """Wait until the Run page's last snapshot ``s`` satisfies ``predicate`` (JavaScript)."""
    page.wait_for_function(f"(() => {{ const s = window.hilaStudio.run.state; return s && ({predicate}); }})()",
                           timeout=timeout)
