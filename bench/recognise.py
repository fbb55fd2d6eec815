"""Recognising known parts in a new demonstration, on real human handwriting (issue 26 item 4).

Data, made at run time from LASA's development shapes (``hila_lang.evaluation.lasa.DEVELOPMENT``;
the 16 held-out shapes are never touched), seeded:

- each round splits the development shapes into a *library* and *distractors*: ``Line`` is
  always a distractor (a straight line cannot be told from the free moves between shapes by its
  shape; see docs/recognition.md), and three more are drawn at random;
- the library holds one template per library shape, learned from its demonstration 1;
- a query chains 4 shapes drawn at random (about one in four a distractor) from demonstrations 2–7,
  each turned by any angle, scaled 0.5–2×, played at 0.5–2× speed with a non-uniform warp,
  joined by free moves, with tracking noise (:mod:`hila_lang.recognition.composite`), at 50 Hz.

Scores: a reported known part is right when its template is the shape's and it overlaps the
true part by IoU ≥ 0.5; precision P and recall R over known parts; B the median of |start
error| and |end error| of the right ones as a fraction of the part's duration; F the share of
distractor parts of which less than half is reported as known.

Controls, same queries, same threshold rule:

- ``euclid``: a plain Euclidean sliding window (stumpy ``mass``, not normalised) of each
  template at its own length and speed, centred (translation removed, nothing else);
- ``speed-dips``: the speed-dip segmenter (``hila_lang.osila.segmentation.speed_segments``, given the
  TRUE number of pieces, shapes and free moves: an oracle), each piece labelled with the nearest
  template by the same elastic distance, known if under the same threshold.

Timing: one composite of at least 20 s (shapes at their own speed) against a 50-template library
(the first 50 of the 14 x 7 development demonstrations, each its own template), median of 5
runs; the load average and the core count are printed.

``--held-out`` runs the same on the 16 other shapes, as a check after the fact: every default
was chosen on the development shapes and none is changed by it.

    python bench/recognise.py [--rounds 4] [--queries 15] [--held-out]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import time

import numpy as np

from hila_lang.evaluation.lasa import DEVELOPMENT, _package, resample_in_time
from hila_lang.recognition.composite import make
from hila_lang.recognition.library import entries_of
from hila_lang.recognition.search import THRESHOLD, Part, recognise
from hila_lang.recognition.shape import arc_length, arc_resample, elastic_distance, smooth
from hila_lang.osila.template import Template

RATE_IN = 100.0  # the raw LASA samples are re-sampled to this rate first, then re-timed
RATE_OUT = 50.0


def lasa_shapes(rate: float = RATE_IN, shapes=DEVELOPMENT) -> dict[str, list[np.ndarray]]:
    pkg, _ = _package()
    out = {}
    for shape in shapes:
        with contextlib.redirect_stdout(io.StringIO()):
            data = getattr(pkg.DataSet, shape)
        out[shape] = [resample_in_time(np.asarray(d.t, float)[0], np.asarray(d.pos, float).T, rate) for d in data.demos]
    return out


def library(data: dict, names) -> list:
    entries = []
    for name in names:
        entries += entries_of(Template(name, data[name][0], {}, times=np.arange(len(data[name][0])) / RATE_IN))
    return entries


def euclid(path: np.ndarray, entries, data) -> list[Part]:
    """Control: plain Euclidean sliding window of each template at its own length (translation removed)."""
    import stumpy

    from hila_lang.recognition.search import _schedule

    cands = []
    for k, e in enumerate(entries):
        raw = data[e.template][0]
        tmpl = raw[:: int(RATE_IN / RATE_OUT)]
        n = len(tmpl)
        if n > len(path):
            continue
        tc = tmpl - tmpl.mean(0)
        sq = np.zeros(len(path) - n + 1)
        for d in range(2):
            sq += stumpy.mass(tc[:, d], path[:, d], normalize=False) ** 2
            c = np.concatenate([[0.0], np.cumsum(path[:, d])])
            sq -= n * ((c[n:] - c[:-n]) / n) ** 2  # centre each window
        rms = np.sqrt(np.maximum(sq, 0) / n) / np.sqrt((tc ** 2).sum(1).mean())
        for i in np.argsort(rms)[:50]:
            if rms[i] < THRESHOLD:
                cands.append((float(i), float(i + n - 1), float(rms[i]), k))
    return _parts(_schedule(cands) if cands else [], entries, len(path))


def _parts(chosen, entries, T) -> list[Part]:
    return [Part(int(lo), int(hi) + 1, entries[k].template, entries[k].tag, d) for lo, hi, d, k in chosen]


def speed_dips(path: np.ndarray, entries, pieces: int) -> list[Part]:
    """Control: speed-dip segmenter with the true number of pieces, nearest template by Procrustes."""
    from hila_lang.osila.segmentation import speed_segments

    out = []
    for a, b in speed_segments(path, pieces, times=np.arange(len(path)) / RATE_OUT):
        piece = smooth(path[a:b])
        if b - a < 4 or arc_length(piece)[-1] <= 0:
            continue
        pts = arc_resample(piece, entries[0].points.shape[0])
        d = np.array([elastic_distance(pts, e.points) for e in entries])
        k = int(np.argmin(d))
        if d[k] < THRESHOLD:
            out.append(Part(a, b, entries[k].template, entries[k].tag, float(d[k])))
    return out


def score(found: list[Part], truth) -> dict:
    known = [p for p in found if p.known]
    tp, errors, used = 0, [], set()
    for a, b, label in truth:
        if label is None:
            continue
        for j, p in enumerate(known):
            inter = min(b, p.end) - max(a, p.start)
            union = max(b, p.end) - min(a, p.start)
            if j not in used and p.template == label and inter / union >= 0.5:
                used.add(j)
                tp += 1
                errors += [abs(p.start - a) / (b - a), abs(p.end - b) / (b - a)]
                break
    new = []
    for a, b, label in truth:
        if label is None:
            cover = sum(max(0, min(b, p.end) - max(a, p.start)) for p in known)
            new.append(cover < 0.5 * (b - a))
    return {"tp": tp, "reported": len(known), "true": sum(1 for *_, lab in truth if lab is not None),
            "errors": errors, "new": new}


def summary(scores) -> str:
    tp = sum(s["tp"] for s in scores)
    rep = sum(s["reported"] for s in scores)
    true = sum(s["true"] for s in scores)
    errs = [e for s in scores for e in s["errors"]]
    new = [n for s in scores for n in s["new"]]
    return (f"precision={tp / max(rep, 1):.3f} recall={tp / max(true, 1):.3f} "
            f"boundary_median={np.median(errs) if errs else float('nan'):.3f} new_flagged={np.mean(new) if new else float('nan'):.3f}")


def figure(path_png: str, c, found: list[Part]) -> None:
    """One query drawn: new stretches grey, each known part coloured and labelled (needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hila_lang.core.fileio import atomic_write_bytes

    fig, ax = plt.subplots(figsize=(7, 6), dpi=110)
    ax.plot(*c.path.T, color="0.8", lw=1, label="new (free moves, distractors)")
    for k, p in enumerate(p for p in found if p.known):
        seg = c.path[p.start:p.end]
        ax.plot(*seg.T, lw=2.2, color=f"C{k % 10}")
        ax.annotate(f"{p.template}\n[{p.start}, {p.end}) d={p.distance:.3f}", seg[len(seg) // 2], fontsize=8,
                    color=f"C{k % 10}", xytext=(6, 6), textcoords="offset points",
                    bbox={"boxstyle": "round", "fc": "white", "ec": "none", "alpha": 0.8})
    truth = ", ".join(f"{label or 'distractor'} [{a}, {b})" for a, b, label in c.parts)
    ax.set_title(f"recognised parts (colour) in one query\ntruth: {truth}", fontsize=8)
    ax.set_aspect("equal")
    ax.legend(loc="best", fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path_png, buf.getvalue())


def online(data, names, entries, rng, queries: int) -> str:
    """Online recognition of ``queries`` composites fed point by point: latency, final = offline, withdrawals."""
    from hila_lang.recognition.online import OnlineRecogniser, _same

    late, same, withdrawn, demo_s, compute_s = [], 0, 0, 0.0, 0.0
    for _ in range(queries):
        chain = [(data[s][rng.integers(1, 7)], s) for s in rng.choice(names, 4)]
        c = make(chain, rng, rate_in=RATE_IN, rate_out=RATE_OUT)
        o = OnlineRecogniser(entries)
        t0 = time.perf_counter()
        for p, t in zip(c.path, c.times):
            o.push(p, t)
        final, _ = o.finish()
        compute_s += time.perf_counter() - t0
        demo_s += c.times[-1]
        same += [p.as_report() for p in final] == [p.as_report() for p in recognise(c.path, entries, c.times)]
        withdrawn += sum(e.kind == "withdrawn" for e in o.events)
        for q in (q for q in final if q.known):
            said = [e.at for e in o.events if e.kind == "known" and _same(e.part, q)
                    and not any(w.kind == "withdrawn" and w.part is e.part for w in o.events)]
            late.append(min(said) - c.times[q.end - 1] if said else np.inf)
    return (f"online parts={len(late)} latency_max={max(late):.2f}s within_0.3s={np.mean(np.array(late) <= 0.3):.3f} "
            f"final_equals_offline={same}/{queries} withdrawn={withdrawn} compute/demo={compute_s / demo_s:.2f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--queries", type=int, default=15)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--held-out", action="store_true",
                    help="run on the 16 held-out shapes instead (a check after the fact: nothing is chosen by it)")
    ap.add_argument("--online", type=int, default=0, metavar="N",
                    help="also feed N composites point by point to the online recogniser (about 1 s of compute per s)")
    ap.add_argument("--figure", metavar="PNG", help="draw the first query and what was recognised (needs matplotlib)")
    args = ap.parse_args(argv)
    shapes = DEVELOPMENT
    if args.held_out:
        from hila_lang.evaluation.lasa import all_shapes

        shapes = tuple(s for s in all_shapes() if s not in DEVELOPMENT)
    data = lasa_shapes(shapes=shapes)
    rng = np.random.default_rng(args.seed)
    results = {"recognise": [], "euclid": [], "speed-dips": []}
    seconds = {k: 0.0 for k in results}
    for _ in range(args.rounds):
        fixed = [s for s in ("Line",) if s in shapes]
        others = [s for s in shapes if s not in fixed]
        distract = [*fixed, *rng.choice(others, 4 - len(fixed), replace=False)]
        names = [s for s in shapes if s not in distract]
        entries = library(data, names)
        for _ in range(args.queries):
            chain = []
            for _ in range(4):
                pool = distract if rng.random() < 0.25 else names
                shape = pool[rng.integers(len(pool))]
                chain.append((data[shape][rng.integers(1, 7)], shape if shape in names else None))
            c = make(chain, rng, rate_in=RATE_IN, rate_out=RATE_OUT)
            for key, run in (("recognise", lambda: recognise(c.path, entries, c.times)),
                             ("euclid", lambda: euclid(c.path, entries, data)),
                             ("speed-dips", lambda: speed_dips(c.path, entries, 2 * len(chain) - 1))):
                t0 = time.perf_counter()
                found = run()
                seconds[key] += time.perf_counter() - t0
                results[key].append(score(found, c.parts))
                if args.figure and key == "recognise" and len(results[key]) == 1:
                    figure(args.figure, c, found)
    n = args.rounds * args.queries
    which = "held-out" if args.held_out else "development"
    print(f"# {n} queries of 4 shapes, {args.rounds} library/distractor splits of LASA's {which} shapes")
    for key in results:
        label = "recognise" if key == "recognise" else f"control {key}"
        print(f"{label} {summary(results[key])} seconds_per_query={seconds[key] / n:.3f}")
    if args.online:
        print(online(data, names, entries, np.random.default_rng(args.seed + 1), args.online))
    # timing: a 20 s demonstration against 50 templates
    pool = [(s, i) for s in shapes for i in range(7)][:50]
    entries = []
    for s, i in pool:
        entries += entries_of(Template(f"{s}_{i + 1}", data[s][i], {}))
    rng = np.random.default_rng(args.seed + 2)
    chain, c = [], None
    while c is None or c.times[-1] < 20.0:
        s = shapes[rng.integers(len(shapes))]
        chain.append((data[s][rng.integers(7)], s))
        c = make(chain, np.random.default_rng(args.seed + 2), rate_in=RATE_IN, rate_out=RATE_OUT, speed=(1.0, 1.0))
    c_times = []
    for _ in range(5):
        t0 = time.perf_counter()
        recognise(c.path, entries, c.times)
        c_times.append(time.perf_counter() - t0)
    print(f"timing demo={c.times[-1]:.1f}s samples={len(c.path)} library={len(entries)} templates "
          f"recognise_seconds={np.median(c_times):.3f} (median of 5) load={os.getloadavg()[0]:.2f} cores={os.cpu_count()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
