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
    parser.add_argument("--record", default=None, metavar="FILE.hilarec",
                        help="record the run in one file (program, templates, settings, every step with its "
                             "paths): 'hila replay FILE' steps through it, 'hila replay --verify FILE' re-runs it")
    parser.add_argument("--record-eyes", action="store_true",
                        help="with --record: keep the left eye's image after each run state (PyBullet)")


def run(args) -> int:
    from ..fileio import atomic_write_text
    from ..language.runner import finish, prepare

    from ..language.recording import start_recording

    options = run_options(args)
    record = start_recording(args, options)  # before the world takes stdin: a person's moves are kept
    interp = prepare(args.program, options, args.backend)
    recorder = record(interp) if record else None
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
        if recorder is not None:
            import sys

            recorder.close(sys.exc_info()[1])
    finish(interp)
    return 0
