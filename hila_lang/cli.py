"""The ``hila`` command line: ``build_parser()`` + ``main(argv) -> int``.

Each sub-command lives in ``hila_lang/commands/<name>.py`` and exposes

- ``HELP``: one line for ``hila --help``;
- ``add_arguments(parser)``: its options (module top level imports nothing heavy);
- ``run(args) -> int``: the work; heavy imports (pybullet, sklearn, cv2) happen in here.

Exit status: 0 success, 1 a run that failed, 2 bad usage or bad input, 3 an internal error,
130 interrupted (Ctrl-C); 143 and 129 stopped by SIGTERM and SIGHUP (handled like Ctrl-C).
Any :class:`~hila_lang.core.errors.HilaError` is printed as a message, never as a traceback.  Any
other exception (raised by hila, a plug-in or OSILA) is a bug: it is reported as an internal
error that says where it was raised and whom to report it to, with exit status 3; ``--debug``
prints its traceback too.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import textwrap

from . import __version__
from .core import threads
from .core.errors import EXIT_BAD_INPUT, EXIT_INTERNAL, HilaError, printable
from .core.interrupts import exit_code, handle_termination

#: sub-command name -> module under hila_lang.commands, in the order ``--help`` lists them
COMMANDS = {
    "exec": "exec_",
    "repl": "repl",
    "replay": "replay",
    "check": "check",
    "compile": "compile_",
    "explain": "explain",
    "learn": "learn",
    "sheet": "sheet",
    "imitate": "imitate",
    "eval": "eval_",
    "snapshot": "snapshot",
    "lsp": "lsp",
    "show": "show",
    "studio": "studio",
    "robot-sim": "robot_sim",
}


#: commands whose runs may use OSILA's compiled kernels: their first run after an install starts
#: their compilation in the background (:func:`hila_lang.core.jit.warm_in_background`)
WARMING = frozenset({"exec", "repl", "replay", "explain", "learn", "imitate", "eval", "studio"})


class _Parser(argparse.ArgumentParser):
    """argparse that exits with status 2 and a one-line hint (its default is a usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def _command_module(name: str):
    return importlib.import_module(f"hila_lang.commands.{COMMANDS[name]}")


def _description(module) -> str:
    """A command's DESCRIPTION as its author laid it out; a single paragraph is wrapped."""
    text = getattr(module, "DESCRIPTION", module.HELP)
    return text if "\n" in text.strip() else textwrap.fill(text, 96)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="hila",
        description=(
            "hila: teach a robot an action from ONE demonstration, then write new tasks as "
            "sequences and hierarchies of its pieces (HILA-OSILA, Wu & Demiris 2010)."
        ),
        epilog="Run 'hila COMMAND --help' for a command's options. "
        "Exit status: 0 ok, 1 run failed, 2 bad input, 3 internal error (a bug in hila or a "
        "plug-in: the message says where to report it; add --debug for the traceback), "
        "130 interrupted (Ctrl-C; 143 SIGTERM, 129 SIGHUP).",
    )
    parser.add_argument("--version", action="version", version=f"hila {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="on an internal error (exit 3), print the Python traceback too")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        module = _command_module(name)
        cmd = sub.add_parser(name, help=module.HELP, description=_description(module),
                             formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(cmd)
        cmd.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                         help="on an internal error (exit 3), print the Python traceback too")
        cmd.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "_run", None) is None:
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT

    if threads.problem():  # HILA_THREADS is read when hila is imported; a bad value is bad input
        print(f"hila: error: {threads.problem()}", file=sys.stderr)
        return EXIT_BAD_INPUT
    handle_termination()  # SIGTERM and SIGHUP stop a run as Ctrl-C does (exit 143, 129)
    if args.command in WARMING:  # the first run after an install fills numba's cache meanwhile
        # lazy: only this branch needs it
        from .core.jit import warm_in_background

        warm_in_background("hila_lang.osila.warm")
    for stream in (sys.stdout, sys.stderr):  # PYTHONIOENCODING=ascii: escapes, not UnicodeEncodeError
        if "utf" not in (getattr(stream, "encoding", None) or "utf").lower() and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    try:
        return int(args._run(args) or 0)
    except HilaError as exc:
        print(str(exc), file=sys.stderr)
        return exc.exit_code
    except OSError as exc:  # a path the user gave cannot be read or written (e.g. --out on a file)
        if isinstance(exc, BrokenPipeError):
            return 0
        where = f"{exc.filename}: " if exc.filename else ""
        print(printable(f"{where}error: {exc.strerror or exc}"), file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as stop:  # Ctrl-C (SIGTERM) outside a run the engine could stop cleanly
        print("interrupted", file=sys.stderr)
        return exit_code(stop)
    except Exception as exc:  # noqa: BLE001 - a bug: say so, say where, exit 3
        # lazy: only this branch needs it
        from .core.errors import internal_error_message

        if getattr(args, "debug", False):
            # lazy: only this branch needs it
            import traceback

            traceback.print_exc(file=sys.stderr)
        print(f"hila: {internal_error_message(exc)}", file=sys.stderr)
        return EXIT_INTERNAL


def _quiet_exit_on_ctrl_c(code: int) -> None:
    """From here on the work is done and its outputs written: a Ctrl-C while Python exits (joblib's
    pool joining its threads) ends the process at once with ``code``, not with a traceback
    ('Exception ignored in threading._shutdown ... KeyboardInterrupt')."""
    def now(signum, frame):
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)

    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # an ignored SIGINT stays ignored
        signal.signal(signal.SIGINT, now)


def entry() -> None:  # pragma: no cover - thin wrapper for python -m
    handle_termination()  # from the start: a SIGTERM while the commands load ends quietly too
    try:
        code = main()
    except KeyboardInterrupt as stop:  # Ctrl-C while the command line is being read
        print("interrupted", file=sys.stderr)
        code = exit_code(stop)
    _quiet_exit_on_ctrl_c(code)
    sys.exit(code)

