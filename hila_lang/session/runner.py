"""Wire a program to its world and back end for ``hila exec`` and ``hila repl``.

``prepare(path, options, backend=None)`` loads, checks and compiles the program with the run's
``--set`` pairs and back end (so every setting is split and parsed, and the program's questions,
events and points checked against what the world declares, before anything is built:
:func:`hila_lang.plugins.options.split_settings`, :mod:`hila_lang.language.worldcheck`), looks
up the world it names (``world NAME``, default ``scripted``), the robot (``--robot``,
:func:`hila_lang.robot.spec.resolve`; default the iCub) and the back end (``--backend``,
else the world's ``default_backend``) in the registry (:mod:`hila_lang.plugins.registry`),
builds the world, then the back end on the world's scene, attaches them, and returns an
:class:`~hila_lang.engine.interpreter.Interpreter`.  ``--out DIR`` works in every world: one
that writes no output folder of its own gets the run's picture and report
(:mod:`hila_lang.session.runout`), written when the run ends.  :func:`finish` ends the run;
:func:`finishing` ends it also when it fails.
"""

from __future__ import annotations

import contextlib
import sys

from ..core.interrupts import guarded
from ..engine.interpreter import Interpreter
from ..language.environment import Environment
from ..language.limits import DEFAULT_STEP_LIMIT
from ..language.source import source_line
from ..plugins import registry
from ..plugins.options import RunOptions
from .runout import run_outputs


def prepare(path, options: RunOptions, backend: str | None = None, *,
            step_limit: int | None = DEFAULT_STEP_LIMIT, env: Environment | None = None,
            text: str | None = None) -> Interpreter:
    """Program + world + back end -> a ready :class:`Interpreter` (at its start state);
    ``step_limit`` bounds each run (:data:`~hila_lang.language.limits.DEFAULT_STEP_LIMIT`);
    ``env`` (default: the process's) finds its templates (the studio's keeps them in its folder);
    ``text``: the program's text, already read (the studio reads it once, inside its folder), so
    ``path`` only names it and places its imports."""
    checked, fsm = (env or Environment.default()).load(path, text, settings=options.settings, backend=backend)
    if options.robot is None:
        # lazy: only this branch needs it
        from ..robot.spec import resolve

        options.robot = resolve(options.settings.get("robot"), options.settings)  # --robot, --set robot.KEY
    world_info = registry.world(checked.world)
    backend_info = registry.backend(backend or world_info.default_backend)
    osila, world_settings, backend_settings = checked.run_settings
    world = world_info.build(options, world_settings)

    outputs = run_outputs(world, options)  # --out for a world that writes none: made and proved writable now
    be = backend_info.build(world.scene, options, backend_settings)
    try:
        world.attach(be)
        interp = Interpreter(checked, fsm, world, be, osila, step_limit=step_limit)
        interp.run_outputs = None if outputs is None else (outputs, options.seed, options.stdout)
        if be.view is not None:
            show_states(interp)
        return interp
    except BaseException:
        be.close()
        raise


def show_states(interp: Interpreter) -> None:
    """Tell the back end's view (a window) each state as it starts: its name and program line."""
    def show(name: str | None) -> None:
        if name is None:
            interp.backend.view.show_state("finished", "")
            return
        st = interp.fsm.states[name]
        text = (source_line(interp.checked.program.source, st.line) or "").split("#")[0].strip() if st.line else ""
        interp.backend.view.show_state(name, f"{interp.fsm.file}:{st.line}  {text}" if st.line else "")

    show(interp.current)
    interp.observers.append(lambda entry: show(entry.next))


def finish(interp: Interpreter):
    """``world.finish(trace, fsm=FSM)`` (its summary, or None), then close the back end.
    A first Ctrl-C while the world saves its outputs waits until they are saved."""
    try:
        with guarded() as guard:
            guard.hold()
            summary = interp.world.finish(interp.trace, fsm=interp.fsm)
            outputs = getattr(interp, "run_outputs", None)
            if outputs is not None:
                # lazy: only this branch needs it
                from .runout import write_run_outputs

                folder, seed, stdout = outputs
                write_run_outputs(folder, interp, seed, stdout)
            return summary
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
