"""``hila exec PROGRAM``: run a program to the end on a back end (dry or pybullet)."""

from __future__ import annotations

from ..language.runopts import add_run_arguments, run_options

HELP = "run a .hila program (dry kinematic back end or the PyBullet iCub)"
DESCRIPTION = (
    "Run a program: each FSM state warps one sub-template onto the scene with OSILA and moves the "
    "hand. Prints one line per state (unless --quiet); exit 1 if the run fails."
)


def add_arguments(parser) -> None:
    from ..plugins.registry import settings_help

    add_run_arguments(parser)
    parser.epilog = settings_help()
    parser.add_argument("--trace", default=None, metavar="FILE", help="write the state trace to FILE")
    parser.add_argument("--quiet", action="store_true", help="do not print the state trace")


def run(args) -> int:
    from ..fileio import atomic_write_text
    from ..language.runner import finish, prepare

    options = run_options(args)
    interp = prepare(args.program, options, args.backend)
    lines: list[str] = []
    try:
        while not interp.done:
            entry = interp.step()
            lines.append(str(entry))
            if not args.quiet:
                print(lines[-1], file=options.stdout, flush=True)
    finally:
        if args.trace:
            atomic_write_text(args.trace, "\n".join(lines) + "\n")
    finish(interp)
    return 0
