"""Command-line options shared by ``hila exec`` and ``hila repl`` (world, back end, seed, output)."""

from __future__ import annotations

import sys
from pathlib import Path


def _seed(text: str) -> int:
    """argparse type for --seed: a whole number >= 0 (numpy's generators refuse negative seeds)."""
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {value}")
    return value


def add_run_arguments(parser) -> None:
    parser.add_argument("program", help="the .hila program")
    parser.add_argument("--backend", choices=("dry", "pybullet"), default=None,
                        help="who moves the hand (default: the world's choice, else dry)")
    parser.add_argument("--seed", type=_seed, default=0, help="seed for every random choice (default 0)")
    parser.add_argument("--out", type=Path, default=None, help="output folder for files the world writes")
    parser.add_argument("--opponent", default=None, help="opponent for game worlds (random, minimax, human)")
    parser.add_argument("--gui", action="store_true", help="open the PyBullet window")
    parser.add_argument("--set", dest="settings", action="append", default=[], metavar="KEY=VALUE",
                        help="a setting for the world, back end or OSILA (osila.threshold=0.002); repeatable")


def run_options(args):
    from .plugins import RunOptions, parse_settings

    return RunOptions(seed=args.seed, out=args.out, opponent=args.opponent, gui=args.gui,
                      settings=parse_settings(args.settings), stdin=sys.stdin, stdout=sys.stdout)
