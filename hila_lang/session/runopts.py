"""Command-line options shared by ``hila exec`` and ``hila repl`` (world, back end, seed, output).

``--backend`` choices come from the registry (entry-point names, nothing imported); every
setting a plug-in declares with a ``flag`` (the tic-tac-toe world's ``--opponent``) becomes an
alias for ``--set NAME=VALUE``.
"""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

from ..core.argtypes import output_path, seed, whole
from ..language.limits import DEFAULT_STEP_LIMIT
from ..plugins import registry
from ..plugins.options import OSILA_SETTABLE, parse_pairs, RunOptions

_steps = whole(note=" (0: no limit)")  # --max-steps


def _out(text: str) -> Path:
    return Path(output_path(text))


def _aliases() -> dict[str, tuple[str, list[str]]]:
    """flag -> (setting name, ["world NAME: doc", ...]) over every declared plug-in."""
    flags: dict[str, tuple[str, list[str]]] = {}
    for kind in ("world", "back end"):
        for info in registry.declarations(kind):
            for s in info.settings:
                if s.flag:
                    name, owners = flags.setdefault(s.flag, (s.name, []))
                    if name == s.name:
                        owners.append(f"{kind} {info.name}: {s.metavar}")
    return flags


def add_setting_arguments(parser) -> None:
    """``--backend``, ``--set KEY=VALUE`` and the plug-ins' flags: what a program runs with, so
    ``hila check`` can check it the way ``hila exec`` will run it.  ``--help`` lists every
    registered world's and back end's settings (:func:`settings_help`)."""
    parser.add_argument("--backend", choices=registry.names("back end"), default=None,
                        help="who moves the hand (default: the world's choice)")
    for flag, (name, owners) in sorted(_aliases().items()):
        parser.add_argument(flag, dest=f"alias:{name}", default=None, metavar=name.upper(),
                            help=f"same as --set {name}=VALUE ({'; '.join(owners)})")
    parser.add_argument("--robot", dest="alias:robot", default=None, metavar="NAME|PATH",
                        help="the robot: a name (" + ", ".join(registry.names("robot")) + "; default icub), "
                             "a spec file (.yaml) or a URDF (.urdf, with --set robot.tip=LINK); same as "
                             "--set robot=NAME (docs/robots.md)")
    parser.add_argument("--set", dest="settings", action="append", default=[], metavar="KEY=VALUE",
                        help="a setting of the world, the back end or OSILA (osila.threshold=0.002); "
                             "repeatable; the settings are listed below")
    parser.epilog = settings_help()


def settings_help() -> str:
    """Every registered world's and back end's settings, and the OSILA options, for ``--help``
    (read from the registry: a plug-in's settings appear as soon as it is installed)."""
    lines = ["settings (--set KEY=VALUE), by the world (world NAME in the program) and the back end:"]
    for kind in ("world", "back end"):
        for info in registry.declarations(kind):
            lines.append(f"  {kind} {info.name}: {info.doc}")
            for s in info.settings:
                lines.extend(textwrap.wrap(s.help(), 96, initial_indent="    ", subsequent_indent="      "))
            if not info.settings:
                lines.append("    (no settings)")

    lines.extend(textwrap.wrap("the robot (--robot NAME|PATH): robot.tip=LINK (the flange), robot.packages=DIR[:DIR] "
                               "(package:// meshes), robot.base=X,Y,Z, robot.pen=METRES (docs/robots.md)",
                               96, initial_indent="  ", subsequent_indent="    "))
    settable = ", ".join(f"osila.{name}" for name in OSILA_SETTABLE)
    lines.extend(textwrap.wrap(f"OSILA: {settable} (see 'hila imitate --help')",
                               96, initial_indent="  ", subsequent_indent="    "))
    return "\n".join(lines)


def settings_of(args) -> dict[str, str]:
    """The ``--set`` pairs and plug-in flags of ``args`` as one dict (a bad pair: InputError)."""
    settings = parse_pairs(args.settings)
    for dest, value in vars(args).items():
        if dest.startswith("alias:") and value is not None:
            settings[dest[6:]] = value
    return settings


def add_run_arguments(parser) -> None:
    parser.add_argument("program", help="the .hila program")
    parser.add_argument("--seed", type=seed, default=0, help="seed for every random choice (default 0)")
    parser.add_argument("--out", type=_out, default=None, help="output folder for files the world writes")
    parser.add_argument("--gui", action="store_true", help="open the PyBullet window")
    parser.add_argument("--max-steps", type=_steps, default=DEFAULT_STEP_LIMIT, metavar="N",
                        help=f"stop a run after N steps, a loop that never ends (default {DEFAULT_STEP_LIMIT}; 0: no limit)")
    add_setting_arguments(parser)


def run_options(args):
    return RunOptions(seed=args.seed, out=args.out, gui=args.gui, settings=settings_of(args),
                      stdin=sys.stdin, stdout=sys.stdout)
