"""What ``hila exec`` / ``hila repl`` pass to every world and back end, and how ``--set`` pairs
are split among OSILA, the robot, the world and the back end and parsed -- before anything is built, by
``hila check`` as by ``hila exec``: a bad value is exit status 2 naming the option.

``osila.KEY`` goes to :func:`hila_lang.osila.imitate`, read and checked by its declaration here
(:data:`OSILA_OPTIONS`: a number in a range, a whole number, or a word such as ``auto``), the
way a world's or a back end's setting is checked by its :class:`~hila_lang.plugins.settings.Setting`
-- OSILA is not run to validate a value; ``robot`` (``--robot NAME|PATH``) and ``robot.KEY`` name
the robot (:func:`hila_lang.robot.spec.resolve` reads them); any other key goes to the world or
the back end that declares it.
"""

from __future__ import annotations

import difflib
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from ..core.errors import InputError
from . import registry


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


@dataclass(frozen=True)
class OsilaOption:
    """The declaration of one OSILA option a run may be given (``--set osila.NAME=VALUE``, a task
    file's ``options``): what it is, its range, whether it is a whole number, and the words it takes
    besides a number (``"auto"``; None: OSILA's own default).  :meth:`check` validates a value,
    :meth:`parse` the text a person typed -- before anything runs, without running OSILA."""

    name: str
    what: str
    low: float = 0.0
    high: float = 1e6
    integer: bool = False
    words: tuple = ()

    def check(self, value: Any) -> Any:
        """``value`` if this option takes it; a ValueError saying what it expected otherwise."""
        if value in self.words and not isinstance(value, bool):
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"expected {self.name} as {'an integer' if self.integer else 'a number'}, got {value!r}")
        if self.integer and value != int(value):
            raise ValueError(f"expected {self.name} as an integer, got {value!r}")
        if not self.low <= value <= self.high:  # NaN fails too
            raise ValueError(f"expected {self.what} from {self.low:g} to {self.high:g}")
        return int(value) if self.integer else float(value)

    def parse(self, text: str) -> Any:
        """The typed text: a number (``0.002``, ``1e8``), or one of :attr:`words` (``auto``;
        ``none`` for OSILA's own default)."""
        t = text.strip()
        if None in self.words and t.lower() in ("", "~", "null", "none"):
            return None
        if t in self.words:
            return t
        try:
            value: float = int(t)
        except ValueError:
            try:
                value = float(t)
            except ValueError:
                raise ValueError(f"expected {self.name} as {'an integer' if self.integer else 'a number'}, "
                                 f"got {t!r}") from None
        return self.check(value)


@dataclass(frozen=True)
class OsilaChoice:
    """An OSILA option that is one of a few words (``reject``)."""

    name: str
    what: str
    choices: tuple

    def check(self, value: Any) -> Any:
        if value not in self.choices or isinstance(value, bool):
            raise ValueError(f"expected {self.name} as one of {', '.join(self.choices)}, got {value!r}")
        return value

    def parse(self, text: str) -> Any:
        return self.check(text.strip())


#: every OSILA option a run may set, declared: the rules a value is checked by before anything is
#: built (issue 20: ``shells=100000000`` hung and grew, ``directions=1e8`` ran out of memory).  The
#: route search costs O(T·M²) time and memory in M = 1 + shells·directions candidates per
#: waypoint: M = 2001 took 1.5 s and 130 MB on the 84-point circle template here (the default
#: M = 29 takes 2 ms), so shells·directions is at most :data:`MAX_CANDIDATES`; the other bounds
#: are far beyond any use (a threshold, a margin in the template's units, metres or pixels).
#: These are OSILA's own rules (:func:`hila_lang.osila.imitate`) -- ``tests/test_lang_worldcheck.py``
#: holds the two together -- named here so neither ``--help`` nor ``hila check`` imports OSILA.
OSILA_OPTIONS: dict[str, OsilaOption | OsilaChoice] = {o.name: o for o in (
    OsilaOption("threshold", "a distance in the template's units", 0, 1e3, words=(None,)),
    OsilaOption("rounds", "plan-adjustment rounds", 1, 1000, integer=True),
    OsilaOption("smoothing", "TPS smoothing", 0, 1e6, words=("auto",)),
    OsilaOption("seed", "a seed", 0, 2**32 - 1, integer=True),
    OsilaOption("distortion", "a weight", 0, 1e6),
    OsilaOption("margin", "a distance in the template's units", 0, 1e3),
    OsilaOption("shells", "candidate shells", 0, 100, integer=True),
    OsilaOption("directions", "candidate directions per shell", 1, 2000, integer=True, words=(None,)),
    OsilaOption("timing", "a weight", 0, 1e6),
    OsilaOption("stretch", "a ratio of route lengths", 1, 1e6),
    OsilaOption("precision", "a distance in the template's units", 0, 1e3, words=(None,)),
    OsilaChoice("reject", "outlier rejection among the ICP pairs", ("auto", "none", "loo", "lmeds")),
)}
#: every OSILA option ``--set osila.NAME`` may set (all of ``hila_lang.osila.OPTIONS`` but those of
#: one step's own pairs, ``hila_lang.osila.PER_STEP``: ``pin`` and ``task_times``); a test keeps it in step
OSILA_SETTABLE = tuple(OSILA_OPTIONS)
#: most candidate offsets around a waypoint, shells x directions (see :data:`OSILA_OPTIONS`)
MAX_CANDIDATES = 2000


def check_osila_options(options: dict, flag=lambda name: f"--set osila.{name}", typed: dict | None = None) -> dict:
    """``options`` checked by their declarations (:data:`OSILA_OPTIONS`) and shells x directions
    bounded by :data:`MAX_CANDIDATES`, before any work; an :class:`InputError` names
    ``flag(name)`` and the value (``typed[name]``, as the person typed it, when given).  Options
    not declared here are left to OSILA."""
    out = dict(options)
    for name, value in options.items():
        if name in OSILA_OPTIONS:
            try:
                out[name] = OSILA_OPTIONS[name].check(value)
            except ValueError as exc:
                shown = (typed or {}).get(name, value)
                raise InputError(f"bad value for {flag(name)}={shown}: {exc}",
                                 hint="the OSILA options are described in 'hila imitate --help'") from None
    shells = out.get("shells", 2)
    directions = out.get("directions") or 14
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (shells, directions)) \
            and shells * directions > MAX_CANDIDATES:
        raise InputError(f"bad value for {flag('shells')} and {flag('directions')}: {shells} x {directions} = "
                         f"{shells * directions:g} candidates around each waypoint, at most {MAX_CANDIDATES} "
                         "(the route search grows with its square)")
    return out


def osila_options(settings: dict[str, str]) -> dict:
    """``{"osila.threshold": "0.002"}`` -> ``{"threshold": 0.002}`` (other keys are ignored), each
    value read and checked by its declaration (:data:`OSILA_OPTIONS`); an unknown option or a bad
    value is an InputError naming ``--set KEY=VALUE``."""
    out, typed = {}, {}
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
        if name not in OSILA_OPTIONS:
            close = difflib.get_close_matches(name, OSILA_SETTABLE, n=1)
            raise InputError(f"unknown OSILA option {name!r} in --set {key}; known: {', '.join(OSILA_SETTABLE)}",
                             hint=f"did you mean 'osila.{close[0]}'?" if close else None)
        try:
            out[name] = OSILA_OPTIONS[name].parse(text)
        except ValueError as exc:
            raise InputError(f"bad value for --set {key}={text}: {exc}",
                             hint="the OSILA options are described in 'hila imitate --help'") from None
        typed[name] = text
    return check_osila_options(out, typed=typed)  # together: shells x directions


def split_settings(settings: dict[str, str], world, backend) -> tuple[dict, dict, dict]:
    """``--set`` pairs -> (OSILA options, the world's settings, the back end's), each parsed
    (``world`` a WorldInfo, ``backend`` a BackendInfo); any other key is an InputError that says
    who has it (``--opponent`` on a world without an opponent) or suggests a near name."""
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
    settings: dict[str, str] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(f"expected --set KEY=VALUE, got {pair!r}")
        settings[key.strip()] = value.strip()
    return settings
