"""The README fits in a head (issue 23 item 5): its first screen says what hila is, gives the two
set-up commands exactly, links the tutorial and shows a picture; the reference material moved to
``docs/`` pages, every one linked from the README, every relative link of the pages resolving."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
#: a first screen: what a terminal or a repository page shows before scrolling
FIRST_SCREEN = 40
SETUP = ("python3 -m venv .venv && . .venv/bin/activate && pip install . && hila exec programs/game.hila",
         "python3 -m venv .venv && . .venv/bin/activate && pip install '.[test,ros]' && "
         "pip install --force-reinstall --no-deps 'lark>=1.1,<2' && pytest -n 2 && pytest -m slow -n 2")
#: every section the README had before issue 23, and the page that holds it now
MOVED = {
    "Tic-tac-toe: `hila exec programs/game.hila`": "worlds.md",
    "Writing a word: `hila exec programs/write.hila`": "worlds.md",
    "The hila language": "language.md",
    "Recording and replaying a run": "recordings.md",
    "A window: `--gui`": "robot.md",
    "An editor that understands .hila: `hila lsp`": "editors.md",
    "Templates and imitation (OSILA / HILA)": "osila.md",
    "Does one demonstration help? `hila eval`": "eval-tables.md",
    "The simulated iCub (PyBullet)": "robot.md",
    "Perception: learning through the iCub's eyes": "robot.md",
    "Benchmarks": "benchmarks.md",
    "Worlds and back ends are plug-ins": "worlds.md",
    "Layout": "layout.md",
}


def test_ci_runs_the_readme_test_command_whole():
    """.ci/run installs what the README's test command installs and runs both its pytest parts (the
    whole suite: the slow tests too), so a step the README forgets fails CI."""
    readme_steps = SETUP[1].split(" && ")[2:]
    ci = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
          if line.strip() and not line.lstrip().startswith("#")]
    ci_steps = []
    for line in ci:
        if line.startswith("python -m pip install") and "--upgrade pip" not in line:
            ci_steps.append("pip install " + line.split("--quiet ", 1)[1])
        elif line.startswith("pytest "):
            ci_steps.append(" ".join(w for w in line.split() if w not in ("-q", "-p", "no:cacheprovider")))
    assert ci_steps == readme_steps


def test_the_first_screen_holds_what_hila_is_the_setup_the_tutorial_and_a_picture():
    head = "\n".join(README.read_text().splitlines()[:FIRST_SCREEN])
    assert head.startswith("# hila\n") and "ONE human demonstration" in head
    for command in SETUP:
        assert f"```sh\n{command}\n```" in head
    assert "(docs/tutorial.md)" in head
    images = re.findall(r"!\[[^\]]+\]\(([^)]+\.png)\)", head)
    assert images and all((ROOT / i).is_file() for i in images)


def test_the_gui_setup_notes_say_it_needs_a_display_and_where_xvfb_run_comes_from():
    text = README.read_text()
    assert "X display" in text and "xvfb-run" in text and "`xvfb` package" in text


def test_every_moved_section_is_on_a_page_the_readme_links():
    text = README.read_text()
    for heading, page in MOVED.items():
        assert f"## {heading}\n" in (ROOT / "docs" / page).read_text(), heading
        assert f"(docs/{page})" in text, page
    for page in ("studio", "scene-matching", "evaluation", "recognition", "limits", "lsp"):  # the new pages
        assert f"(docs/{page}.md)" in text, page


def test_the_relative_links_of_the_readme_and_the_pages_resolve():
    pages = [README, *sorted((ROOT / "docs").glob("*.md"))]
    for page in pages:
        for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", page.read_text()):
            assert (page.parent / target).exists(), f"{page.name}: {target}"


#: the folders of a clone a page may name a path in
CLONE_FOLDERS = ("programs", "primitives", "hila_lang", "bench", "tests", "docs", "grammar")


def _pages():
    return [README, *sorted((ROOT / "docs").glob("*.md"))]


def test_every_path_the_pages_name_is_in_a_clone():
    """A path in backticks (`programs/game.hila`, `hila_lang/worlds/tictactoe/`) is where a clone
    has it; placeholders (NAME, <N>, *, {...}) and paths under a run's own folders are skipped."""
    missing = []
    for page in _pages():
        for token in re.findall(r"`([^`\s]+)`", page.read_text()):
            token = token.split(":")[0].split("#")[0].rstrip(".,;)")
            if not token.startswith(tuple(f"{f}/" for f in CLONE_FOLDERS)):
                continue
            if re.search(r"[A-Z]{2,}|[<>*{}$]|\.\.\.", token):
                continue
            if not (ROOT / token).exists():
                missing.append(f"{page.name}: {token}")
    assert missing == []


def test_every_install_command_installs_the_clone_with_an_extra_it_declares():
    """``pip install`` in the pages installs ``.`` or ``'.[EXTRA]'`` (the README's form), with
    extras ``pyproject.toml`` declares: not a package name a clone does not have."""
    import tomllib

    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])
    wrong = []
    for page in _pages():
        for args in re.findall(r"pip install ([^\n`]+)", page.read_text()):
            first = args.split()[0]
            if first.startswith(("-", "'.", '".', ".")) or first in ("-e",):
                named = re.findall(r"\.\[([\w,-]+)\]", first)
                if all(e in extras for n in named for e in n.split(",")):
                    continue
            if page.name in ("robot.md", "studio.md", "README.md") and first in ("xvfb",):
                continue
            wrong.append(f"{page.name}: pip install {args.strip()}")
    assert wrong == []


def test_the_code_cites_only_files_and_design_sections_the_repository_has():
    """A docstring or comment that points elsewhere points into the repository: a page that exists
    (a page under ``docs/``, ``README.md``), a section of ``docs/design.md`` that exists (``§N``), never a
    design file the project does not carry nor a path on someone's machine."""
    design = (ROOT / "docs" / "design.md").read_text()
    sections = set(re.findall(r"^#{2,3} (\d+(?:\.\d+)?)[. ]", design, re.M))
    assert {"2.2", "3", "5", "6"} <= sections
    outside = ("DESIGN" + ".md", "DESIGN §", "STYLE" + ".md", "/work/", "seed/000")
    files = [p for folder in ("hila_lang", "bench", "tests") for p in sorted((ROOT / folder).rglob("*.py"))]
    assert len(files) > 200
    for path in files:
        text = path.read_text()
        name = path.relative_to(ROOT)
        for cited in re.findall(r"docs/design\.md\s*§\s*(\d+(?:\.\d+)?)", text):
            assert cited in sections, f"{name} cites docs/design.md §{cited}, which it does not have"
        for page in re.findall(r"(?<![\w/.-])((?:docs/)?[\w-]+\.md)\b", text):
            assert (ROOT / page).is_file() or (ROOT / "docs" / page).is_file(), f"{name} cites {page}"
        for word in outside:
            assert word not in text or path.name == "test_readme.py", f"{name} cites {word!r}, outside the repository"
