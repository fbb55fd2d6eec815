"""Command-line options shared by ``hila exec`` and ``hila repl`` (world, back end, seed, output).

``--backend`` choices come from the registry (entry-point names, nothing imported); every
setting a plug-in declares with a ``flag`` (the tic-tac-toe world's ``--opponent``) becomes an
alias for ``--set NAME=VALUE``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .limits import DEFAULT_STEP_LIMIT


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


def _steps(text: str) -> int:
    """argparse type for --max-steps: a whole number >= 0 (0: no limit)."""
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0 (0: no limit), got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0 (0: no limit), got {value}")
    return value


def _aliases() -> dict[str, tuple[str, list[str]]]:
    """flag -> (setting name, ["world NAME: doc", ...]) over every declared plug-in."""
    from ..plugins import registry

    flags: dict[str, tuple[str, list[str]]] = {}
    for kind in ("world", "back end"):
        for info in registry.declarations(kind):
            for s in info.settings:
                if s.flag:
                    name, owners = flags.setdefault(s.flag, (s.name, []))
                    if name == s.name:
                        owners.append(f"{kind} {info.name}: {s.metavar}")
    return flags


def add_run_arguments(parser) -> None:
    from ..plugins import registry

    parser.add_argument("program", help="the .hila program")
    parser.add_argument("--backend", choices=registry.names("back end"), default=None,
                        help="who moves the hand (default: the world's choice)")
    parser.add_argument("--seed", type=_seed, default=0, help="seed for every random choice (default 0)")
    parser.add_argument("--out", type=Path, default=None, help="output folder for files the world writes")
    for flag, (name, owners) in sorted(_aliases().items()):
        parser.add_argument(flag, dest=f"alias:{name}", default=None, metavar=name.upper(),
                            help=f"same as --set {name}=VALUE ({'; '.join(owners)})")
    parser.add_argument("--gui", action="store_true", help="open the PyBullet window")
    parser.add_argument("--max-steps", type=_steps, default=DEFAULT_STEP_LIMIT, metavar="N",
                        help=f"stop a run after N steps, a loop that never ends (default {DEFAULT_STEP_LIMIT}; 0: no limit)")
    parser.add_argument("--set", dest="settings", action="append", default=[], metavar="KEY=VALUE",
                        help="a setting of the world, the back end or OSILA (osila.threshold=0.002); repeatable")


def run_options(args):
    from ..plugins.options import RunOptions, parse_pairs

    settings = parse_pairs(args.settings)
    for dest, value in vars(args).items():
        if dest.startswith("alias:") and value is not None:
            settings[dest[6:]] = value
    return RunOptions(seed=args.seed, out=args.out, gui=args.gui, settings=settings,
                      stdin=sys.stdin, stdout=sys.stdout)
