"""The output folder of a game: images, pen traces, the FSM and ``report.json``.

Files (all written atomically through :mod:`hila_lang.core.fileio`):

- ``report.json``: seed, opponent, who started, the moves, the final board, the result, per-mark
  R of each drawn mark against the demonstrated one (after similarity alignment), how far each
  mark strays outside its cell (on the sheet where it was then; for a mark drawn while the
  sheet moved, where its ink lies on the sheet in its final position), each mark's re-plans
  (``track``: time, how far the cell moved, from which point, the blend, whether the pen lifted),
  tracking error (planned against executed pen path), wall time, the perturbations (settings and
  what happened when, the sheet's moves during strokes included),
  the referee's ``fouls``, and ``vision``: whether the robot read the board with its eye cameras
  or played blind (dry back end); with eyes, the robot's mark (``robot_mark``: the pen-down
  sub-templates it reads its marks by), every ``misread`` the referee found (look, cell, what the
  robot saw, what was there), every ``unclear`` cell (ink the robot said it could not tell,
  ``"?"``: not guessed), the perceived grid corners' distance from the true ones (median and
  max, mm), the table height the robot estimated and its error, and per look the board it read
  (the same reading it played on), the views it took and why;
- ``eye.png``: the final left eye-camera image (PyBullet back end only);
- ``top.png``: the board from above with the planned paths (green) and the executed pen paths
  (blue) drawn over it, each where it lies on the sheet now (a stroke drawn while the sheet moved
  shows its executed path only: its plan changed with the sheet) -- a rendered camera view with the PyBullet back end (the arm may hide
  part of the board), the paper's ink otherwise;
- ``paper.png``: the sheet straight from above -- its ink (what the cameras see on the paper)
  with the same planned and executed paths over it, never hidden by the arm;
- ``traces.csv``: every pen path: ``source,state,pen_down,kind,index,x,y,z`` (metres);
- ``fsm.dot``: the program's state machine (when the runner hands it over).

The default folder is ``runs/game-<UTC time>-seed<N>``, made fresh (a suffix is added when it
exists).
"""

from __future__ import annotations

import io
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from ...core.fileio import OutputFolder
from ...sim.canvas import Canvas, INK_RGB
from ...sim.motion import carried
from . import rules as ttt
from .marks import on_paper, tracking_error
from .referee import pose_of

PLANNED_BGR = (60, 170, 60)
EXECUTED_BGR = (200, 80, 20)


def _mm(x: float | None) -> float | None:
    return None if x is None else round(1000.0 * float(x), 3)


def build_report(world, trace=None) -> dict[str, Any]:
    """The game's summary as plain JSON-ready data (see the module docstring)."""
    errors = []
    for st in world.states:
        if st["planned"] is not None and st["executed"] is not None and len(st["executed"]):
            errors.append(tracking_error(st["planned"], st["executed"], prefix=True))
    all_err = np.concatenate(errors) if errors else None
    marks = []
    for m in world.marks:
        marks.append({
            "cell": m["cell"],
            "intended_cell": m["intended_cell"],
            "state": m["state"],
            "r": None if m["r"] is None else round(m["r"], 4),
            "r_planned": None if m["r_planned"] is None else round(m["r_planned"], 4),
            "outside_cell_mm": _mm(m["outside_cell_m"]),
            "contact_points": m["contact_points"],
            "tracking_median_mm": _mm(m.get("tracking_median_m")),
            "tracking_max_mm": _mm(m.get("tracking_max_m")),
            "replans": m.get("replans") or [],
        })
    rs = [m["r"] for m in marks if m["r"] is not None]
    backend = world.backend
    return {
        "game": "tictactoe",
        "seed": world.seed,
        "opponent": world.opponent.name,
        "first": world.first,
        "backend": None if backend is None else backend.name,
        "robot": getattr(getattr(backend, "robot", None), "name", None),
        "park": [round(float(v), 5) for v in world.park],
        "scene": {
            "grid_center": list(world.referee.layout.grid_center),
            "grid_size": world.referee.layout.grid_size,
            "grid_rotation_deg": round(float(np.degrees(world.referee.layout.grid_rotation)), 3),
            "surface_z": world.referee.layout.surface_z,
        },
        "perturbations": {
            "board.bump": world.referee.bump, "light": world.referee.light,
            "board.slide": world.referee.motion.slide, "board.turn": world.referee.motion.turn,
            "board.jump": world.referee.motion.jump, "sheet_moves": world.referee.motion.moves,
            "crosses": "sloppy" if world.referee.sloppy else "neat",
            "eyes.noise": None if not world.sees else float(backend.eyes.noise),
            "events": world.referee.perturbations,
        },
        "moves": world.moves,
        "board": list(world.board),
        "board_text": ttt.render(world.board).splitlines(),
        "result": world.result() or "unfinished",  # a game stopped (Ctrl-C) before its end, as the README says
        "winning_line": ttt.winning_line(world.board),
        "marks": marks,
        "marks_outside_cell": sum(1 for m in world.marks if m["outside_cell_m"] > 0),
        "fouls": world.referee.fouls,
        "r_min": None if not rs else min(rs),
        "r_mean": None if not rs else round(float(np.mean(rs)), 4),
        "tracking_error_mm": None if all_err is None else {
            "median": _mm(np.median(all_err)), "max": _mm(all_err.max()),
            "states": len(errors),
        },
        "vision": vision_summary(world),
        "fsm_states_run": len(world.states),
        "trace_entries": None if trace is None else len(trace),
        "wall_time_s": round(time.perf_counter() - world.t0, 3),
    }


def vision_summary(world) -> dict[str, Any]:
    """How the robot knew the board: its eye cameras (the referee's scores of every look) or,
    without cameras, blind play from the moves it knew of."""
    sightings, looks = world.sightings, world.referee.looks
    if not sightings:
        return {"board_read_by": "memory", "corners_from": "the board's layout (no eye cameras)", "misreads": []}
    errors = np.concatenate([look["corner_errors_m"] for look in looks]) if looks else np.zeros(1)
    return {
        "board_read_by": "vision",
        "corners_from": "eye cameras",
        "looks": len(sightings),
        "images": sum(len(s["views"]) for s in sightings),
        "robot_mark": None if world.player.mark is None else world.player.mark.names,
        "misreads": [dict(m) for m in world.referee.misreads],
        "unclear": [dict(u) for u in world.referee.unclear],
        "unsure": [{"look": s["look"], "cells": list(s["unsure"])} for s in sightings if s["unsure"]],
        "corner_error_mm": {"median": _mm(np.median(errors)), "max": _mm(errors.max())},
        "corner_error_max_mm": _mm(errors.max()),
        "table_height_m": round(float(sightings[-1]["surface_z"]), 5),
        "table_error_max_mm": _mm(max(abs(look["table_error_m"]) for look in looks)) if looks else None,
        "arm_lifted": sum(s["arm"] == "lifted" for s in sightings),
        "arm_aside": sum(s["arm"] == "aside" for s in sightings),
        "seconds": round(sum(s["seconds"] for s in sightings), 3),
        "per_look": [{"look": look["look"], "moves_before": look["moves_before"], "views": look["views"],
                      "board": look["board"], "doubts": sight["doubts"], "misreads": look["misreads"],
                      "corner_error_median_mm": _mm(look["corner_error_median_m"]),
                      "corner_error_max_mm": _mm(look["corner_error_max_m"]),
                      "table_error_mm": _mm(look["table_error_m"])}
                     for look, sight in zip(looks, sightings)],
    }


#: every file a game may write (a file of an earlier game that this one does not write is removed)
FILES = ("eye.png", "fsm.dot", "paper.png", "report.json", "top.png", "traces.csv")


def output_folder(out: Path | str | None, seed: int):
    """``out`` as given, or a fresh ``runs/game-<UTC time>-seed<N>[-k]`` folder: an
    :class:`~hila_lang.core.fileio.OutputFolder`, created and proved writable."""
    return OutputFolder(out, f"game-{{time}}-seed{seed}", owned=FILES)


def traces_csv(world) -> str:
    """Every planned and executed path of the robot and every opponent stroke, as CSV text."""
    buf = io.StringIO()
    buf.write("source,state,pen_down,kind,index,x,y,z\n")
    for st in world.states:
        for kind in ("planned", "executed"):
            pts = st[kind]
            if pts is None:
                continue
            for i, (x, y, z) in enumerate(np.asarray(pts, dtype=float)):
                buf.write(f"robot,{st['state']},{int(st['pen_down'])},{kind},{i},{x:.6f},{y:.6f},{z:.6f}\n")
    for move, strokes in enumerate(world.crosses, start=1):
        for s, stroke in enumerate(strokes):
            for i, (x, y, z) in enumerate(stroke):
                buf.write(f"opponent,cross{move}.{s + 1},1,inked,{i},{x:.6f},{y:.6f},{z:.6f}\n")
    return buf.getvalue()


def _on_sheet_now(points: np.ndarray, then, now) -> np.ndarray:
    """``points`` (N, 3) drawn when the sheet was at ``then`` (a Grid), where they are on the
    sheet at ``now``: the ink moved with the sheet (``board.bump``)."""
    if then is None or then == now:
        return points
    local = then.world_to_grid(points)
    moved = now.grid_to_world(local[:, 0], local[:, 1])
    moved[:, 2] = points[:, 2]
    return moved


def _overlay(rgb: np.ndarray, world, project) -> np.ndarray:
    """``rgb`` with every planned (green) and executed (blue) robot path drawn over it, each
    where it lies on the sheet now."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    scale = 1 if rgb.shape[0] >= 480 else 2
    if scale > 1:
        rgb = cv2.resize(rgb, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    bgr = np.ascontiguousarray(rgb[:, :, ::-1])

    for st in world.states:
        for kind, colour in (("planned", PLANNED_BGR), ("executed", EXECUTED_BGR)):
            pts = st[kind]
            if pts is None or len(pts) < 2 or (kind == "planned" and st.get("during")):
                continue
            pts = np.asarray(pts, dtype=float)
            if st.get("during"):  # drawn while the sheet moved: each sample where it lies on the sheet
                pts = carried(pts, st["during"], pose_of(st["sheet"]))
            pts = _on_sheet_now(pts, st.get("sheet"), world.spec)
            px = np.asarray(project(pts), dtype=float) * scale
            px = px[np.isfinite(px).all(axis=1)]
            if len(px) >= 2:
                cv2.polylines(bgr, [np.round(px).astype(np.int32)], False, colour, 1, cv2.LINE_AA)
    return np.ascontiguousarray(bgr[:, :, ::-1])


def paper_view(world) -> np.ndarray:
    """The sheet seen straight from above (its ink texture, RGB) with the robot's paths over it.

    With the PyBullet back end this is the texture the cameras see; otherwise the ink is
    rasterised here from the pen traces that touched the paper and the opponent's strokes.
    """
    canvas = Canvas(world.spec.paper())
    ink = None if world.backend is None else world.backend.ink
    if ink is not None:
        rgb = np.ascontiguousarray(ink.ink_image()).copy()
    else:
        for st in world.states:
            if st["pen_down"] and st["executed"] is not None:
                touching = on_paper(st["executed"], world.spec.surface_z)
                if len(touching) >= 2:
                    canvas.draw_polyline(touching)
        for strokes in world.crosses:
            for stroke in strokes:
                canvas.draw_polyline(stroke, color=INK_RGB["opponent"])
        rgb = np.ascontiguousarray(canvas.image).copy()
    return _overlay(rgb, world, canvas.to_pixels)


def top_view(world) -> np.ndarray:
    """The board from above (RGB) with planned and executed paths: a rendered camera view
    with the PyBullet back end (the arm moved aside for it: the game ends with the hand over the
    board), else :func:`paper_view`."""
    overview = None if world.backend is None else world.backend.overview
    if overview is None:
        return paper_view(world)
    image = overview.top_view_image(arm_aside=True)
    return _overlay(np.ascontiguousarray(image.rgb).copy(), world, image.project)


def write_outputs(world, report: dict[str, Any]) -> Path:
    """Write the output folder of ``world``'s game (made when the world was); returns the folder."""
    folder = world.outputs if world.outputs is not None else output_folder(world.options.out, world.seed)
    folder.write_text("traces.csv", traces_csv(world))
    folder.write_png("top.png", top_view(world))
    folder.write_png("paper.png", paper_view(world))
    if world.sees:
        folder.write_png("eye.png", world.backend.eyes.camera_image("left").rgb)
    if world.fsm is not None:
        folder.write_text("fsm.dot", world.fsm.to_dot())
    folder.file("report.json")
    report = dict(report, files=folder.names())
    folder.write_text("report.json", json.dumps(report, indent=2) + "\n")
    folder.close()  # the run's files are published together (the manifest names the run)
    return folder.path
