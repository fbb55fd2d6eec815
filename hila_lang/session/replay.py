"""Replaying a recording (:mod:`hila_lang.session.recording`) without a simulator, and verifying it.

:class:`ReplayEngine` has the stepping engine's face (``step``, ``back``, ``reset``, ``current``,
``trace``, ``hand()``, ``explain()``, ...) over the recorded steps, so the REPL's commands work on
it unchanged: ``step``, ``run``/``continue`` to a breakpoint, ``back``, ``where``, ``icps``,
``vars``, ``path --plot``, ``explain`` (OSILA is run again on the recorded ICPs: no simulator),
``fsm``.

:func:`verify` runs the recorded command again (the program and templates as they are now, the
recorded seed, settings and typed input) and compares every step with the recording: state,
transition, ICPs, planned and executed paths (within a tolerance, metres), a streamed run's
re-plans (when, from where, the points perceived, the new tail), value and trace text.
It reports the first difference, and notes the files that changed since the recording.
"""

from __future__ import annotations

import io
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ..core.errors import HilaError, HilaRuntimeError
from ..engine.trace import Trace, TraceEntry
from ..hierarchy.explain import explain_run
from ..hierarchy.step import Constraint
from ..language.fsm import FSM
from ..osila.template import template_from_dict
from ..plugins.options import RunOptions
from .recording import sha256
from .runner import finish, prepare


#: the exit statuses of a recorded run stopped from outside: Ctrl-C, SIGHUP, SIGTERM
INTERRUPTED_EXITS = (130, 129, 143)


def _entry(s: dict) -> TraceEntry:
    replans = None
    if s.get("replans") is not None:
        # lazy: only this branch needs it
        from ..engine.tracking import Replan

        replans = [Replan.from_dict(r) for r in s["replans"]]
    return TraceEntry(s["step"], s["state"], s["kind"], s["line"], s["text"], s["next"], path=s["path"],
                      executed=s["executed"], icps=dict(s["icps"]), pen_down=s["pen_down"], value=s["value"],
                      replans=replans)


class ReplayEngine:
    """A recording, stepped like a run (see the module docstring)."""

    def __init__(self, record: dict) -> None:
        self.record = record
        self.fsm = FSM.from_dict(record["fsm"])
        program = SimpleNamespace(source=record["program"]["text"], file=record["program"]["file"])
        self.checked = SimpleNamespace(program=program)
        self.backend = SimpleNamespace(name=f"replay of {record['command'].get('backend')}, no simulator")
        self.steps = record["steps"]
        self.observers: list = []
        self.reset()

    # -- the engine's face ----------------------------------------------------------------------
    def reset(self) -> None:
        self.index = 0
        self._sync()

    def _sync(self) -> None:
        """Rebuild what the steps before ``index`` left (after ``reset`` or ``back``)."""
        self.trace = Trace(0)  # the interpreter's trace type: 'where' and the rest read it alike
        self.env = {}
        self.last_path, self.last_run, self.last_icps = None, None, {}
        for s in self.steps[: self.index]:
            self._take(s)
        self._where()

    def _take(self, s: dict) -> None:
        """Add step ``s`` to what has been replayed (one step: replay stays linear in steps)."""
        self.trace.record(_entry(s))
        self.env.update(s["env"])
        if s["kind"] == "run":
            self.last_path, self.last_run, self.last_icps = s["path"], _entry(s), dict(s["icps"])

    def _where(self) -> None:
        result = self.record["result"]
        if self.index < len(self.steps):
            self.current, self.done = self.steps[self.index]["state"], False
        elif result["status"] == "finished" and self.steps:
            self.current, self.done = self.steps[-1]["state"], True
        else:
            self.current = result.get("state") or (self.steps[-1]["next"] if self.steps else self.fsm.start)
            self.done = False

    @property
    def state(self):
        return self.fsm.states[self.current]

    def hand(self) -> np.ndarray:
        return self.steps[self.index - 1]["hand"] if self.index else self.record["start"]["hand"]

    def step(self) -> TraceEntry:
        if self.done:
            raise HilaRuntimeError("the recorded program has finished; 'reset' to replay it again")
        if self.index >= len(self.steps):
            result = self.record["result"]
            if result["status"] == "failed":
                raise HilaRuntimeError(f"the recorded run failed here:\n{result['error']}")
            raise HilaRuntimeError("the recording ends here (the run was stopped)")
        s = self.steps[self.index]
        self.index += 1
        self._take(s)
        self._where()
        return _entry(s)

    def run(self, until=None, max_steps: int | None = None, each=None) -> list[TraceEntry]:
        """Replay steps until the end of the recording, ``max_steps`` steps, or just before a
        state ``until`` (a name or a predicate on it), as :meth:`Interpreter.run` does."""
        stop = until if callable(until) or until is None else (lambda name: name == until)
        done: list[TraceEntry] = []
        while not self.done and self.index < len(self.steps) and (max_steps is None or len(done) < max_steps):
            if stop is not None and done and stop(self.current):
                break
            done.append(self.step())
            if each is not None:
                each(done[-1])
        return done

    def _guard(self, state, action):
        return action()

    def bind(self, st) -> dict:
        """The ICPs the next recorded step bound, when it is ``st``."""
        if self.index < len(self.steps) and self.steps[self.index]["state"] == st.name:
            return self.steps[self.index]["icps"]
        raise HilaRuntimeError(f"the recording has no binding for {st.name} here")

    def keep_history(self) -> None:
        return None  # a recording can always go back

    def back(self, n: int = 1) -> str:
        if not self.index:
            raise HilaRuntimeError("nothing to go back to: the replay is at its start")
        if not 1 <= n <= self.index:
            raise HilaRuntimeError(f"can go back 1 to {self.index} step(s), not {n}")
        self.index -= n
        self._sync()
        return f"back {n} step{'s' if n > 1 else ''}: at {self.current}"

    def reload(self, checked, fsm) -> str:
        raise HilaRuntimeError("a recording cannot be reloaded: it replays what ran",
                               hint="to try a change, run the program with 'hila repl' and use reload there")

    def explain(self) -> list[str]:
        """OSILA again on the recorded ICPs and constraints (the current state, or the last run)."""
        if self.index < len(self.steps) and "osila" in self.steps[self.index]:
            s, how = self.steps[self.index], "about to run"
        else:
            runs = [s for s in self.steps[: self.index] if "osila" in s]
            if not runs:
                raise HilaRuntimeError("nothing to explain yet: no run state is current or has run")
            s = runs[-1]
            how = f"step {s['step']}"
        return explain_recorded(self.record, s, title=f"{s['state']} (line {s['line']}), {how}")


def recorded_template(record: dict, st):
    """The (sub-)template a recorded run state ran, from the template text in the recording."""
    # lazy: loads yaml, which importing this module does not
    import yaml

    entry = record["templates"][st.template]
    template = template_from_dict(yaml.safe_load(entry["text"]), entry["file"])
    return template if st.tag is None else template.sub(st.tag)


def explain_recorded(record: dict, s: dict, *, title: str) -> list[str]:
    st = FSM.from_dict(record["fsm"]).states[s["state"]]
    template = recorded_template(record, st)
    osila = s["osila"]
    constraints = [Constraint(np.asarray(c["point"], float), c["radius"], c["name"]) for c in osila["constraints"]]
    options = {k: (tuple(v) if isinstance(v, list) else v) for k, v in osila["options"].items()}
    binding = {k: s["icps"].get(k) for k in template.icps}
    return explain_run(template, binding, None, constraints, options, title=title)


# ------------------------------------------------------------------------------------ verify

def _max_difference(a, b) -> tuple[float, int]:
    d = np.abs(np.asarray(a, float) - np.asarray(b, float)).max(axis=-1)
    i = int(np.argmax(d))
    return float(d[i]), i


def differing_points(recorded, now) -> tuple[str, str]:
    """``recorded`` and ``now`` (points) written with the fewest decimals (3 to 12) that tell
    them apart, so a difference is never shown as the same numbers twice."""
    def text(p, digits):
        return "(" + ", ".join(f"{float(v):.{digits}f}" for v in np.asarray(p, float).reshape(-1)) + ")"

    for digits in range(3, 13):
        a, b = text(recorded, digits), text(now, digits)
        if a != b:
            return a, b
    return text(recorded, 17), text(now, 17)


def _path_difference(what: str, recorded, now, tolerance: float) -> str | None:
    if recorded is None or now is None:
        return None if recorded is None and now is None else f"{what}: recorded {'none' if recorded is None else 'a path'}, now {'none' if now is None else 'a path'}"
    if recorded.shape != now.shape:
        return f"{what}: recorded {len(recorded)} points, now {len(now)}"
    d, i = _max_difference(recorded, now)
    if d > tolerance:
        a, b = differing_points(recorded[i], now[i])
        return f"{what} differs by up to {d * 1000:.3g} mm (point {i}: recorded {a}, now {b})"
    return None


def step_difference(s: dict, entry: TraceEntry, tolerance: float) -> str | None:
    """How the re-run's ``entry`` differs from the recorded step ``s`` (the first thing), or None."""
    for key in ("state", "kind", "next"):
        if getattr(entry, key) != s[key]:
            return f"{key}: recorded {s[key]}, now {getattr(entry, key)}"
    if list(entry.icps) != list(s["icps"]):
        return f"ICPs bound: recorded {', '.join(s['icps'])}, now {', '.join(entry.icps)}"
    for k, v in s["icps"].items():
        d = float(np.abs(entry.icps[k] - v).max())
        if d > tolerance:
            a, b = differing_points(v, entry.icps[k])
            return f"ICP {k}: recorded {a}, now {b} (up to {d * 1000:.3g} mm apart)"
    for what, key in (("the planned path", "path"), ("the executed path", "executed")):
        why = _path_difference(what, s[key], getattr(entry, key), tolerance)
        if why:
            return why
    why = replan_difference(s.get("replans"), entry.replans, tolerance)
    if why:
        return why
    a, b = s["value"], entry.value
    same = (isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape
            and np.abs(a - b).max() <= tolerance) or (not isinstance(a, np.ndarray) and a == b)
    if not same:
        if isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape:
            ra, rb = differing_points(a, b)
            return f"value: recorded {ra}, now {rb} (up to {float(np.abs(a - b).max()) * 1000:.3g} mm apart)"
        return f"value: recorded {a!r}, now {b!r}"
    if entry.text != s["text"]:
        return f"trace text: recorded {s['text']!r}, now {entry.text!r}"
    return None


def replan_difference(recorded, now, tolerance: float) -> str | None:
    """How a streamed run's re-plans differ from the recorded ones (the first thing), or None.
    ``recorded``: the record's dicts (None: not streamed); ``now``: :class:`~hila_lang.engine.tracking.Replan` s."""
    if recorded is None and now is None:
        return None
    recorded, now = recorded or [], now or []
    if len(recorded) != len(now):
        return f"re-plans: recorded {len(recorded)}, now {len(now)}"
    for i, (r, n) in enumerate(zip(recorded, now), 1):
        if abs(r["t"] - n.t) > 1e-9 or r["stamp"] != n.stamp or r["index"] != n.index or r["lifted"] != n.lifted:
            return (f"re-plan {i}: recorded at {r['t']:.3f} s from point {r['stamp']}, now at {n.t:.3f} s from point "
                    f"{n.stamp}")
        tail = np.asarray(r["tail"], dtype=float).reshape(-1, 3)
        why = _path_difference(f"re-plan {i}'s new tail", tail, np.asarray(n.tail, dtype=float), tolerance)
        if why:
            return why
    return None


def changed_files(record: dict) -> list[str]:
    """Notes on the program and templates that differ from the recording now (or are gone)."""
    notes = []
    files = [("program", record["program"]["path"], record["program"]["sha256"])]
    files += [(f"template {alias}", t["file"], t["sha256"]) for alias, t in record["templates"].items()]
    for what, file, digest in files:
        path = Path(file)
        if not path.is_file():
            notes.append(f"{what} ({file}) is gone")
        elif sha256(path.read_bytes()) != digest:
            notes.append(f"{what} ({file}) has changed since the recording")
    return notes


def verify(record: dict, *, tolerance: float = 1e-6) -> tuple[bool, list[str]]:
    """Run the recorded command again and compare; returns (no difference, report lines)."""
    lines = [f"note: {n}" for n in changed_files(record)]
    command, steps = record["command"], record["steps"]
    program = record["program"]["file"]
    if not Path(program).is_file():
        program = record["program"]["path"]
    with tempfile.TemporaryDirectory(prefix="hila-verify-") as out:
        options = RunOptions(seed=int(command["seed"]), out=Path(out), settings=dict(command["settings"]),
                             stdin=io.StringIO("".join(record.get("input", []))), stdout=io.StringIO())
        interp = prepare(program, options, command.get("backend"))
        try:
            if record.get("eyes") and interp.backend.eyes is not None:  # the same calls as when recorded
                interp.observers.append(lambda e: interp.backend.eyes.camera_image("left") if e.kind == "run" else None)
            for s in steps:
                where = f"step {s['step']}, state {s['state']} ({record['program']['file']}:{s['line']})"
                try:
                    entry = interp.step()
                except HilaError as exc:
                    lines.append(f"first difference at {where}: the re-run failed there, the recording went on:\n{exc}")
                    return False, lines
                why = step_difference(s, entry, tolerance)
                if why:
                    lines.append(f"first difference at {where}: {why}")
                    return False, lines
            result = record["result"]
            n = len(steps) + 1
            limit = command.get("max_steps") or 0  # 0 / None: no limit (recordings before it was kept)
            if result["status"] == "failed" and result.get("exit") in INTERRUPTED_EXITS:
                # stopped by Ctrl-C (SIGTERM, SIGHUP): the re-run is stopped at the same place
                lines.append(f"note: the recording was interrupted at step {n}; the re-run is stopped there too")
            elif result["status"] == "failed" and limit and len(steps) >= limit:
                if interp.done:  # the recording hit --max-steps; the re-run must not have finished either
                    lines.append(f"first difference at step {n}: the recording stopped at the step limit "
                                 f"({limit}), the re-run finished")
                    return False, lines
            elif result["status"] == "failed":
                try:
                    interp.step()
                except HilaError as exc:
                    if str(exc) != result["error"]:
                        lines.append(f"first difference at step {n}: both fail, recorded:\n{result['error']}\nnow:\n{exc}")
                        return False, lines
                else:
                    lines.append(f"first difference at step {n}: the recording failed there, the re-run went on")
                    return False, lines
            elif result["status"] == "finished" and not interp.done:
                lines.append(f"first difference at step {n}: the recording finished, the re-run goes on at {interp.current}")
                return False, lines
        finally:
            finish(interp)
    lines.append(f"no difference: {len(steps)} steps verified (tolerance {tolerance * 1000:g} mm)")
    return True, lines
