"""Wire a program to its world and back end for ``hila exec`` and ``hila repl``.

``prepare(path, options, backend=None)`` loads and compiles the program, looks up the world it
names (``world NAME``, default ``scripted``) and the back end (``--backend``, else the world's
``default_backend``) in the registry (:mod:`hila_lang.plugins.registry`), splits and parses every
``--set`` before anything is built (``osila.KEY`` -> :func:`hila_lang.osila.imitate`, values as
YAML scalars: ``0.002``, ``true``; the world's and the back end's own settings through their
declarations; any other key is refused with "did you mean"), builds the world, then the back end
on the world's scene, attaches them, and returns an
:class:`~hila_lang.language.interpreter.Interpreter`.  :func:`finish` ends the run;
:func:`finishing` ends it also when it fails.
"""

from __future__ import annotations

import contextlib
import difflib
import sys

from ..errors import InputError
from ..plugins import registry
from ..plugins.options import RunOptions
from . import load_program
from .interpreter import Interpreter
from .limits import DEFAULT_STEP_LIMIT


def osila_options(settings: dict[str, str]) -> dict:
    """``{"osila.threshold": "0.002"}`` -> ``{"threshold": 0.002}`` (other keys are ignored)."""
    import yaml

    from ..osila import OPTIONS

    out = {}
    for key, text in settings.items():
        if key.startswith("osila."):
            if key[6:] not in OPTIONS:
                close = difflib.get_close_matches(key[6:], OPTIONS, n=1)
                raise InputError(f"unknown OSILA option {key[6:]!r} in --set {key}; known: {', '.join(OPTIONS)}",
                                 hint=f"did you mean 'osila.{close[0]}'?" if close else None)
            try:
                out[key[6:]] = yaml.safe_load(text)
            except yaml.YAMLError:
                raise InputError(f"cannot read --set {key}={text}: expected a number, true/false or a list") from None
    return out


def split_settings(settings: dict[str, str], world, backend) -> tuple[dict, dict, dict]:
    """``--set`` pairs -> (OSILA options, the world's settings, the back end's), each parsed."""
    world_keys = {s.name for s in world.settings}
    backend_keys = {s.name for s in backend.settings}
    mine: dict[str, dict[str, str]] = {"world": {}, "backend": {}}
    for key, text in settings.items():
        if key.startswith("osila."):
            continue
        if key in world_keys:
            mine["world"][key] = text
        elif key in backend_keys:
            mine["backend"][key] = text
        else:
            known = sorted(world_keys | backend_keys)
            close = difflib.get_close_matches(key, known, n=1)
            raise InputError(
                f"unknown setting {key!r} for world {world.name!r} and back end {backend.name!r}; known: "
                + ", ".join([*known, "osila.OPTION"]),
                hint=f"did you mean {close[0]!r}?" if close else None)
    return osila_options(settings), world.parse(mine["world"]), backend.parse(mine["backend"])


def prepare(path, options: RunOptions, backend: str | None = None, *,
            step_limit: int | None = DEFAULT_STEP_LIMIT) -> Interpreter:
    """Program + world + back end -> a ready :class:`Interpreter` (at its start state);
    ``step_limit`` bounds each run (:data:`~hila_lang.language.limits.DEFAULT_STEP_LIMIT`)."""
    checked, fsm = load_program(path)
    world_info = registry.world(checked.world)
    backend_info = registry.backend(backend or world_info.default_backend)
    osila, world_settings, backend_settings = split_settings(options.settings, world_info, backend_info)
    world = world_info.build(options, world_settings)
    be = backend_info.build(world.scene, options, backend_settings)
    try:
        world.attach(be)
        return Interpreter(checked, fsm, world, be, osila, step_limit=step_limit)
    except BaseException:
        be.close()
        raise


def finish(interp: Interpreter):
    """``world.finish(trace, fsm=FSM)`` (its summary, or None), then close the back end.
    A first Ctrl-C while the world saves its outputs waits until they are saved."""
    from ..interrupts import guarded

    try:
        with guarded() as guard:
            guard.hold()
            return interp.world.finish(interp.trace, fsm=interp.fsm)
    finally:
        interp.backend.close()


@contextlib.contextmanager
def finishing(interp: Interpreter, stderr=None):
    """:func:`finish` after the block, also when the run in it failed or was interrupted: the
    world saves what was done (a game stopped at move 5 keeps its first 5 moves).  A failure
    while saving after a failed run is reported as a note; the run's own error is raised."""
    try:
        yield interp
    except BaseException:
        try:
            finish(interp)
        except Exception as late:  # noqa: BLE001 - the run's own error is what the user must see
            print(f"note: saving the outputs of the failed run failed too: {late}", file=stderr or sys.stderr)
        raise
    finish(interp)
