"""``hila compile PROGRAM --format text|dot|json|ast``: the FSM (or the AST) of a program."""

from __future__ import annotations

import sys

from ..core.argtypes import output_path
from ..language.ast import dump
from ..language.environment import Environment
HELP = "compile a .hila program to its state machine (text, dot, json) or dump its AST"
DESCRIPTION = (
    "Compile a program to its explicit finite state machine. --format ast stops after parsing "
    "and prints the syntax tree; text, dot (Graphviz) and json print the FSM."
)


def add_arguments(parser) -> None:
    parser.add_argument("program", help="the .hila program")
    parser.add_argument("--format", choices=("text", "dot", "json", "ast"), default="text")
    parser.add_argument("-o", "--output", type=output_path, default=None, help="write to this file instead of stdout")


def render(path: str, fmt: str) -> str:
    """The requested stage of ``path`` as text."""
    env = Environment.default()
    if fmt == "ast":  # stops after parsing
        program = env.load(path, stop="ast")
        return dump(program.items) + "\n"
    _, fsm = env.load(path)  # parsed once, checked, compiled
    return {"text": fsm.to_text, "dot": fsm.to_dot, "json": fsm.to_json}[fmt]()


def run(args) -> int:
    text = render(args.program, args.format)
    if args.output:
        # lazy: only this branch needs it
        from ..core.fileio import atomic_write_text

        atomic_write_text(args.output, text)
    else:
        sys.stdout.write(text)
    return 0
