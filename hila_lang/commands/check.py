"""``hila check PROGRAM...``: parse, check and compile; report the first error of each file."""

from __future__ import annotations

import sys

from ..core.errors import HilaError
from ..language.environment import Environment
from ..session.runopts import add_setting_arguments, settings_of

HELP = "check .hila programs: syntax, names, ICP bindings, reachability (exit 2 on error)"
DESCRIPTION = (
    "Parse, check and compile each program without running it: syntax, names, ICP bindings and "
    "the points' sizes, the questions (ask), events (wait) and scene points the world declares, "
    "reachability. Give the --set settings and --backend the program will run with: they are "
    "checked too, and the scripted world's questions, events and points come from its script "
    "(--set script=FILE.yaml). Errors print as FILE:LINE:COL: error: MESSAGE with the source line "
    "and a caret; exit status 2 if any fails."
)


def add_arguments(parser) -> None:
    parser.add_argument("programs", nargs="+", metavar="PROGRAM", help=".hila files")
    add_setting_arguments(parser)


def run(args) -> int:
    settings = settings_of(args)
    status = 0
    env = Environment.default()
    for path in args.programs:
        try:
            checked, fsm = env.load(path, settings=settings, backend=args.backend)
        except HilaError as exc:
            print(str(exc), file=sys.stderr)
            status = max(status, exc.exit_code)
            continue
        for warning in checked.warnings:
            print(warning, file=sys.stderr)
        runs = sum(1 for s in fsm.states.values() if s.kind == "run")
        print(f"{fsm.file}: ok ({len(fsm.states)} states, {runs} run states, world {fsm.world})")
    return status
