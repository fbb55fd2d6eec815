"""The tutorial (docs/tutorial.md, issue 23 item 4) works as written: every ``$ `` command of its
``console`` blocks is run exactly as written, in order, by bash in a copy of what it needs; the
output lines the page shows must be lines of what the command printed; a command that the page
says exits with a status (``# exit status N``) must, every other one must succeed."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "tutorial.md"


def commands(text: str) -> list[tuple[str, list[str], int]]:
    """``(command, shown output lines, expected exit status)`` of every console block, in order;
    a heredoc (``<<'EOF'``) is part of its command up to its ``EOF`` line."""
    out = []
    for block in re.findall(r"```console\n(.*?)```", text, flags=re.S):
        lines = block.splitlines()
        i = 0
        while i < len(lines):
            line = lines[i]
            assert line.startswith("$ "), f"output before any command in a console block: {line!r}"
            command = [line[2:]]
            i += 1
            end = re.search(r"<<'(\w+)'", line)
            while end and i < len(lines):
                command.append(lines[i])
                i += 1
                if command[-1] == end.group(1):
                    break
            shown = []
            while i < len(lines) and not lines[i].startswith("$ "):
                shown.append(lines[i])
                i += 1
            status = re.search(r"# exit status (\d+)$", line)
            out.append(("\n".join(command), shown, int(status.group(1)) if status else 0))
    return out


def test_the_page_has_the_steps_the_issue_asks_for():
    steps = [c for c, _, _ in commands(PAGE.read_text())]
    assert any(c.startswith("hila learn primitives/letters/demos/") and ".csv" in c for c in steps)
    assert any(c.startswith("hila show ") for c in steps) and any(c.startswith("hila check ") for c in steps)
    assert any(c.startswith("hila exec ") and "--out" in c for c in steps)
    program = next(c for c in steps if c.startswith("cat > mine.hila"))
    body = program.splitlines()[1:-1]
    assert len(body) == 5 and " via (" in program  # five lines, a via point


@pytest.mark.slow
def test_the_tutorials_commands_run_as_written(tmp_path):
    shutil.copytree(ROOT / "primitives", tmp_path / "primitives")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
           "HILA_PATH": ""}
    for command, shown, status in commands(PAGE.read_text()):
        done = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=300)
        printed = (done.stdout + done.stderr).splitlines()
        assert done.returncode == status, f"{command}\n{done.stdout}\n{done.stderr}"
        for line in shown:
            assert line in printed, f"{command}: the page shows {line!r}, the command printed:\n" + "\n".join(printed)
        assert "Traceback" not in done.stderr
    import cv2

    picture = cv2.imread(str(tmp_path / "out" / "path.png"))  # "look at the picture"
    assert picture is not None and picture.shape[1] > 600
    assert (tmp_path / "out" / "report.json").is_file()
