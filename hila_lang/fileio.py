"""Safe file input and output shared by every stage: atomic writes, safe YAML, CSV paths."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

from .errors import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically: a temporary file in the same folder, then rename.

    A crash leaves either the old file or the new one, never half of one.  Parent folders are
    created.  Returns the path written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual mode
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError) and not isinstance(exc, BrokenPipeError):
            # name the file the user asked for, not the temporary one (e.g. a directory in the way)
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        raise
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Atomic :func:`atomic_write_bytes` for UTF-8 text."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def write_png(path: str | os.PathLike, image, *, bgr: bool = False) -> Path:
    """Write an image (H, W, 3) or (H, W) uint8 as PNG, atomically.

    ``image`` is RGB unless ``bgr`` (OpenCV's own channel order, for images drawn with cv2).
    """
    import cv2
    import numpy as np

    image = np.ascontiguousarray(image)
    if image.ndim == 3 and not bgr:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", image)
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise InputError(f"cannot encode a PNG image of shape {image.shape}", file=str(path))
    return atomic_write_bytes(path, buf.tobytes())


def read_bytes(path: str | os.PathLike, what: str = "file") -> bytes:
    """Read a file, turning every OS failure into an :class:`InputError` naming ``what`` and the path."""
    path = Path(path)
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{what} not found", file=str(path)) from None
    except IsADirectoryError:
        raise InputError(f"expected a {what}, got a directory", file=str(path)) from None
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror}", file=str(path)) from None


def read_text(path: str | os.PathLike, what: str = "file") -> str:
    """Read a UTF-8 text file, turning every OS or decoding failure into :class:`InputError`."""
    data = read_bytes(path, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise InputError(
            f"{what} is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})",
            file=str(path),
            line=line,
        ) from None


def _unique_key_loader():
    """A ``yaml.SafeLoader`` subclass that refuses duplicate keys in a mapping (built lazily)."""
    import yaml

    class UniqueKeyLoader(yaml.SafeLoader):
        def construct_mapping(self, node, deep=False):
            seen: dict[Any, Any] = {}
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.get(key)
                except TypeError:  # unhashable key: let SafeLoader report it
                    break
                if first is not None:
                    raise yaml.constructor.ConstructorError(
                        None, None,
                        f"duplicate key {key!r} (first defined at line {first.line + 1})",
                        key_node.start_mark,
                    )
                seen[key] = key_node.start_mark
            return super().construct_mapping(node, deep=deep)

    return UniqueKeyLoader


def load_yaml(path: str | os.PathLike, what: str = "YAML file", *, unique_keys: bool = False) -> Any:
    """``yaml.safe_load`` a file; syntax errors become :class:`InputError` with line and column.

    With ``unique_keys`` a key repeated in one mapping is an error too (plain YAML keeps the last
    one silently), reported at the repeated key's line and column.
    """
    import yaml

    text = read_text(path, what)
    try:
        if unique_keys:
            return yaml.load(text, Loader=_unique_key_loader())  # a SafeLoader subclass
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or str(exc)
        kwargs: dict[str, Any] = {"file": str(path)}
        if mark is not None:
            kwargs.update(line=mark.line + 1, column=mark.column + 1)
            lines = text.splitlines()
            if mark.line < len(lines):
                kwargs["source_line"] = lines[mark.line]
        raise InputError(f"{what} is not valid YAML: {problem}", **kwargs) from None


def dump_yaml(path: str | os.PathLike, data: Any, header: str = "") -> Path:
    """Write ``data`` as block-style YAML, atomically, after an optional ``# comment`` header."""
    import yaml

    body = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    if header:
        header = "".join(f"# {ln}\n" if ln else "#\n" for ln in header.splitlines())
    return atomic_write_text(path, header + body)


def cache_folders(name: str) -> list[Path]:
    """Where hila may keep what it computes once and reuses (the generated robot model, the eyes'
    lens calibration): ``$HILA_CACHE_DIR/hila/<name>`` (else ``$XDG_CACHE_HOME`` or
    ``~/.cache``), then a temporary folder for when that one is not writable, in that order."""
    base = os.environ.get("HILA_CACHE_DIR") or os.environ.get("XDG_CACHE_HOME")
    root = Path(base) if base else Path.home() / ".cache"
    return [root / "hila" / name, Path(tempfile.gettempdir()) / f"hila-{os.getuid()}" / name]


def output_folder(out, name: str) -> Path:
    """``out`` as given (created), or a fresh ``runs/<name>-<UTC time>[-k]`` folder (created).

    A run that writes files by default writes them where the user will find them and never over
    an earlier run's.
    """
    import time

    if out is not None:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        return folder
    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
    base = Path("runs") / name.replace("{time}", stamp)
    folder, k = base, 1
    while folder.exists():
        k += 1
        folder = base.with_name(f"{base.name}-{k}")
    folder.mkdir(parents=True)
    return folder
