"""Record a run in one file (``hila exec ... --record run.hilarec``) and read it back.

A recording is a ZIP archive (one file, written atomically at the end of the run, whether it
finished or failed) that any ZIP tool opens, with

- ``record.json``: ``{"hila_record": 1, ...}`` -- the command (program, world, back end, seed,
  settings), the program's text, every imported template's file, SHA-256 and text, the FSM
  (:meth:`~hila_lang.language.fsm.FSM.to_dict`), the lines a person typed (a human opponent),
  where the hand started, then one entry per step: state, kind, line, trace text, next state,
  value, the variables it set, the ICPs bound, the planned and the executed path (metres, full
  float precision), OSILA's account of a run state (map, threshold, rounds, constraint pairs
  added, the constraints and options), where the hand ended, and for a streamed run (``track``)
  its re-plans (time, how far the tracked points moved, where the new plan took over, the blend,
  whether the pen lifted, where the tracked points were taken to be and the new tail); last, how
  the run ended (a failed run: the error, its exit status, the state, and -- when a back end
  stopped part of the way through a move -- the path the hand made, ``executed``);
- ``eyes/NNNN.png``: the left eye's image after each run state (``--record-eyes``).

:func:`read_record` reads it back without a simulator (numpy arrays for points and paths);
:mod:`hila_lang.session.replay` steps through it and verifies it.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import time
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..core.errors import HilaError, InputError
from ..core.fileio import atomic_write_bytes, check_regular, ensure_writable

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
    """What a :class:`~hila_lang.hierarchy.step.Step` did, as JSON."""
    res = step.result
    return {
        "warp": res.warp.kind, "threshold": float(res.threshold), "rounds": int(res.rounds),
        "added": [[int(t), _array(q), str(label)] for t, q, label in res.added],
        "constraints": [{"point": _array(c.point), "radius": c.radius, "name": c.name} for c in step.constraints],
        "options": {k: plain(v) if not isinstance(v, (list, tuple)) else list(v) for k, v in step.options.items()},
        "start_bound": bool(step.start_bound),
    }


class Recorder:
    """Collects a run of ``interp`` (an :class:`~hila_lang.engine.interpreter.Interpreter`) and
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
        if entry.replans is not None:
            record["replans"] = [r.to_dict() for r in entry.replans]
        if self.eyes and entry.kind == "run":
            record["eye"] = self.eye_image(entry.step)
        self.steps.append(record)

    def eye_image(self, step: int) -> str:
        # lazy: loads cv2, which importing this module does not
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
            if getattr(error, "executed", None) is not None:  # the part of the move made before it stopped
                result["executed"] = _array(error.executed)
        else:
            result = {"status": "failed", "error": f"{type(error).__name__}: {error}", "exit": 3, "state": it.current}

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
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr(RECORD_JSON, json.dumps(document, separators=(",", ":")))
        for name, data in (images or {}).items():
            z.writestr(name, data)
    return atomic_write_bytes(path, buffer.getvalue())


#: the largest ``record.json`` read, decompressed (bytes).  A run step with its planned and
#: executed paths takes about 2-12 kB of JSON, so this holds tens of thousands of steps; the
#: shipped game records 62.  Parsed JSON takes several times its text, so this bounds memory
#: to a few GB at worst (a 3 MB "zip bomb" recording used to take 6.2 GB).
RECORD_JSON_LIMIT = 256 << 20
#: the largest eye image read (bytes, decompressed); a 320x240 PNG is about 100 kB
EYE_IMAGE_LIMIT = 16 << 20


class _Damaged(Exception):
    """A recording that does not hold what :func:`write_record` writes (a message for the user)."""


def _member(z: zipfile.ZipFile, name: str, limit: int) -> bytes:
    """One member of the archive, decompressed, at most ``limit`` bytes (checked as it is read:
    the size the archive declares may lie)."""
    try:
        info = z.getinfo(name)
    except KeyError:
        raise _Damaged(f"not a hila recording (expected a ZIP file holding {name})") from None
    if info.flag_bits & 0x1:
        raise _Damaged(f"its member {name} is encrypted; hila writes recordings unencrypted")
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise _Damaged(f"its member {name} uses compression method {info.compress_type}; "
                       "hila writes deflate (8) or none (0)")
    if info.file_size > limit:
        raise _Damaged(f"its member {name} is {info.file_size:,} bytes decompressed, more than hila reads "
                       f"({limit:,})")
    try:
        with z.open(info) as f:
            data = f.read(limit + 1)
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, NotImplementedError, RuntimeError) as exc:
        raise _Damaged(f"its member {name} is damaged ({exc})") from None
    if len(data) > limit:
        raise _Damaged(f"its member {name} decompresses to more than hila reads ({limit:,} bytes)")
    return data


class RecordImages(dict):
    """The eye images of a recording, name -> PNG bytes, each read from the file when first
    asked for (a recording's images are never read unless used)."""

    def __init__(self, path, names) -> None:
        super().__init__((n, None) for n in names)
        self.path = path

    def __getitem__(self, name: str) -> bytes:
        data = super().__getitem__(name)
        if data is None:
            try:
                with zipfile.ZipFile(self.path) as z:
                    data = _member(z, name, EYE_IMAGE_LIMIT)
            except (_Damaged, zipfile.BadZipFile, OSError) as exc:
                raise InputError(f"cannot read the recording's image {name}: {exc}", file=str(self.path)) from None
            self[name] = data
        return data

    def values(self):
        return [self[n] for n in self]

    def items(self):
        return [(n, self[n]) for n in self]


def _need(d, key, kinds, where, *, optional=False):
    """``d[key]``, of one of ``kinds`` (a type or tuple), else :class:`_Damaged` naming ``where``."""
    if not isinstance(d, dict):
        raise _Damaged(f"{where} is not a mapping")
    if key not in d:
        if optional:
            return None
        raise _Damaged(f"{where} has no '{key}'")
    value = d[key]
    if isinstance(value, bool) and bool not in (kinds if isinstance(kinds, tuple) else (kinds,)):
        raise _Damaged(f"{where}['{key}'] is {value!r}, expected {_kind_names(kinds)}")
    if not isinstance(value, kinds):
        raise _Damaged(f"{where}['{key}'] is {type(value).__name__}, expected {_kind_names(kinds)}")
    return value


def _kind_names(kinds) -> str:
    names = {dict: "a mapping", list: "a list", str: "text", int: "a whole number", float: "a number",
             bool: "true/false", type(None): "null"}
    return " or ".join(names.get(k, k.__name__) for k in (kinds if isinstance(kinds, tuple) else (kinds,)))


def _points(value, where: str, shape: str) -> np.ndarray:
    """A recorded point or path as a finite float array of ``shape`` ("point", "path")."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise _Damaged(f"{where} is not a {shape} of numbers") from None
    if (shape == "point" and a.shape not in ((2,), (3,))) or (shape == "path" and (a.ndim != 2 or a.shape[1] not in (2, 3))):
        raise _Damaged(f"{where} has shape {a.shape}, expected a {shape} in 2 or 3 dimensions")
    if not np.isfinite(a).all():
        raise _Damaged(f"{where} holds a number that is not finite (NaN or infinity)")
    return a


def _validate(doc) -> None:
    """Check and convert ``doc`` (the parsed ``record.json``) in place; :class:`_Damaged` names
    the first thing missing or of the wrong kind."""
    if not isinstance(doc, dict):
        raise _Damaged(f"{RECORD_JSON} is not a mapping")
    version = doc.get("hila_record")
    if version != RECORD_VERSION:
        raise _Damaged(f"this hila reads recordings of version {RECORD_VERSION}, got {version!r}")
    program = _need(doc, "program", dict, "the recording")
    for key in ("file", "path", "sha256", "text"):
        _need(program, key, str, "its 'program'")
    for alias, t in _need(doc, "templates", dict, "the recording").items():
        for key in ("file", "sha256", "text"):
            _need(t, key, str, f"its template '{alias}'")
    command = _need(doc, "command", dict, "the recording")
    seed = _need(command, "seed", int, "its 'command'")
    if seed < 0:
        raise _Damaged(f"its 'command' has seed {seed}, expected a whole number >= 0")
    settings = _need(command, "settings", dict, "its 'command'")
    if not all(isinstance(k, str) and isinstance(v, str) for k, v in settings.items()):
        raise _Damaged("its command's 'settings' are not text pairs")
    _need(command, "backend", (str, type(None)), "its 'command'", optional=True)
    _need(command, "max_steps", (int, type(None)), "its 'command'", optional=True)
    inputs = _need(doc, "input", list, "the recording", optional=True) or []
    if not all(isinstance(line, str) for line in inputs):
        raise _Damaged("its 'input' is not a list of lines")
    start = _need(doc, "start", dict, "the recording")
    start["hand"] = _points(_need(start, "hand", list, "its 'start'"), "its start 'hand'", "point")
    fsm = _need(doc, "fsm", dict, "the recording")
    try:
        # lazy: only this branch needs it
        from ..language.fsm import FSM

        states = FSM.from_dict(fsm).states
    except (HilaError, KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        raise _Damaged(f"its 'fsm' is damaged ({type(exc).__name__}: {exc})") from None
    result = _need(doc, "result", dict, "the recording")
    status = _need(result, "status", str, "its 'result'")
    if status not in ("finished", "stopped", "failed"):
        raise _Damaged(f"its result's status is {status!r}, expected finished, stopped or failed")
    if status == "failed":
        _need(result, "error", str, "its 'result'")
        _need(result, "exit", int, "its 'result'")
        if result.get("executed") is not None:  # the part of the failing move that was made
            result["executed"] = _points(result["executed"], "its result's 'executed'", "path")
    state = _need(result, "state", (str, type(None)), "its 'result'", optional=True)
    if state is not None and state not in states:
        raise _Damaged(f"its result names state {state!r}, which its FSM does not have")
    for i, s in enumerate(_need(doc, "steps", list, "the recording")):
        where = f"step {i + 1}"
        _need(s, "step", int, where)
        for key in ("state", "kind", "text"):
            _need(s, key, str, where)
        if s["state"] not in states:
            raise _Damaged(f"{where} names state {s['state']!r}, which its FSM does not have")
        _need(s, "line", (int, type(None)), where, optional=True)
        _need(s, "next", (str, type(None)), where, optional=True)
        s.setdefault("line", None)
        s.setdefault("next", None)
        s.setdefault("pen_down", None)
        for key in ("path", "executed"):
            value = s.get(key)
            s[key] = None if value is None else _points(value, f"{where}'s '{key}'", "path")
        s["hand"] = None if s.get("hand") is None else _points(s["hand"], f"{where}'s 'hand'", "point")
        icps = _need(s, "icps", dict, where, optional=True) or {}
        s["icps"] = {k: _points(v, f"{where}'s ICP '{k}'", "point") for k, v in icps.items()}
        s["value"] = unplain(s.get("value"))
        env = _need(s, "env", dict, where, optional=True) or {}
        s["env"] = {k: unplain(v) for k, v in env.items()}
        if "osila" in s:
            osila = _need(s, "osila", dict, where)
            for c in _need(osila, "constraints", list, f"{where}'s 'osila'"):
                _points(_need(c, "point", list, f"{where}'s constraint"), f"{where}'s constraint point", "point")
            _need(osila, "options", dict, f"{where}'s 'osila'")


def read_record(path) -> dict:
    """A recording as a dict (points and paths as numpy arrays; ``images``: name -> PNG bytes,
    read when first used).

    Anything that is not a hila recording of a version this hila reads is an
    :class:`~hila_lang.core.errors.InputError` naming the file and what is wrong (issue 20): a
    damaged archive or member, an encrypted or unknown compression, ``record.json`` larger than
    :data:`RECORD_JSON_LIMIT` decompressed, nested too deeply, or missing a field or holding
    one of the wrong kind.  Only ``record.json`` is read; other members (a huge ``eyes/``) are
    not, and members hila does not write are ignored.
    """
    check_regular(path, "recording")
    try:
        with zipfile.ZipFile(path) as z:
            names = [n for n in z.namelist() if n.startswith("eyes/") and n.endswith(".png")]
            data = _member(z, RECORD_JSON, RECORD_JSON_LIMIT)
        try:
            doc = json.loads(data.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise _Damaged(f"its {RECORD_JSON} is not valid JSON: {exc}") from None
        except RecursionError:
            raise _Damaged(f"its {RECORD_JSON} is nested too deeply") from None
        _validate(doc)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, EOFError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f"not a hila recording (expected a ZIP file holding {RECORD_JSON})",
                         file=str(path), hint=f"the file could not be read as one: {exc}") from None
    except _Damaged as exc:
        version = doc.get("hila_record") if "doc" in locals() and isinstance(doc, dict) else None
        hint = ("replay it with the hila version that wrote it"
                if isinstance(version, int) and version != RECORD_VERSION else None)
        raise InputError(f"the recording is damaged or not one hila reads: {exc}", file=str(path), hint=hint) from None
    doc["images"] = RecordImages(path, names)
    return doc
