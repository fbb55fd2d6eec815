"""Shared helpers of the studio tests: a ``hila studio`` process on a folder, and a browser."""

from __future__ import annotations

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
    """``hila studio FOLDER`` in a child process; ``url`` is its first line's URL."""

    def __init__(self, folder: Path) -> None:
        pytest.importorskip("starlette", reason="hila studio needs the 'studio' extra (starlette, uvicorn)")
        self.folder = folder
        self.proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "studio", str(folder)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env={**os.environ, "PYTHONUNBUFFERED": "1"})
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


def chromium_or_skip():
    exe = shutil.which("chromium")
    if exe is None:
        pytest.skip("Debian's chromium is not installed (apt-get install chromium); .ci/run installs it")
    sync_api = pytest.importorskip("playwright.sync_api", reason="the Python package playwright is not installed")
    return exe, sync_api
