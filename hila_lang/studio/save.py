"""A demonstration saved as a template (the Demonstrate page's *Save template*): :func:`learned`
makes the three files' texts (``NAME.demo.csv``, ``NAME.icps.yaml``, ``NAME.yaml``) with
``hila learn``'s own function, in a worker (:mod:`.worker`); :func:`save` writes them as one
transaction (:func:`.files.write`), an existing name only with ``overwrite``."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..hierarchy.learn import learn_files
from ..osila.demofile import demo_csv, icps_text
from ..osila.template import template_text
from . import files
from .security import inside


def _names(req: dict) -> tuple[str, str, str]:
    """(``NAME.yaml``, ``NAME.demo.csv``, ``NAME.icps.yaml``) of a save, its name checked (the
    template first: a 409 names it)."""
    # lazy: loads lark, which importing this module does not
    from ..language.transformer import usable_as_tag

    name = str(req.get("name", "")).strip()
    if not usable_as_tag(name):
        raise InputError(f"template name {name!r}: a program imports it by name, so use a letter or '_' and "
                         "then letters, digits or '_'")
    return f"{name}.yaml", f"{name}.demo.csv", f"{name}.icps.yaml"


def learned(folder: Path, req: dict) -> tuple[dict[str, str], dict]:
    """What a save writes, learned but not written: ({file name: text} of ``NAME.demo.csv``,
    ``NAME.icps.yaml`` and ``NAME.yaml``, the answer ``{template, demo, icps, command,
    segments}``).  The template is learned with ``hila learn``'s function from the very CSV and
    ICP texts written (copies in a private temporary folder), so it is byte for byte what ``hila
    learn NAME.demo.csv --icps NAME.icps.yaml ...`` writes.  Runs in a worker (:mod:`.worker`).

    ``command`` is the ``hila learn`` line that writes the same template byte for byte -- with
    ``--cuts A,B`` when the person moved the method's cuts.

    ``req``: ``name``, ``path`` (T, D), ``times`` (T,), optional ``pen`` (T,: drawn with a pointer or
    tracked by the Camera scene), ``icps`` {name: point}, ``tags`` (list), ``contact`` (list),
    ``method``, ``seed`` and optional ``cuts`` (k - 1 indices).
    """
    target_name, demo_name, icps_name = _names(req)
    name = target_name[:-len(".yaml")]
    path = np.asarray(req.get("path"), float)
    times = np.asarray(req.get("times"), float)
    if path.ndim != 2 or path.shape[1] not in (2, 3) or len(times) != len(path):
        raise InputError(f"expected a path (T, 2 or 3) with T times, got {path.shape} and {times.shape}")
    pen = recorded_pen(req, len(path))
    icps = req.get("icps") or {}
    if not icps:
        raise InputError("place at least one ICP (click on the scene) before saving")
    tags = [str(t) for t in req.get("tags") or []]
    contact = [str(t) for t in req.get("contact") or []]
    method, seed = str(req.get("method", "contact" if pen is not None else "speed")), int(req.get("seed", 0))
    target, demo, icps_file = (inside(folder, n) for n in (target_name, demo_name, icps_name))
    k = max(len(tags), 1)
    cuts = None if req.get("cuts") is None or not tags else [int(c) for c in req["cuts"]]
    if cuts is not None and len(cuts) != len(tags) - 1:
        raise InputError(f"cuts: expected {len(tags) - 1} cuts for {len(tags)} tags, got {len(cuts)}")
    texts = {demo_name: demo_csv(path, times, pen), icps_name: icps_text(icps)}
    with tempfile.TemporaryDirectory(prefix="hila-learn-") as tmp:
        copies = [Path(tmp) / n for n in (demo_name, icps_name)]
        for copy in copies:
            copy.write_text(texts[copy.name], encoding="utf-8")
        common = dict(name=name, tags=tags, contact=contact, k=k, seed=seed, named=(str(demo), str(icps_file)))
        template = learn_files(str(copies[0]), str(copies[1]), method=method, **common)
        if cuts == [s.start for s in template.segments[1:]]:
            cuts = None  # the method's own cuts: the command says the method
        if cuts is not None:
            template = learn_files(str(copies[0]), str(copies[1]), cuts=cuts, **common)
    argv = [str(demo), "--icps", str(icps_file), "-k", str(k)] + \
        (["--cuts", ",".join(map(str, cuts))] if cuts is not None else ["--method", method]) + \
        ["--seed", str(seed), "-o", str(target)] + (["--tags", ",".join(tags)] if tags else []) + \
        (["--contact", ",".join(contact)] if contact else [])
    texts[target_name] = template_text(template)
    return texts, dict(template=target_name, demo=demo_name, icps=icps_name, command="hila learn " + " ".join(argv),
                       segments=[dict(tag=s.tag, start=s.start, stop=s.stop, contact=s.contact)
                                 for s in template.segments])


def recorded_pen(doc: dict, n: int) -> np.ndarray | None:
    """The request's recorded pen (``pen``: T booleans), or None."""
    pen = doc.get("pen")
    if pen is None:
        return None
    if not isinstance(pen, list) or len(pen) != n or not all(isinstance(v, (bool, int)) for v in pen):
        raise InputError(f"expected 'pen' as {n} booleans (the pen down at each point), got {str(pen)[:60]}")
    return np.asarray(pen, bool)


def save(folder: Path, req: dict) -> dict:
    """Learn (:func:`learned`) and write ``NAME.demo.csv``, ``NAME.icps.yaml`` and ``NAME.yaml``
    in ``folder`` as one transaction (:func:`.files.write`: all or none; an existing name only
    with ``req["overwrite"]``); returns ``{template, demo, icps, command, segments}``."""
    overwrite = bool(req.get("overwrite"))
    files.refuse_existing(folder, _names(req), overwrite)  # before the work
    texts, answer = learned(folder, req)
    files.write(folder, texts, overwrite=overwrite)
    return answer
