"""``hila explain PROGRAM``: run a program and say, for its run states, what OSILA did and why."""

from __future__ import annotations

import fnmatch

from ..core.errors import HilaRuntimeError
from ..session.runopts import add_run_arguments, run_options

HELP = "run a program and explain each run state: ICP pairs, fallbacks, rounds of plan adjustment and why"
DESCRIPTION = (
    "Run a program as 'hila exec' does, then explain every run state (or those matching --state): "
    "the ICP pairs the warp used (template point -> task point), the map and why a fallback "
    "(similarity, translation) was taken, the rounds of plan adjustment and which via/avoid each "
    "round missed, the constraint pairs added, and how the route meets each constraint. A state "
    "whose constraints cannot be met is explained round by round before the error (exit 1)."
)


def add_arguments(parser) -> None:
    add_run_arguments(parser)
    parser.add_argument("--state", action="append", default=[], metavar="PATTERN",
                        help="explain only states matching PATTERN (glob, e.g. 'main/*/draw'); repeatable")


def run(args) -> int:
    # lazy: loads numpy, which importing this module does not
    from ..session.runner import finish, prepare

    options = run_options(args)
    interp = prepare(args.program, options, args.backend, step_limit=args.max_steps)
    out = options.stdout

    def wanted(name: str) -> bool:
        return not args.state or any(fnmatch.fnmatchcase(name, p) for p in args.state)

    failed = None
    try:
        try:
            interp.run()
        except HilaRuntimeError as exc:
            failed = exc
        for entry in interp.trace:
            if entry.step_result is not None and wanted(entry.state):
                template = interp.runs.template(interp.fsm.states[entry.state])
                # lazy: loads numpy, which importing this module does not
                from ..hierarchy.explain import explain_step

                print("\n".join(explain_step(template, entry.step_result,
                                             title=f"{entry.state} (line {entry.line}), step {entry.step}")),
                      file=out, flush=True)
        if failed is not None and not interp.done and interp.state.kind == "run" and wanted(interp.current):
            try:
                print("\n".join(interp.explain()), file=out, flush=True)
            except HilaRuntimeError:
                pass  # the run's own error (below) says it
    finally:
        finish(interp)
    if failed is not None:
        raise failed
    return 0
