"""``hila exec PROGRAM``: run a program to the end on a back end (dry or pybullet)."""

from __future__ import annotations

import sys

from ..core.argtypes import output_path
from ..core.fileio import AtomicFile
from ..session.runopts import add_run_arguments, run_options

HELP = "run a .hila program (dry kinematic back end or the PyBullet iCub)"
DESCRIPTION = (
    "Run a program: each FSM state warps one sub-template onto the scene with OSILA and moves the "
    "hand. Prints one line per state (unless --quiet); exit 1 if the run fails, 130 if Ctrl-C "
    "stops it. Output paths (--out, --trace) are checked before anything runs; the world saves "
    "what was done and --trace is written even when the run fails or is stopped (its last line "
    "is the state that failed)."
)


def add_arguments(parser) -> None:
    add_run_arguments(parser)
    parser.add_argument("--trace", type=output_path, default=None, metavar="FILE",
                        help="write the state trace to FILE (also when the run fails: its last line is the failing state)")
    parser.add_argument("--quiet", action="store_true", help="do not print the state trace")
    parser.add_argument("--record", type=output_path, default=None, metavar="FILE.hilarec",
                        help="record the run in one file (program, templates, settings, every step with its "
                             "paths): 'hila replay FILE' steps through it, 'hila replay --verify FILE' re-runs it")
    parser.add_argument("--record-eyes", action="store_true",
                        help="with --record: keep the left eye's image after each run state (PyBullet)")


def run(args) -> int:
    # lazy: loads numpy, which importing this module does not
    from ..session.recording import start_recording
    from ..session.runner import finishing, prepare

    options = run_options(args)
    trace = AtomicFile(args.trace) if args.trace else None  # a bad --trace path: refused now
    try:
        record = start_recording(args, options)  # before the world takes stdin: a person's moves are kept
        interp = prepare(args.program, options, args.backend, step_limit=args.max_steps)
    except BaseException:
        if trace is not None:
            trace.discard()
        raise
    recorder = record(interp) if record else None
    if trace is not None:  # streamed: memory stays flat however long the run
        interp.observers.append(lambda entry: trace.write(f"{entry}\n"))
    show = None if args.quiet else (lambda entry: print(entry, file=options.stdout, flush=True))
    try:
        with finishing(interp):
            interp.run(each=show)
    finally:
        error = sys.exc_info()[1]
        try:  # each is saved even when the other cannot be (a full disk)
            if recorder is not None:
                recorder.close(error)
        finally:
            if trace is not None:
                trace.commit()
    return 0
