"""Outside the checkout (issue 13): an installed hila carries its templates and programs and finds
them from any folder.

The checkout is built into a wheel and installed into a folder of its own; the commands then run
from another folder, with Python's site-packages on the path only for the dependencies (``-S``:
no editable install of the checkout is in the way).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("install")
    wheels, site, source = tmp / "wheels", tmp / "site", tmp / "source"
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "build", "runs", "demos")
    for part in ("hila_lang", "grammar", "primitives", "programs"):  # built from a copy: no build/ in the checkout
        shutil.copytree(ROOT / part, source / part, ignore=ignore)
    for part in ("setup.py", "pyproject.toml", "README.md"):
        shutil.copy(ROOT / part, source / part)
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", str(source), "-w", str(wheels)],
                           capture_output=True, text=True, timeout=900)
    assert build.returncode == 0, build.stderr[-3000:]
    install = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(site),
                              *map(str, wheels.glob("*.whl"))], capture_output=True, text=True, timeout=600)
    assert install.returncode == 0, install.stderr[-3000:]
    elsewhere = tmp / "elsewhere"
    elsewhere.mkdir()
    # the dependencies: every site-packages folder this Python sees (a venv made with
    # --system-site-packages has them in the base Python's); their .pth files are not read under -S,
    # so an editable install of the checkout stays out of the way
    deps = [sysconfig.get_paths()["purelib"], *(p for p in sys.path if Path(p).name in ("site-packages", "dist-packages"))]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), *dict.fromkeys(deps)])}
    env.pop("HILA_PATH", None)

    def hila(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-S", "-m", "hila_lang", *args], cwd=elsewhere, env=env,
                              capture_output=True, text=True, timeout=600)

    return site, elsewhere, hila


@pytest.mark.slow
def test_the_package_carries_its_templates_programs_and_grammar(installed):
    site, _, _ = installed
    package = site / "hila_lang"
    assert (package / "grammar" / "hila.lark").is_file()
    assert {p.name for p in (package / "programs").glob("*.hila")} == {p.name for p in (ROOT / "programs").glob("*.hila")}
    assert {p.name for p in (package / "primitives").glob("*.yaml")} == {p.name for p in (ROOT / "primitives").glob("*.yaml")}
    assert len(list((package / "primitives" / "letters").glob("*.yaml"))) == 26
    assert {p.name for p in (package / "robot" / "robots").glob("*.yaml")} == {"panda.yaml", "kuka.yaml"}


def test_the_shipped_robots_are_found_from_any_folder(installed):
    _, _, hila = installed
    probe = hila("check", "game.hila", "--robot", "kuka")  # the spec read from the installed package
    assert probe.returncode == 0, probe.stderr


@pytest.mark.slow
def test_the_shipped_game_runs_from_any_folder(installed):
    site, elsewhere, hila = installed
    out = hila("exec", "game.hila", "--backend", "dry", "--quiet", "--out", "g")
    assert out.returncode == 0, out.stderr
    assert "result: " in out.stdout and (elsewhere / "g" / "report.json").is_file()
    probe = hila("check", "game.hila")
    assert probe.stdout.startswith(str(site / "hila_lang" / "programs" / "game.hila") + ": ok")


def test_a_program_by_path_and_an_import_by_name_from_any_folder(installed):
    _, elsewhere, hila = installed
    out = hila("exec", str(ROOT / "programs" / "abc.hila"), "--quiet")
    assert out.returncode == 0, out.stderr
    (elsewhere / "x.hila").write_text("world tictactoe\nimport circle\nmain { let c = ask best_move\n"
                                      "  run circle.reach(c.*, hand = arm.lift, start = none) }\n")
    out = hila("check", "x.hila")  # circle.yaml: installed with the package
    assert out.returncode == 0 and out.stdout.startswith("x.hila: ok"), out.stderr
