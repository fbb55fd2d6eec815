"""Where hila finds the data files it ships (the grammar)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def grammar_path(name: str = "hila.lark") -> Path:
    """Path of ``grammar/<name>``.

    A regular install carries the grammar inside the package as ``hila_lang.grammar``; an
    editable install (or running from the checkout) finds it in the checkout's ``grammar/``.
    """
    try:
        candidate = Path(str(resources.files("hila_lang.grammar") / name))
        if candidate.is_file():
            return candidate
    except ModuleNotFoundError:
        pass
    candidate = Path(__file__).resolve().parent.parent / "grammar" / name
    if candidate.is_file():
        return candidate
    raise FileNotFoundError(f"grammar file {name!r} is missing from this hila installation")
