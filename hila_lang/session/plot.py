"""Draw a generated path with OpenCV (matplotlib is not a dependency): top and side views."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import InputError


def plot_path(path: np.ndarray, file, *, icps: dict | None = None, executed: np.ndarray | None = None,
              title: str = "", marks: list | None = None, legend: str = "blue planned, red executed") -> Path:
    """Write a PNG with the path seen from above as the robot faces it (x forward up, y to the
    left) and from the side (x, z).

    ``path`` (T, 3) in metres is drawn blue with its start as a green dot; ``executed`` (T', 3),
    if given, red; ``icps`` (name -> (3,)) as labelled black circles; ``marks`` a list of
    ``(index, label)``: the path point ``index`` drawn as an orange tick with ``label`` beside it
    (a template's cuts with the tag that starts there, a run's states where each starts).
    """
    import cv2

    path = np.asarray(path, dtype=float)
    if path.ndim != 2 or path.shape[1] not in (2, 3) or len(path) == 0:
        raise InputError(f"expected a path of shape (T, 3) to plot, got {path.shape}")
    if path.shape[1] == 2:
        path = np.column_stack([path, np.zeros(len(path))])
    icps = {k: np.resize(np.asarray(v, float), 3) for k, v in (icps or {}).items()}
    everything = np.vstack([path] + list(icps.values()) + ([executed] if executed is not None else []))
    lo, hi = everything.min(0), everything.max(0)
    span = max(float((hi - lo).max()), 1e-6) * 1.1
    mid = (lo + hi) / 2
    size, pad = 400, 30
    img = np.full((size + 2 * pad + 20, 2 * (size + 2 * pad), 3), 255, np.uint8)
    # the top view as the robot faces the table: forward (+x) up the image, its left (+y) to the left
    views = [((1, 0), "top, as the robot faces it (x forward up, y left)", 0, -1),
             ((0, 2), "side (x right, z up)", size + 2 * pad, 1)]

    def px(p, view, x0):
        axes, flip = view
        u = flip * (p[axes[0]] - mid[axes[0]]) / span + 0.5
        v = (p[axes[1]] - mid[axes[1]]) / span + 0.5
        return int(x0 + pad + u * size), int(20 + pad + (1 - v) * size)

    for axes_of, label, x0, flip in views:
        view = (axes_of, flip)
        cv2.rectangle(img, (x0 + pad, 20 + pad), (x0 + pad + size, 20 + pad + size), (200, 200, 200), 1)
        cv2.putText(img, label, (x0 + pad, 20 + pad - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (60, 60, 60), 1, cv2.LINE_AA)
        for line, colour in ((path, (200, 80, 0)), (executed, (0, 0, 220))):
            if line is not None and len(line) > 1:
                pts = np.array([px(p, view, x0) for p in line], np.int32)
                cv2.polylines(img, [pts], False, colour, 1, cv2.LINE_AA)
        cv2.circle(img, px(path[0], view, x0), 4, (0, 160, 0), -1)
        for k, (c, text) in enumerate(_merged([(px(path[int(i)], view, x0), str(t)) for i, t in marks or ()])):
            cv2.drawMarker(img, c, (0, 140, 255), cv2.MARKER_TILTED_CROSS, 9, 2)
            # labels alternate below and above their tick: neighbouring ticks keep readable labels
            cv2.putText(img, text, (c[0] + 6, c[1] + (14 if k % 2 == 0 else -8)),
                        cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 110, 230), 1, cv2.LINE_AA)
        for name, p in icps.items():
            c = px(p, view, x0)
            cv2.circle(img, c, 5, (0, 0, 0), 1)
            cv2.putText(img, name, (c[0] + 6, c[1] - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, f"{title}  ({len(path)} points, view {span * 100:.1f} cm; {legend})", (pad, 16),
                cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    from ..core.fileio import write_png

    return write_png(file, img, bgr=True)


def _merged(marks: list, near: int = 6) -> list:
    """Marks ``(pixel, label)`` within ``near`` pixels of an earlier one joined into one label:
    ``"reach 2"``, ``"reach 5"`` -> ``"reach 2,5"`` (same first word), else ``"a; b"``."""
    groups: list[tuple[tuple[int, int], list[str]]] = []
    for c, text in marks:
        for g, texts in groups:
            if abs(g[0] - c[0]) <= near and abs(g[1] - c[1]) <= near:
                texts.append(text)
                break
        else:
            groups.append((c, [text]))
    out = []
    for c, texts in groups:
        heads = {t.split(" ", 1)[0] for t in texts}
        if len(texts) > 1 and len(heads) == 1 and all(" " in t for t in texts):
            out.append((c, f"{heads.pop()} " + ",".join(t.split(" ", 1)[1] for t in texts)))
        else:
            out.append((c, "; ".join(texts)))
    return out
