"""The Imitate page: the task scene's ICPs, ``via`` points and ``avoid`` discs as the person drags them,
and OSILA's path through THE HILA step (:func:`hila_lang.hierarchy.step.hila_step`, the one every
``run`` state, ``hila imitate`` and ``hila eval`` use), with the reason for its map and plan
adjustment in ``hila explain``'s words (:func:`hila_lang.hierarchy.explain.warp_reason`; the full account,
:func:`hila_lang.hierarchy.explain.explain_run`, when the drag ends).  The evaluation's controls (bare TPS,
similarity, aligned DMP: :func:`hila_lang.evaluation.controls.generator`) on the same pairs can
be drawn beside it.

Routes: ``GET /api/template?path=`` (a template as the page draws it), ``POST
/api/imitate/export`` (the path as CSV and the scene as a ``.hila`` program), ``POST
/api/imitate/explain`` (``hila explain``'s account); websocket ``/ws/imitate``: a scene in,
OSILA's path (or the reason there is none) out, answered with the scene's ``seq``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.websockets import WebSocket

from ..core.errors import HilaError, InputError
from ..evaluation.controls import dmp_available, generator
from ..evaluation.protocols import Constraints
from ..hierarchy.explain import explain_run, warp_reason
from ..hierarchy.step import Constraint, hila_step
from ..osila.demofile import demo_csv
from ..osila.template import load_template
from . import schema, worker
from .page import gone, JSONSocket, Page, read_json, studio_of, template_json
from .schema import query
from .security import inside

#: the controls drawn beside OSILA (names of hila_lang.evaluation.controls)
CONTROLS = ("tps", "similarity", "dmp-aligned")


def _points(mapping, dim: int, what: str) -> dict[str, np.ndarray]:
    out = {}
    for k, v in (mapping or {}).items():
        p = np.asarray(v, float)
        if p.shape != (dim,) or not np.isfinite(p).all():
            raise InputError(f"{what} {k!r}: expected {dim} finite numbers, got {v!r}")
        out[str(k)] = p
    return out


def scene_parts(template, req: dict):
    """(binding {ICP: point}, constraints) of a request ``{icps, via: [p], avoid: [{centre, radius}]}``."""
    dim = template.path.shape[1]
    icps = _points(req.get("icps"), dim, "ICP")
    unknown = sorted(set(icps) - set(template.icps))
    if unknown:
        raise InputError(f"the template has no ICP {unknown[0]!r}; it has {', '.join(template.icps)}")
    constraints = [Constraint(np.asarray(p, float), None, f"via {i + 1}")
                   for i, p in enumerate(_points({str(i): p for i, p in enumerate(req.get("via") or [])}, dim, "via").values())]
    for i, a in enumerate(req.get("avoid") or []):
        c = _points({"c": a.get("centre")}, dim, f"avoid {i + 1}")["c"]
        r = float(a.get("radius", 0))
        if not r > 0:
            raise InputError(f"avoid {i + 1}: expected a radius > 0, got {a.get('radius')!r}")
        constraints.append(Constraint(c, r, f"avoid {i + 1}"))
    return icps, constraints


def imitate(template, req: dict) -> dict:
    """OSILA's path for the scene in ``req`` and why its map is what it is; the controls when
    ``req["controls"]``.  Returns ``{path, reason, server_ms, controls?}`` or ``{error}``."""
    t0 = time.perf_counter()
    icps, constraints = scene_parts(template, req)
    if not icps:
        raise InputError("no task ICPs: add at least one")
    try:
        step = hila_step(template, icps, None, constraints=constraints)
    except HilaError as exc:
        return dict(error=exc.message, server_ms=(time.perf_counter() - t0) * 1000)
    res = step.result
    reason = [f"map: {warp_reason(res.warp, template.path.shape[1])}",
              f"plan adjustment: {'none needed (1 round)' if res.rounds == 1 else f'{res.rounds} rounds'}"]
    reason += [f"{c.name}: " + (f"met at {v * 1000:.1f} mm" if c.radius is None else f"cleared by {v * 1000:.1f} mm")
               for c, v in step.met()]
    out = dict(path=step.path.tolist(), reason=reason)
    if req.get("controls"):
        out["controls"] = controls(template, icps)
    out["server_ms"] = (time.perf_counter() - t0) * 1000
    return out


def controls(template, icps: dict) -> dict:
    """The controls' paths on the ICP pairs (a control that cannot run here is left out)."""
    names = list(icps)
    c = Constraints(np.array([template.icps[k] for k in names]), np.array([icps[k] for k in names]),
                    tuple(names), (None,) * len(names), 1)
    out = {}
    for method in CONTROLS:
        if method.startswith("dmp") and not dmp_available():
            continue
        try:
            out[method] = np.asarray(generator(method, template.path, {})(c)).tolist()
        except (HilaError, np.linalg.LinAlgError, ValueError):
            continue
    return out


def explain(template, req: dict) -> list[str]:
    """``hila explain``'s account of this step (:func:`hila_lang.hierarchy.explain.explain_run`)."""
    icps, constraints = scene_parts(template, req)
    return explain_run(template, icps, None, constraints, {})


def _pt(p) -> str:
    return "(" + ", ".join(f"{float(v):.4f}" for v in p) + ")"


def point_names(icps: dict, names: dict | None) -> dict[str, str]:
    """ICP -> the name the task scene gives its point (``req["names"]``: the person renamed it on
    the page; default the ICP's own name).  A name must be one a program can declare and pass
    (:func:`hila_lang.language.transformer.usable_as_point`: the grammar decides), and no two
    points may share one."""
    # lazy: loads lark, which importing this module does not
    from ..language.transformer import usable_as_point

    out = {}
    for k in icps:
        name = str((names or {}).get(k) or k).strip()
        if not usable_as_point(name):
            raise InputError(f"point name {name!r} for ICP {k!r}: a program cannot write it (expected a letter "
                             "or '_', then letters, digits or '_', and not a keyword of the language)")
        if name in out.values():
            raise InputError(f"point name {name!r} is given to two ICPs; each task point needs its own name")
        out[k] = name
    return out


def snippet(template, req: dict, import_name: str) -> str:
    """The scene as a ``.hila`` program that runs the template there (``hila check`` reads it);
    each task point named as the person renamed it (:func:`point_names`)."""
    icps, constraints = scene_parts(template, req)
    names = point_names(icps, req.get("names"))
    lines = [f"# the task scene drawn in hila studio for {import_name}.yaml", f"import {import_name}", ""]
    for k, p in icps.items():
        lines.append(f"point {names[k]} = {_pt(p)}")
    for c in constraints:
        name = c.name.replace(" ", "_")
        lines.append(f"point {name} = {_pt(c.point)}")
    args = ", ".join(f"{k} = {names[k]}" for k in icps)
    tail = "".join(f" via {c.name.replace(' ', '_')}" if c.radius is None
                   else f" avoid {c.name.replace(' ', '_')} radius {c.radius:.4f}" for c in constraints)
    lines += ["", "main {", f"    run {import_name}({args}){tail}", "}", ""]
    return "\n".join(lines)


def load(folder: Path, name: str):
    return load_template(inside(folder, name))


# ----------------------------------------------------------------------------- routes


async def _template(request: Request) -> Response:
    return JSONResponse(template_json(studio_of(request).template(query(request, schema.TEMPLATE_QUERY)["path"])))


async def _export(request: Request) -> Response:
    doc = await read_json(request)
    name = str(doc.get("template", ""))
    t = studio_of(request).template(name)
    result = await worker.run(imitate, t, doc, gone=gone(request))
    if "error" in result:
        raise InputError(result["error"])
    return JSONResponse({"csv": demo_csv(result["path"], t.times), "hila": snippet(t, doc, Path(name).stem)})


async def _explain(request: Request) -> Response:
    doc = await read_json(request)
    t = studio_of(request).template(str(doc.get("template", "")))
    return JSONResponse({"lines": await worker.run(explain, t, doc, gone=gone(request))})


class ImitateSocket(JSONSocket):
    """A scene in, OSILA's path out (:func:`imitate`), each answer with the scene's ``seq``."""

    async def on_message(self, websocket: WebSocket, doc: dict) -> None:
        template = studio_of(websocket).template(str(doc.get("template", "")))
        out = await worker.run(imitate, template, doc)
        await websocket.send_text(json.dumps(dict(out, seq=doc.get("seq"))))

    async def on_error(self, websocket: WebSocket, doc: dict, text: str) -> None:
        await websocket.send_text(json.dumps({"error": text, "seq": doc.get("seq")}))


PAGE = Page("imitate", "2 Imitate", "imitate.js", routes=[
    Route("/api/template", _template),
    Route("/api/imitate/export", _export, methods=["POST"]),
    Route("/api/imitate/explain", _explain, methods=["POST"]),
    WebSocketRoute("/ws/imitate", ImitateSocket),
])
