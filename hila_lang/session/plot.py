"""Draw a generated path with OpenCV (matplotlib is not a dependency): top and side views.

One orientation everywhere (``hila show``'s text picture, ``--plot``, a run's ``path.png``): the
paper **as the robot sees it** -- from above and behind the robot, so what is farther from it is
up and its right is to the right.  For a 3-D path (world frame) that is +x up and -y to the
right; for a 2-D template (a drawing on a sheet, x right, y up, as the studio shows it and as it
is laid on the robot's paper: :meth:`hila_lang.sim.surface.Surface.to_world`) it is x to the right
and y up.  :func:`paper_view` is that map.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.fileio import write_png

#: how the top view is oriented, in words (titles and ``hila show``)
PAPER_VIEW = "the paper as the robot sees it: farther up, its right to the right"


def paper_view(points, dim: int | None = None) -> np.ndarray:
    """Points (N, D) or (D,) -> (N, 2) or (2,): (right, up) on the paper as the robot sees it
    (module docstring).  ``dim`` is the path's D when ``points`` were padded (2-D ICPs)."""
    p = np.asarray(points, dtype=float)
    d = dim or p.shape[-1]
    return p[..., :2].copy() if d == 2 else np.stack([-p[..., 1], p[..., 0]], axis=-1)


class _Labels:
    """Labels placed apart: each goes at the first of eight places around its point, then the
    same eight twice and three times as far, whose box overlaps no label placed before and
    stays inside its panel (else the least crowded one)."""

    OFFSETS = tuple((dx * k, dy * k) for k in (1, 2, 3)
                    for dx, dy in ((6, -4), (6, 12), (-6, -4), (-6, 12), (0, -10), (0, 18), (10, 4), (-10, 4)))

    def __init__(self) -> None:
        self.boxes: list[tuple[int, int, int, int]] = []

    def put(self, img, text: str, at: tuple[int, int], colour, panel: tuple[int, int, int, int]) -> None:
        # lazy: loads cv2, which importing this module does not
        import cv2

        (w, h), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1)
        best, best_overlap = None, None
        for dx, dy in self.OFFSETS:
            x = at[0] + dx if dx >= 0 else at[0] + dx - w
            if dx == 0:
                x = at[0] - w // 2
            y = at[1] + dy
            box = (x, y - h, x + w, y + 2)
            inside = panel[0] <= box[0] and box[2] <= panel[2] and panel[1] <= box[1] and box[3] <= panel[3]
            overlap = sum(max(0, min(box[2], b[2]) - max(box[0], b[0])) * max(0, min(box[3], b[3]) - max(box[1], b[1]))
                          for b in self.boxes) + (0 if inside else 10 ** 6)
            if best is None or overlap < best_overlap:
                best, best_overlap = box, overlap
            if overlap == 0:
                break
        self.boxes.append(best)
        cv2.putText(img, text, (best[0], best[3] - 2), cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)


def plot_path(path: np.ndarray, file, *, icps: dict | None = None, executed: np.ndarray | None = None,
              title: str = "", marks: list | None = None, legend: str = "blue planned, red executed",
              zoom=None) -> Path:
    """Write a PNG with the path from above, the paper as the robot sees it (:func:`paper_view`),
    and from the side (forward to the right, z up; a 2-D path has no side).

    ``path`` (T, D) in metres is drawn blue with its start as a green dot; ``executed`` (T', D),
    if given, red; ``icps`` (name -> (D,)) as labelled black circles; ``marks`` a list of
    ``(index, label)``: the path point ``index`` drawn as an orange tick with ``label`` beside it
    (a template's cuts with the tag that starts there, a run's states where each starts).
    ``zoom`` (indices of ``path``, e.g. where the pen touches) adds a panel fitted to those
    points, so a small mark is not lost when a far point (the hand's start) sets the scale.
    Labels are placed apart (:class:`_Labels`).
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    path = np.asarray(path, dtype=float)
    if path.ndim != 2 or path.shape[1] not in (2, 3) or len(path) == 0:
        raise InputError(f"expected a path of shape (T, 3) to plot, got {path.shape}")
    dim = path.shape[1]
    icps = {k: np.asarray(v, float)[:dim] for k, v in (icps or {}).items()}
    executed = None if executed is None else np.asarray(executed, float)[:, :dim]
    zoom = None if zoom is None or len(zoom) < 2 else np.asarray(zoom, int)
    size, pad, top = 400, 30, 20
    panels = [("top", f"top: {PAPER_VIEW}", None)]
    if zoom is not None:
        panels.append(("top", "the drawing (pen down), zoomed", zoom))
    if dim == 3:
        panels.append(("side", "side: forward to the right, z up", None))
    img = np.full((size + 2 * pad + top, len(panels) * (size + 2 * pad), 3), 255, np.uint8)
    for k, (kind, label, fit) in enumerate(panels):
        x0 = k * (size + 2 * pad)
        _panel(img, x0, (pad, top, size), kind, label, path, executed, icps, marks, fit, dim)
    shown = max(float(np.ptp(paper_view(path), axis=0).max()), 1e-6)
    cv2.putText(img, f"{title}  ({len(path)} points, {shown * 100:.1f} cm across; {legend})", (pad, 16),
                cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)

    return write_png(file, img, bgr=True)


def _panel(img, x0: int, frame, kind: str, label: str, path, executed, icps: dict, marks, fit, dim: int) -> None:
    """One view into ``img`` at column ``x0``: ``kind`` top (:func:`paper_view`) or side (x, z),
    fitted to the points ``fit`` indexes (with the ICPs near them), or to everything."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    pad, top, size = frame

    def view(p):
        p = np.asarray(p, float)
        return paper_view(p, dim) if kind == "top" else p[..., [0, 2]]

    pts = view(path)
    names = list(icps)
    spots = [view(icps[n]) for n in names]
    if fit is None:
        region = np.vstack([pts] + ([view(executed)] if executed is not None else []) + [s[None] for s in spots])
    else:
        region = pts[fit]
        reach = float(np.ptp(region, axis=0).max()) or 1e-3
        mid = (region.min(0) + region.max(0)) / 2
        near = [s for s in spots if np.abs(s - mid).max() < 1.5 * reach]
        region = np.vstack([region] + [s[None] for s in near])
    lo, hi = region.min(0), region.max(0)
    span = max(float((hi - lo).max()), 1e-6) * 1.15
    mid = (lo + hi) / 2
    box = (x0 + pad, top + pad, x0 + pad + size, top + pad + size)

    def px(q):
        u = (q[0] - mid[0]) / span + 0.5
        v = (q[1] - mid[1]) / span + 0.5
        return int(round(x0 + pad + u * size)), int(round(top + pad + (1 - v) * size))

    canvas = img[box[1]:box[3] + 1, box[0]:box[2] + 1]
    sub = np.full_like(canvas, 255)
    offset = np.array([box[0], box[1]])

    def local(q):
        return tuple(int(v) for v in np.array(px(q)) - offset)

    for line, colour in ((pts, (200, 80, 0)), (None if executed is None else view(executed), (0, 0, 220))):
        if line is not None and len(line) > 1:
            cv2.polylines(sub, [np.array([local(q) for q in line], np.int32)], False, colour, 1, cv2.LINE_AA)
    cv2.circle(sub, local(pts[0]), 4, (0, 160, 0), -1)
    canvas[:] = sub  # drawn inside the frame only: a zoomed panel crops what lies outside
    cv2.rectangle(img, box[:2], box[2:], (200, 200, 200), 1)
    cv2.putText(img, label, (x0 + pad, top + pad - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (60, 60, 60), 1, cv2.LINE_AA)
    labels = _Labels()
    inside = (box[0], box[1], box[2], box[3])

    def shown(c):
        return box[0] <= c[0] <= box[2] and box[1] <= c[1] <= box[3]

    for c, text in _merged([(px(pts[int(i)]), str(t)) for i, t in marks or ()]):
        if shown(c):
            cv2.drawMarker(img, c, (0, 140, 255), cv2.MARKER_TILTED_CROSS, 9, 2)
            labels.put(img, text, c, (0, 110, 230), inside)
    for name, spot in zip(names, spots):
        c = px(spot)
        if shown(c):
            cv2.circle(img, c, 5, (0, 0, 0), 1)
            labels.put(img, name, c, (0, 0, 0), inside)


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
