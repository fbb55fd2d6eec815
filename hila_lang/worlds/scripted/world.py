"""A scripted test world: fixed scene points, answers and events read from a script.

``ScriptedWorld(points, answers, events)``:

- ``points``: name -> (x, y, z), metres (``points()`` returns them);
- ``answers``: question -> value, or a list of values handed out in order (``query``); a list
  that runs out is a runtime error, so a test fails loudly instead of looping;
- ``events``: event -> list of values handed out in order by ``wait``.

- ``motion``: moves of the points while the robot moves (:mod:`.motion`): the world's ``tracking``
  capability shows the robot where they are at each look of a ``track`` clause.

Every ``notify`` is kept in :attr:`log` as ``(event, data)`` (the newest :data:`KEEP_LOG`).  From the command line,
``--set script=FILE.yaml`` loads a YAML mapping with the keys ``points``, ``answers``,
``events`` (and optionally ``home``: where the back end starts the hand, ``scene.home``, and
``motion``); without a script the world is empty and a program supplies its points with
``point NAME = (x, y, z)``.
A question or event the script does not name is an :class:`~hila_lang.core.errors.UnknownNameError`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...core.bounded import BoundedLog
from ...core.errors import HilaRuntimeError, InputError, UnknownNameError
from ...core.fileio import load_yaml
from ...plugins.registry import Declared
from ...plugins.snapshots import AttributeSnapshots
from ...sim.surface import Scene
from .motion import ScriptedTracking


#: notifications kept in :attr:`ScriptedWorld.log`
KEEP_LOG = 1000


class ScriptedWorld:
    """Implements :class:`hila_lang.plugins.protocols.World` from a script (see the module docstring)."""

    def __init__(self, points=None, answers=None, events=None, home=None, stdout=None, motion=None) -> None:
        #: where :meth:`finish` prints the result line (None: it prints nothing)
        self.stdout = stdout
        #: the points as they are, and as the robot last saw them while a step runs (None between steps)
        self._true = {str(k): _point(v, f"point {k!r}") for k, v in (points or {}).items()}
        self._seen: dict | None = None
        if motion is not None and not isinstance(motion, list):
            raise InputError(f"expected 'motion' as a list of moves, got {_kind(motion)}")
        self.tracking = ScriptedTracking(self, motion)
        self.answers = {k: (list(v) if isinstance(v, list) else v) for k, v in (answers or {}).items()}
        self.events = {k: list(v) for k, v in (events or {}).items()}
        self.home = None if home is None else _point(home, "home")
        self.scene = None if self.home is None else Scene(home=self.home)
        self.log: BoundedLog = BoundedLog(KEEP_LOG)  # every notification; the newest kept
        self.snapshots = AttributeSnapshots(self, ("answers", "events", "_true", "tracking.visits"), append_only=("log",))

    def attach(self, backend) -> None:
        pass

    def points(self) -> dict[str, np.ndarray]:
        return dict(self._true if self._seen is None else self._seen)

    def query(self, name: str, *args: Any) -> Any:
        if name not in self.answers:
            raise UnknownNameError("question", name, self.answers, owner="the scripted world")
        value = self.answers[name]
        if isinstance(value, list):
            if not value:
                raise HilaRuntimeError(f"the script has no more answers to '{name}'")
            return value.pop(0)
        return value

    def wait(self, event: str, *args: Any) -> Any:
        if event not in self.events:
            raise UnknownNameError("event", event, self.events, owner="the scripted world")
        if not self.events[event]:
            raise HilaRuntimeError(f"the script has no more '{event}' events")
        return self.events[event].pop(0)

    def notify(self, event: str, **data: Any) -> None:
        self.log.append((event, data))

    def finish(self, trace=None, *, fsm=None) -> dict:
        """Counts of the states and run states executed (every one, not only those kept); prints
        the result line (also under ``--quiet``): finished, or where the run stopped."""
        trace = trace or []
        kinds = getattr(trace, "kinds", None)
        if kinds is None:  # a plain list of entries
            kinds = {"run": sum(1 for t in trace if t.kind == "run")}
        summary = {"states": len(trace), "runs": kinds.get("run", 0)}
        if self.stdout is not None:
            last = trace[-1] if len(trace) else None
            if last is not None and last.error:
                how = f"stopped at step {last.step} ({last.state}, line {last.line})"
            elif last is not None and last.next is None:
                how = "finished"
            else:
                how = "stopped (the message says why)"
            print(f"result: {how}: {summary['states']} steps, {summary['runs']} run states", file=self.stdout,
                  flush=True)
        return summary


def _point(value, what: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"expected {what} as 3 numbers, got {value!r}") from None
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise InputError(f"expected {what} as 3 finite numbers, got {value!r}")
    return arr


def load_script(path, stdout=None) -> ScriptedWorld:
    """A :class:`ScriptedWorld` from a YAML script file."""
    doc = load_yaml(path, "world script", unique_keys=True) or {}
    if not isinstance(doc, dict):
        raise InputError("expected a world script mapping with keys points, answers, events, home", file=str(path))
    unknown = set(doc) - {"points", "answers", "events", "home", "motion"}
    if unknown:
        raise InputError(f"unknown key {sorted(unknown)[0]!r} in world script; expected points, answers, events, home, "
                         "motion", file=str(path))
    try:
        _check_shape(doc)
        return ScriptedWorld(doc.get("points"), doc.get("answers"), doc.get("events"), doc.get("home"), stdout,
                             doc.get("motion"))
    except InputError as exc:
        exc.file = str(path)
        raise


#: what each mapping of a script holds, for messages
_SCRIPT_MAPPINGS = {"points": "name -> [x, y, z]", "answers": "question -> value or [values in turn]",
                    "events": "event -> [values in turn]"}


def _kind(value) -> str:
    name = type(value).__name__
    return {"list": "a list", "int": "an int", "str": "a string", "float": "a number", "bool": "true/false"}.get(
        name, f"a {name}")


def _check_shape(doc: dict) -> None:
    """A script's mappings are mappings of names (and an event's values a list): anything else is
    an InputError saying which key, not a crash further on (a string of events would be its letters)."""
    for key, what in _SCRIPT_MAPPINGS.items():
        value = doc.get(key)
        if value is None:
            continue
        if not isinstance(value, dict):
            raise InputError(f"expected {key!r} as a mapping {what}, got {_kind(value)}")
        for name, given in value.items():
            if not isinstance(name, str):
                raise InputError(f"expected the names in {key!r} as words, got {name!r}")
            if key == "events" and not isinstance(given, list):
                raise InputError(f"expected 'events.{name}' as a list of values in turn, got {given!r}")


def declared(settings):
    """What the world with these settings answers (for ``hila check``): its script's names."""
    script = settings.get("script")
    if not script:
        return Declared({}, {}, frozenset(), False, "the scripted world (no --set script=FILE.yaml)",
                        "the scripted world answers what its script names: give the script with "
                        "--set script=FILE.yaml (points, answers, events)")
    world = load_script(script)
    return Declared({k: "from the script" for k in world.answers}, {k: "from the script" for k in world.events},
                    frozenset(world.points()), False, f"the scripted world ({script})",
                    question_dims=_point_sizes(world.answers), event_dims=_point_sizes(world.events))


def _point_sizes(values: dict) -> dict[str, int]:
    """name -> 2 or 3 for the names whose every value (in turn) is a point of that size."""
    out = {}
    for name, given in values.items():
        sizes = {_point_size(v) for v in (given if isinstance(given, list) else [given])}
        if len(sizes) == 1 and None not in sizes:
            out[name] = sizes.pop()
    return out


def _point_size(value) -> int | None:
    numbers = isinstance(value, (list, tuple)) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    return len(value) if numbers and len(value) in (2, 3) else None


def make_world(options, settings) -> ScriptedWorld:
    """Plug-in factory: ``--set script=FILE.yaml`` or an empty world."""
    script = settings.get("script")
    return load_script(script, options.stdout) if script else ScriptedWorld(stdout=options.stdout)
