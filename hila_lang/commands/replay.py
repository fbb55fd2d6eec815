"""``hila replay FILE.hilarec``: step through a recorded run (no simulator), or verify it."""

from __future__ import annotations

import sys

from ..core.errors import InputError

HELP = "step through a recording of 'hila exec --record' (no simulator), or re-run it with --verify"
DESCRIPTION = (
    "Open a recording in the REPL's commands without a simulator: step [n], run/continue, break "
    "STATE, back [n], where, icps, vars, path [--plot FILE.png], explain, fsm, reset, quit. With "
    "--verify, run the recorded command again (the program and templates as they are now, the "
    "recorded seed, settings and typed input) and report the first step that differs (exit 1), "
    "or that none does (exit 0); files changed since the recording are noted first."
)


def add_arguments(parser) -> None:
    parser.add_argument("recording", metavar="FILE.hilarec", help="a file written by 'hila exec ... --record'")
    parser.add_argument("--verify", action="store_true", help="re-run the recorded command and compare every step")
    parser.add_argument("--tolerance", type=float, default=1e-6, metavar="METRES",
                        help="largest difference of a point or path taken as equal when verifying (default 1e-6 m)")


def run(args) -> int:
    # lazy: loads numpy, which importing this module does not
    from ..session.recording import read_record

    record = read_record(args.recording)
    if args.verify:
        # lazy: loads numpy, which importing this module does not
        from ..session.replay import verify

        if not args.tolerance >= 0:
            raise InputError(f"expected --tolerance >= 0 metres, got {args.tolerance}")
        ok, lines = verify(record, tolerance=args.tolerance)
        print("\n".join(lines), file=sys.stdout)
        return 0 if ok else 1
    # lazy: loads numpy, which importing this module does not
    from ..session.repl import Repl
    from ..session.replay import ReplayEngine

    engine = ReplayEngine(record)
    Repl(engine, stdin=sys.stdin, stdout=sys.stdout).cmdloop()
    return 0
