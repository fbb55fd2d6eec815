"""``--out DIR`` in every world: the run's picture and report, for a world that writes none itself.

The tic-tac-toe and letters worlds write their own output folders (they hold an ``outputs``
attribute).  Any other world -- the default scripted one, a third-party plug-in -- gets this one
when ``--out`` is given: :func:`run_outputs` makes the folder and proves it writable before the
run (a bad ``--out`` is refused before anything moves), :func:`write_run_outputs` writes, when
the run ends (also when it failed or was stopped: what was done is kept):

- ``path.png``: every run state's planned path (blue) and the path the back end executed (red),
  the scene points bound to its ICPs (black circles), top and side views (:func:`hila_lang.session.plot.plot_path`), each state's start marked and
  named ``NAME STEP`` (the state's last name part and the step number of its trace line; states
  that start at one place share a label: ``reach 2,5,8``);
- ``report.json``: the program, world, back end, seed, the counts, how the run ended, and one
  record per run state (step, state, program line, template, pen, points, where the plan starts
  and ends, where the hand ended and how far that is from the plan's end, in mm).

Only the newest :data:`~hila_lang.language.limits.TRACE_KEEP` trace entries are kept by the
interpreter, so a very long run's picture shows its last states (the report says how many).
"""

from __future__ import annotations

import json

import numpy as np

from ..core.fileio import OutputFolder
from .plot import plot_path

#: every file this writes (a reused folder loses the ones a run did not write)
FILES = ("path.png", "report.json")


def run_outputs(world, options):
    """The :class:`~hila_lang.core.fileio.OutputFolder` for ``options.out``, made now; None when
    ``--out`` is not given or the world writes its own (it has an ``outputs`` attribute)."""
    if options.out is None or hasattr(world, "outputs"):
        return None

    return OutputFolder(options.out, "run-{time}", owned=FILES)


def _point(p) -> list[float]:
    return [round(float(v), 5) for v in p]


def run_report(interp, seed: int | None = None) -> dict:
    """The run as JSON-ready data (see the module docstring)."""
    trace = interp.trace
    runs = [e for e in trace if e.kind == "run" and e.path is not None]
    last = trace[-1] if len(trace) else None
    states = []
    for e in runs:
        planned = np.asarray(e.path, dtype=float)
        executed = None if e.executed is None else np.asarray(e.executed, dtype=float)
        st = interp.fsm.states.get(e.state)
        states.append({
            "step": e.step, "state": e.state, "line": e.line,
            "template": getattr(st, "template", None),
            "pen_down": bool(e.pen_down),
            "points": len(planned),
            "planned_start": _point(planned[0]), "planned_end": _point(planned[-1]),
            "executed_end": None if executed is None or not len(executed) else _point(executed[-1]),
            "end_error_mm": None if executed is None or not len(executed)
            else round(float(np.linalg.norm(executed[-1] - planned[-1])) * 1000, 3),
        })
    return {
        "program": str(interp.fsm.file), "world": interp.fsm.world, "backend": interp.backend.name,
        "robot": getattr(getattr(interp.backend, "robot", None), "name", None), "seed": seed,
        "steps": len(trace), "run_states": trace.kinds.get("run", 0) if hasattr(trace, "kinds") else len(runs),
        "finished": bool(interp.done),
        "stopped": None if last is None or not last.error else {"step": last.step, "state": last.state,
                                                                "line": last.line, "error": last.error},
        "states_kept": len(runs),
        "states": states,
    }


#: at most this many ICPs are drawn on the picture (the newest states' first)
MAX_DRAWN_ICPS = 24


def _scene_points(runs) -> dict:
    """The ICPs the run states were bound to (not their ``start``/``end``), each once: a name
    bound to different points in different states is drawn as ``NAME@STEP``."""
    drawn: dict[str, np.ndarray] = {}
    for e in reversed(runs):
        for name, p in (e.icps or {}).items():
            p = np.asarray(p, dtype=float).reshape(-1)
            if name in ("start", "end") or p.shape != (3,) or len(drawn) >= MAX_DRAWN_ICPS:
                continue
            if name in drawn and not np.allclose(drawn[name], p, atol=1e-4):
                name = f"{name}@{e.step}"
            drawn.setdefault(name, p)
    return drawn


def write_run_outputs(folder, interp, seed: int | None = None, stdout=None) -> dict:
    """Write ``path.png`` (when a run state moved the hand) and ``report.json`` into ``folder``."""
    report = run_report(interp, seed)
    runs = [e for e in interp.trace if e.kind == "run" and e.path is not None]
    if runs:
        planned = np.vstack([np.asarray(e.path, dtype=float) for e in runs])
        executed = [np.asarray(e.executed, dtype=float) for e in runs if e.executed is not None and len(e.executed)]
        starts = np.cumsum([0] + [len(e.path) for e in runs[:-1]])
        marks = [(int(i), f"{e.state.rsplit('/', 1)[-1]} {e.step}") for i, e in zip(starts, runs)]
        plot_path(planned, folder.file("path.png"), executed=np.vstack(executed) if executed else None,
                  marks=marks, icps=_scene_points(runs), title=f"{interp.fsm.file} ({interp.backend.name})",
                  legend="blue planned, red executed, x: where each state starts")
    folder.write_text("report.json", json.dumps(report, indent=2) + "\n")
    folder.close()
    if stdout is not None:
        print(f"outputs written to {folder.path}", file=stdout, flush=True)
    report["out"] = str(folder.path)
    return report
