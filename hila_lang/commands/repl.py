"""``hila repl PROGRAM``: step a program's state machine interactively (or from piped stdin)."""

from __future__ import annotations

from ..session.runopts import add_run_arguments, run_options

HELP = "step a .hila program state by state (step, run, break, where, icps, explain, back, reload, ...)"
DESCRIPTION = (
    "An interactive stepper over the program's FSM. Commands: step [n], run, break STATE, "
    "continue, where, icps, explain, vars, path [--plot FILE.png], fsm, back [n] (undo steps: the "
    "world and the simulator are restored), reload (the edited program and templates, from the "
    "same state), reset, help, quit. Reads piped stdin too."
)


def add_arguments(parser) -> None:
    add_run_arguments(parser)


def run(args) -> int:
    # lazy: loads numpy, which importing this module does not
    from ..session.repl import Repl
    from ..session.runner import finish, prepare

    options = run_options(args)
    interp = prepare(args.program, options, args.backend, step_limit=args.max_steps)
    repl = Repl(interp, stdin=options.stdin, stdout=options.stdout)
    try:
        repl.cmdloop()
    finally:
        finish(interp)
    return 0
