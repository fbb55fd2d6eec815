"""Where hila finds what it ships (the grammar, the learned templates, the example programs) and
the search path of programs and templates.

The checkout keeps ``grammar/``, ``primitives/`` and ``programs/`` at its top, where people look
for them; an install carries them inside the package as ``hila_lang.grammar``,
``hila_lang.primitives`` and ``hila_lang.programs`` (``setup.py``), so an installed ``hila``
finds them through the package (``__path__``) whether the install is editable or not, from any
folder.

The search path (``HILA_PATH`` is a list of folders, separated by ``:`` -- ``;`` on Windows):

- a program named on the command line (``hila exec game.hila``): the path as given (from the
  current folder), then each ``HILA_PATH`` folder and its ``programs/``, then the package's own
  programs;
- a template imported by name (``import circle``): each ``HILA_PATH`` folder and its
  ``primitives/``, then the program's folder, its ``primitives/`` and ``../primitives/`` (a
  checkout's layout), then the package's own templates.
"""

from __future__ import annotations

import importlib
import os
import sys
from pathlib import Path

#: what hila ships, by package name -> the checkout's folder
SHIPPED = {"grammar": "grammar", "primitives": "primitives", "programs": "programs"}


def shipped(kind: str) -> Path | None:
    """The folder of what hila ships of ``kind`` (``"grammar"``, ``"primitives"``,
    ``"programs"``): inside the installed package, else the checkout's; None when missing."""
    try:  # a namespace package (a folder of data): its first folder that exists
        folders = list(getattr(importlib.import_module(f"hila_lang.{kind}"), "__path__", []))
    except ModuleNotFoundError:
        folders = []
    folders.append(Path(__file__).resolve().parents[2] / SHIPPED[kind])  # the checkout: hila_lang/core/ is 2 down
    return next((Path(f) for f in folders if Path(f).is_dir()), None)


def grammar_path(name: str = "hila.lark") -> Path:
    """Path of ``grammar/<name>``."""
    folder = shipped("grammar")
    if folder is not None and (folder / name).is_file():
        return folder / name
    raise FileNotFoundError(f"grammar file {name!r} is missing from this hila installation")


def hila_path() -> list[Path]:
    """The folders of the ``HILA_PATH`` environment variable, in order (empty entries skipped)."""
    return [Path(p).expanduser() for p in os.environ.get("HILA_PATH", "").split(os.pathsep) if p.strip()]


def _unique(folders) -> list[Path]:
    seen, out = set(), []
    for f in folders:
        if f is not None and f not in seen:
            seen.add(f)
            out.append(f)
    return out


def program_search_path() -> list[Path]:
    """Folders a program given by a relative path is looked up in after the current folder."""
    return _unique([q for p in hila_path() for q in (p, p / "programs")] + [shipped("programs")])


def find_program(name: str | os.PathLike) -> Path:
    """The program ``name`` names: the path as given if it exists, else the first match along
    :func:`program_search_path` (a relative name only); else the path as given (reading it
    then says it is not found)."""
    given = Path(name)
    if given.exists() or given.is_absolute():
        return given
    for folder in program_search_path():
        if (folder / given).is_file():
            return folder / given
    return given


def template_search_path(program_file: str | None) -> list[Path]:
    """Folders ``import NAME`` looks in for ``NAME.yaml``, in order (see the module docstring);
    ``program_file`` is the importing program's path (``"<...>"`` or None: the current folder)."""
    here = (Path(program_file).resolve().parent if program_file and not str(program_file).startswith("<")
            else Path.cwd())
    return _unique([q for p in hila_path() for q in (p, p / "primitives")]
                   + [here, here / "primitives", here.parent / "primitives", shipped("primitives")])


def usable_cores() -> int:
    """The CPU cores this process may run on (its affinity), at least 1."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(os.cpu_count() or 1, 1)


def clamp_jobs(jobs: int, stderr=None) -> int:
    """``jobs`` worker processes, at most the cores this process may use (-1: all of them); more
    would only share the same cores and each worker holds its own copy of the data (about
    200 MB in ``hila eval``).  A clamped value is said on ``stderr`` (issue 20: ``--jobs
    1000000`` was a ValueError from a library)."""
    cores = usable_cores()
    if jobs == -1 or jobs <= cores:
        return jobs
    print(f"note: --jobs {jobs} is more than the {cores} cores this process may use; using {cores}",
          file=stderr or sys.stderr)
    return cores
