"""Record a run in one file (``hila exec ... --record run.hilarec``) and read it back.

A recording is a ZIP archive (one file, written atomically at the end of the run, whether it
finished or failed) that any ZIP tool opens, with

- ``record.json``: ``{"hila_record": 1, ...}`` -- the command (program, world, back end, seed,
  settings), the program's text, every imported template's file, SHA-256 and text, the FSM
  (:meth:`~hila_lang.language.fsm.FSM.to_dict`), the lines a person typed (a human opponent),
  where the hand started, then one entry per step: state, kind, line, trace text, next state,
  value, the variables it set, the ICPs bound, the planned and the executed path (metres, full
  float precision), OSILA's account of a run state (map, threshold, rounds, constraint pairs
  added, the constraints and options) and where the hand ended; last, how the run ended;
- ``eyes/NNNN.png``: the left eye's image after each run state (``--record-eyes``).

:func:`read_record` reads it back without a simulator (numpy arrays for points and paths);
:mod:`hila_lang.language.replay` steps through it and verifies it.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HilaError, InputError

#: the version :func:`write_record` writes and :func:`read_record` reads
RECORD_VERSION = 1
RECORD_JSON = "record.json"


class TeeInput:
    """A text stream that remembers every line read from ``stream`` (a person's moves), so a
    replay can type them again."""

    def __init__(self, stream) -> None:
        self.stream, self.lines = stream, []

    def readline(self, *args) -> str:
        line = self.stream.readline(*args)
        if line:
            self.lines.append(line)
        return line

    def __iter__(self):
        return iter(self.readline, "")

    def isatty(self) -> bool:
        return bool(getattr(self.stream, "isatty", lambda: False)())

    def __getattr__(self, name):
        return getattr(self.stream, name)


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _array(a) -> list | None:
    return None if a is None else np.asarray(a, dtype=float).tolist()


def plain(value) -> Any:
    """A hila value as JSON: a point (ndarray) as ``{"point": [...]}``."""
    if isinstance(value, np.ndarray):
        return {"point": value.tolist()}
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    return repr(value)


def unplain(value) -> Any:
    if isinstance(value, dict) and set(value) == {"point"}:
        return np.asarray(value["point"], dtype=float)
    return value


def osila_record(step) -> dict:
    """What a :class:`~hila_lang.hierarchy.Step` did, as JSON."""
    res = step.result
    return {
        "warp": res.warp.kind, "threshold": float(res.threshold), "rounds": int(res.rounds),
        "added": [[int(t), _array(q), str(label)] for t, q, label in res.added],
        "constraints": [{"point": _array(c.point), "radius": c.radius, "name": c.name} for c in step.constraints],
        "options": {k: plain(v) if not isinstance(v, (list, tuple)) else list(v) for k, v in step.options.items()},
        "start_bound": bool(step.start_bound),
    }


class Recorder:
    """Collects a run of ``interp`` (an :class:`~hila_lang.language.interpreter.Interpreter`) and
    writes it to ``path`` with :meth:`close`.

    Parameters
    ----------
    interp : Interpreter
    path : path-like
        The ``.hilarec`` file (refused now if it is a folder).
    command : dict
        ``program``, ``backend``, ``seed``, ``settings``, ``world`` as the run was asked for.
    stdin : TeeInput, optional
        The stream a person typed into.
    eyes : bool
        Keep the left eye's image after each run state (when the back end has eyes).
    """

    def __init__(self, interp, path, command: dict, stdin: TeeInput | None = None, eyes: bool = False) -> None:
        self.path = Path(path)
        if self.path.is_dir():
            raise InputError("expected --record to name a file, got a folder", file=str(self.path))
        self.interp, self.command, self.stdin = interp, dict(command), stdin
        self.eyes = eyes and interp.backend.eyes is not None
        self.images: dict[str, bytes] = {}
        self.steps: list[dict] = []
        self._env = dict(interp.env)
        self.start_hand = _array(interp.hand())
        self.started = time.time()
        interp.observers.append(self.observe)

    def observe(self, entry) -> None:
        """Called by the interpreter after each step (see ``Interpreter.observers``).  A step that
        failed or was interrupted is not a step of the recording: how the run ended is its
        ``result`` (the error and the state)."""
        if entry.error is not None:
            return
        it = self.interp
        changed = {k: plain(v) for k, v in it.env.items() if k not in self._env or not _same(self._env[k], v)}
        self._env = dict(it.env)
        record = {
            "step": entry.step, "state": entry.state, "kind": entry.kind, "line": entry.line, "text": entry.text,
            "next": entry.next, "value": plain(entry.value), "pen_down": entry.pen_down, "env": changed,
            "icps": {k: _array(v) for k, v in entry.icps.items()}, "path": _array(entry.path),
            "executed": _array(entry.executed), "hand": _array(it.hand()),
        }
        if entry.step_result is not None:
            record["osila"] = osila_record(entry.step_result)
        if self.eyes and entry.kind == "run":
            record["eye"] = self.eye_image(entry.step)
        self.steps.append(record)

    def eye_image(self, step: int) -> str:
        import cv2

        image = self.interp.backend.eyes.camera_image("left").rgb
        ok, png = cv2.imencode(".png", np.ascontiguousarray(image[:, :, ::-1]))
        name = f"eyes/{step:04d}.png"
        self.images[name] = png.tobytes()
        return name

    def document(self, error: BaseException | None = None) -> dict:
        it = self.interp
        checked = it.checked
        templates = {}
        for alias, file in checked.template_files.items():
            data = Path(file).read_bytes()
            templates[alias] = {"file": str(file), "sha256": sha256(data), "text": data.decode("utf-8")}
        source = checked.program.source
        if error is None:
            result = {"status": "finished" if it.done else "stopped"}
        elif isinstance(error, HilaError):
            result = {"status": "failed", "error": str(error), "exit": error.exit_code, "state": it.current}
        else:
            result = {"status": "failed", "error": f"{type(error).__name__}: {error}", "exit": 3, "state": it.current}
        from .. import __version__

        return {
            "hila_record": RECORD_VERSION,
            "hila_version": __version__,
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(self.started)),
            "command": self.command,
            "cwd": os.getcwd(),
            "program": {"file": it.fsm.file, "path": str(Path(it.fsm.file).resolve()),
                        "sha256": sha256(source.encode("utf-8")), "text": source},
            "templates": templates,
            "fsm": it.fsm.to_dict(),
            "input": list(self.stdin.lines) if self.stdin is not None else [],
            "start": {"hand": self.start_hand},
            "eyes": self.eyes,
            "steps": self.steps,
            "result": result,
        }

    def close(self, error: BaseException | None = None) -> Path:
        """Write the recording (atomically); ``error`` is how the run ended, if it failed."""
        if self.observe in self.interp.observers:
            self.interp.observers.remove(self.observe)
        return write_record(self.path, self.document(error), self.images)


def start_recording(args, options):
    """For ``hila exec --record``: None, or a function that starts a :class:`Recorder` on the
    interpreter.  It wraps ``options.stdin`` now, before the world takes it, so the lines a
    person types are kept; a folder given as the file, or a place that cannot be written, is refused
    before anything runs."""
    if not getattr(args, "record", None):
        if getattr(args, "record_eyes", False):
            raise InputError("--record-eyes needs --record FILE.hilarec")
        return None
    from ..fileio import ensure_writable

    path = Path(args.record)
    if path.is_dir():
        raise InputError("expected --record to name a file, got a folder", file=str(path))
    ensure_writable(path)  # a recording that cannot be written is refused before the run, not after
    options.stdin = TeeInput(options.stdin)
    command = {"program": str(args.program), "backend": args.backend, "seed": options.seed,
               "settings": dict(options.settings), "record_eyes": bool(args.record_eyes),
               "max_steps": getattr(args, "max_steps", None)}

    def start(interp) -> Recorder:
        command.update(world=interp.fsm.world, backend=interp.backend.name)
        return Recorder(interp, path, command, options.stdin, eyes=args.record_eyes)

    return start


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape and bool((a == b).all())
    return type(a) is type(b) and a == b


def write_record(path, document: dict, images: dict[str, bytes] | None = None) -> Path:
    """Write a recording: ``record.json`` and the images, in one ZIP file, atomically."""
    from ..fileio import atomic_write_bytes

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr(RECORD_JSON, json.dumps(document, separators=(",", ":")))
        for name, data in (images or {}).items():
            z.writestr(name, data)
    return atomic_write_bytes(path, buffer.getvalue())


def read_record(path) -> dict:
    """A recording as a dict (points and paths as numpy arrays; ``images``: name -> PNG bytes).

    Anything that is not a hila recording of a version this hila reads is an
    :class:`~hila_lang.errors.InputError` naming the file.
    """
    from ..fileio import read_bytes

    data = read_bytes(path, "recording")
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            doc = json.loads(z.read(RECORD_JSON).decode("utf-8"))
            images = {n: z.read(n) for n in z.namelist() if n.startswith("eyes/")}
    except (zipfile.BadZipFile, KeyError):
        raise InputError(f"not a hila recording (expected a ZIP file holding {RECORD_JSON})", file=str(path)) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"the recording's {RECORD_JSON} is not valid JSON: {exc}", file=str(path)) from None
    version = doc.get("hila_record") if isinstance(doc, dict) else None
    if version != RECORD_VERSION:
        raise InputError(f"this hila reads recordings of version {RECORD_VERSION}, got {version!r}", file=str(path),
                         hint="replay it with the hila version that wrote it" if isinstance(version, int) else None)
    try:
        for s in doc["steps"]:
            for key in ("path", "executed", "hand"):
                s[key] = None if s.get(key) is None else np.asarray(s[key], dtype=float)
            s["icps"] = {k: np.asarray(v, dtype=float) for k, v in (s.get("icps") or {}).items()}
            s["value"] = unplain(s.get("value"))
            s["env"] = {k: unplain(v) for k, v in (s.get("env") or {}).items()}
        doc["start"]["hand"] = np.asarray(doc["start"]["hand"], dtype=float)
        for key in ("fsm", "program", "templates", "command", "result"):
            doc[key]  # noqa: B018 - present
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"the recording is incomplete or damaged ({type(exc).__name__}: {exc})",
                         file=str(path)) from None
    doc["images"] = images
    return doc
