"""What ``hila exec`` / ``hila repl`` pass to every world and back end, and how ``--set`` pairs
are split among OSILA, the robot, the world and the back end and parsed -- before anything is built, by
``hila check`` as by ``hila exec``: a bad value is exit status 2 naming the option.

``osila.KEY`` goes to :func:`hila_lang.osila.imitate` (values read as YAML scalars: ``0.002``,
``true``, ``[1, 2]``) and is validated by OSILA itself on a two-point path, so the rules live in
one place; ``robot`` (``--robot NAME|PATH``) and ``robot.KEY`` name the robot
(:func:`hila_lang.robot.spec.resolve` reads them); any other key goes to the world or the back
end that declares it.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO


@dataclass
class RunOptions:
    """Options shared by all plug-ins (their own settings come separately, parsed).

    Attributes
    ----------
    seed : int
        Seed for every random choice (scene placement, opponents).
    out : Path or None
        Output folder for files a world writes (None: the world decides).
    gui : bool
        Open a GUI window (PyBullet) instead of running headless.
    settings : dict[str, str]
        ``--set key=value`` pairs as typed; the runner splits them among OSILA (``osila.*``),
        the robot (``robot``, the value of ``--robot``, and ``robot.*``), the world and the back
        end, and parses each with the owner's declaration.
    robot : RobotSpec or None
        The robot the run moves (:func:`hila_lang.robot.spec.resolve` of the ``robot``
        settings, done by the runner); None: the iCub.
    stdin, stdout : text streams
        A human opponent and the REPL read the same ``stdin``, so piped input drives both.
    """

    seed: int = 0
    out: Path | None = None
    gui: bool = False
    settings: dict[str, str] = field(default_factory=dict)
    stdin: TextIO = field(default_factory=lambda: sys.stdin)
    stdout: TextIO = field(default_factory=lambda: sys.stdout)
    robot: Any = None


#: the range of every numeric OSILA option a run may be given by ``--set osila.NAME=VALUE``,
#: checked before OSILA is called at all (issue 20: ``shells=100000000`` hung and grew,
#: ``directions=1e8`` ran out of memory).  The route search costs O(T·M²) time and memory in
#: M = 1 + shells·directions candidates per waypoint: M = 2001 took 1.5 s and 130 MB on the
#: 84-point circle template here (the default M = 29 takes 2 ms), so shells·directions is at
#: most :data:`MAX_CANDIDATES`; the other bounds are far beyond any use (a threshold, margin in
#: the template's units, metres or pixels).
OSILA_RANGES: dict[str, tuple[float, float, str]] = {
    "threshold": (0, 1e3, "a distance in the template's units"),
    "rounds": (1, 1000, "plan-adjustment rounds"),
    "smoothing": (0, 1e6, "TPS smoothing"),
    "seed": (0, 2**32 - 1, "a seed"),
    "distortion": (0, 1e6, "a weight"),
    "margin": (0, 1e3, "a distance in the template's units"),
    "shells": (0, 100, "candidate shells"),
    "directions": (1, 2000, "candidate directions per shell"),
    "timing": (0, 1e6, "a weight"),
    "stretch": (1, 1e6, "a ratio of route lengths"),
    "precision": (0, 1e3, "a distance in the template's units"),
}
#: every OSILA option ``--set osila.NAME`` may set (all of ``hila_lang.osila.OPTIONS`` but those of
#: one step's own pairs, ``hila_lang.osila.PER_STEP``: ``pin`` and ``task_times``), named here so
#: ``--help`` need not import OSILA; a test keeps it in step
OSILA_SETTABLE = (*OSILA_RANGES, "reject")
#: most candidate offsets around a waypoint, shells x directions (see :data:`OSILA_RANGES`)
MAX_CANDIDATES = 2000


def check_osila_ranges(options: dict, flag=lambda name: f"--set osila.{name}", typed: dict | None = None) -> None:
    """Refuse an OSILA option outside :data:`OSILA_RANGES` (and shells x directions above
    :data:`MAX_CANDIDATES`) before any work: an :class:`InputError` naming ``flag(name)``.
    Values that are not numbers are left to OSILA's own checks; ``typed`` gives a value as the
    user typed it, for the message."""
    from ..core.errors import InputError

    for name, value in options.items():
        if name not in OSILA_RANGES or isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        low, high, what = OSILA_RANGES[name]
        if not low <= value <= high:  # NaN fails too
            shown = (typed or {}).get(name, value)
            raise InputError(f"bad value for {flag(name)}={shown}: expected {what} from {low:g} to {high:g}")
    shells = options.get("shells", 2)
    directions = options.get("directions") or 14
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (shells, directions)) \
            and shells * directions > MAX_CANDIDATES:
        raise InputError(f"bad value for {flag('shells')} and {flag('directions')}: {shells} x {directions} = "
                         f"{shells * directions:g} candidates around each waypoint, at most {MAX_CANDIDATES} "
                         "(the route search grows with its square)")


def osila_options(settings: dict[str, str]) -> dict:
    """``{"osila.threshold": "0.002"}`` -> ``{"threshold": 0.002}`` (other keys are ignored);
    an unknown option or a value OSILA refuses is an InputError naming ``--set KEY=VALUE``."""
    import difflib

    import yaml

    from ..core.errors import InputError
    from ..osila import OPTIONS, PER_STEP, imitate

    out = {}
    for key, text in settings.items():
        if not key.startswith("osila."):
            continue
        name = key[6:]
        if name == "pin":
            raise InputError("--set osila.pin: a pin fixes stamps of one path; each step pins its own bound "
                             "start and end, so a pin cannot be set for a whole run",
                             hint="bind the sub-template's 'start' or 'end' ICP in the program instead")
        if name == "task_times":
            raise InputError("--set osila.task_times: task times belong to one step's ICP pairs (when the task "
                             "passes each), so they cannot be set for a whole run")
        if name not in OPTIONS:
            settable = [o for o in OPTIONS if o not in PER_STEP]
            close = difflib.get_close_matches(name, settable, n=1)
            raise InputError(f"unknown OSILA option {name!r} in --set {key}; known: {', '.join(settable)}",
                             hint=f"did you mean 'osila.{close[0]}'?" if close else None)
        try:
            out[name] = yaml.safe_load(text)
        except yaml.YAMLError:
            raise InputError(f"cannot read --set {key}={text}: expected a number, true/false or a list") from None
        if isinstance(out[name], str):  # YAML 1.1 reads 1e8 (no dot) as text: a number all the same
            try:
                out[name] = float(out[name])
            except ValueError:
                pass
        check_osila_ranges({name: out[name]}, typed={name: text})
        try:  # OSILA's own checks, on a path of two points
            imitate([[0.0, 0.0], [1.0, 0.0]], [[0.0, 0.0]], [[0.0, 0.0]], **{name: out[name]})
        except InputError as exc:
            raise InputError(f"bad value for --set {key}={text}: {exc.message}",
                             hint="the OSILA options are described in 'hila imitate --help'") from None
    check_osila_ranges(out)  # together: shells x directions
    return out


def split_settings(settings: dict[str, str], world, backend) -> tuple[dict, dict, dict]:
    """``--set`` pairs -> (OSILA options, the world's settings, the back end's), each parsed
    (``world`` a WorldInfo, ``backend`` a BackendInfo); any other key is an InputError that says
    who has it (``--opponent`` on a world without an opponent) or suggests a near name."""
    import difflib

    from ..core.errors import InputError

    world_keys = {s.name for s in world.settings}
    backend_keys = {s.name for s in backend.settings}
    mine: dict[str, dict[str, str]] = {"world": {}, "backend": {}}
    for key, text in settings.items():
        if key.startswith(("osila.", "robot.")) or key == "robot":  # OSILA's; the robot's (hila_lang.robot.spec)
            continue
        if key in world_keys:
            mine["world"][key] = text
        elif key in backend_keys:
            mine["backend"][key] = text
        else:
            known = sorted(world_keys | backend_keys)
            owners, flag = _owners(key)
            close = difflib.get_close_matches(key, known, n=1)
            hint = (f"'{key}'{f' ({flag})' if flag else ''} is a setting of {', '.join(owners)}" if owners
                    else f"did you mean {close[0]!r}?" if close else None)
            raise InputError(
                f"unknown setting {key!r} for world {world.name!r} and back end {backend.name!r}; known: "
                + ", ".join([*known, "osila.OPTION"]), hint=hint)
    return osila_options(settings), world.parse(mine["world"]), backend.parse(mine["backend"])


def _owners(key: str) -> tuple[list[str], str | None]:
    """(["world tictactoe", ...] that declare setting ``key``, its command-line flag or None)."""
    from . import registry

    owners, flag = [], None
    for kind in ("world", "back end"):
        for info in registry.declarations(kind):
            for s in info.settings:
                if s.name == key:
                    owners.append(f"{kind} {info.name}")
                    flag = flag or s.flag
    return owners, flag


def parse_pairs(pairs: list[str] | None) -> dict[str, str]:
    """``["a=1", "b=x"]`` -> ``{"a": "1", "b": "x"}``; a pair without ``=`` is an InputError."""
    from ..core.errors import InputError

    settings: dict[str, str] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(f"expected --set KEY=VALUE, got {pair!r}")
        settings[key.strip()] = value.strip()
    return settings
