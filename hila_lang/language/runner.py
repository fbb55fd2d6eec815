"""Wire a program to its world and back end for ``hila exec`` and ``hila repl``.

``prepare(path, options, backend=None)`` loads and compiles the program, builds the world the
program names (``world NAME``, default ``scripted``) and the back end (``--backend``, else the
world's ``default_backend``, else ``dry``), attaches them, and returns an
:class:`~hila_lang.language.interpreter.Interpreter`.  ``--set osila.KEY=VALUE`` settings are
passed to :func:`hila_lang.osila.imitate` (values parsed as YAML scalars: ``0.002``, ``true``).
"""

from __future__ import annotations

from ..errors import InputError
from . import load_program
from .interpreter import Interpreter
from .plugins import RunOptions, make_backend, make_world


def osila_options(settings: dict[str, str]) -> dict:
    """``{"osila.threshold": "0.002"}`` -> ``{"threshold": 0.002}``."""
    import yaml

    from ..osila import OPTIONS

    out = {}
    for key, text in settings.items():
        if key.startswith("osila."):
            if key[6:] not in OPTIONS:
                import difflib

                close = difflib.get_close_matches(key[6:], OPTIONS, n=1)
                raise InputError(f"unknown OSILA option {key[6:]!r} in --set {key}; known: {', '.join(OPTIONS)}",
                                 hint=f"did you mean 'osila.{close[0]}'?" if close else None)
            try:
                out[key[6:]] = yaml.safe_load(text)
            except yaml.YAMLError:
                raise InputError(f"cannot read --set {key}={text}: expected a number, true/false or a list") from None
    return out


def prepare(path, options: RunOptions, backend: str | None = None) -> Interpreter:
    """Program + world + back end -> a ready :class:`Interpreter` (at its start state)."""
    checked, fsm = load_program(path)
    world = make_world(checked.world, options)
    be = make_backend(world, options, backend)
    return Interpreter(checked, fsm, world, be, osila_options(options.settings))


def finish(interp: Interpreter):
    """``world.finish(trace, fsm=FSM)`` if the world has it (its dict, or None), then close the back end."""
    try:
        fin = getattr(interp.world, "finish", None)
        return fin(interp.trace, fsm=interp.fsm) if callable(fin) else None
    finally:
        close = getattr(interp.backend, "close", None)
        if callable(close):
            close()
