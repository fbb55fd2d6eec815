"""The studio's one door to the language's front end (parse, check, compile).

Every parse/check/compile the studio asks for goes through :func:`analyse`, so that when the
shared front end (one ``Environment`` for ``check``, the REPL and the LSP) lands, this one
function is switched over and the page cannot disagree with ``hila check`` or ``hila lsp``.
Today it is ``hila lsp``'s own analysis (:class:`hila_lang.lsp.analysis.Document`): the same
located problems an editor shows.  Runs load their program through the engine
(:func:`hila_lang.session.runner.prepare`, the REPL's ``reload``), not here.
"""

from __future__ import annotations

from pathlib import Path


def analyse(path: Path, text: str) -> dict:
    """The program ``text`` (as if saved at ``path``: imports resolve beside it) as the page needs it:
    ``problems``, each ``{line, character, end_line, end_character, message, severity}``
    (0-based, as in LSP), and ``settings``, the names of the settings its world declares (the
    page offers an opponent only to a world that has one)."""
    from ..lsp.analysis import Document

    doc = Document(str(path))
    problems = [dict(line=p.line, character=p.character, end_line=p.end_line, end_character=p.end_character,
                     message=p.message, severity=p.severity) for p in doc.analyse(text)]
    world = doc.world() if getattr(doc, "items", None) is not None else None
    return dict(problems=problems, settings=[s.name for s in world.settings] if world is not None else [])
