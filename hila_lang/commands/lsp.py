"""``hila lsp``: the language server for editors (stdio)."""

from __future__ import annotations

from ..core.errors import InputError

HELP = "a language server for .hila programs over stdio (diagnostics, hover, definition, completion)"
DESCRIPTION = (
    "Speak the Language Server Protocol on stdin/stdout, for an editor to start: diagnostics as "
    "you type (the errors 'hila check' reports, at the same place), hover (a template's tags and "
    "ICPs, a world's questions and events, a task's parameters), go to definition (tasks, points, "
    "imports to their YAML file) and completion (tags after 'circle.', ICP names inside a run, "
    "ask/wait names of the world), narrowed to the word being typed. Documents over 256,000 "
    "characters get one diagnostic saying so instead. Needs pygls: pip install 'hila-lang[lsp]'. "
    "docs/lsp.md shows how to hook it into VS Code, Neovim and Helix."
)


def add_arguments(parser) -> None:
    pass


def run(args) -> int:
    try:
        # lazy: loads pygls, which importing this module does not
        from ..lsp.server import serve
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.split(".")[0] in ("pygls", "lsprotocol"):
            raise InputError("hila lsp needs pygls, which is not installed",
                             hint="pip install 'hila-lang[lsp]' (or pip install pygls)") from None
        raise
    serve()
    return 0
