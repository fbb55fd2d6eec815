"""Safe file input and output shared by every stage: atomic writes, safe YAML, CSV paths."""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from pathlib import Path
from typing import Any

from .errors import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _make_folder(folder: Path, path: Path) -> None:
    """Create ``folder`` and its parents for writing ``path``; an OSError names ``path`` (the
    user's), and a file in the way says which."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        blocker = next((p for p in [folder, *folder.parents] if p.exists() and not p.is_dir()), folder)
        raise NotADirectoryError(errno.ENOTDIR, f"cannot make its folder: {blocker} is a file", str(path)) from None
    except OSError as exc:
        raise OSError(exc.errno, f"cannot make its folder {folder}: {exc.strerror}", str(path)) from None


class AtomicFile:
    """A file written in pieces and published whole: the pieces go to a temporary file beside
    ``path``; :meth:`commit` renames it over ``path`` (a crash leaves the old file or the new
    one, never half of one), :meth:`discard` drops it.

    Opening it creates the folder and the temporary file, so a destination that cannot be
    written fails at once (before any work), with an ``OSError`` naming ``path`` -- never the
    temporary file.  A long run streams its trace through one, so memory stays flat.
    """

    def __init__(self, path: str | os.PathLike, *, binary: bool = False) -> None:
        self.path = Path(path)
        _make_folder(self.path.parent, self.path)
        if self.path.is_dir():
            raise IsADirectoryError(errno.EISDIR, "is a folder, expected a file", str(self.path))
        try:
            fd, self._tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(self.path)) from None
        self._fh = os.fdopen(fd, "wb" if binary else "w", **({} if binary else {"encoding": "utf-8"}))

    def write(self, data) -> None:
        with self._named():
            self._fh.write(data)

    def commit(self) -> Path:
        """Publish what was written at ``path``; returns it."""
        with self._named():
            self._fh.flush()
            os.fsync(self._fh.fileno())
            os.fchmod(self._fh.fileno(), 0o666 & ~_umask())  # mkstemp makes 0600; the usual mode
            self._fh.close()
            os.replace(self._tmp, self.path)
        return self.path

    def discard(self) -> None:
        """Drop what was written; ``path`` keeps what it held."""
        if not self._fh.closed:
            self._fh.close()
        try:
            os.unlink(self._tmp)
        except FileNotFoundError:
            pass

    @contextlib.contextmanager
    def _named(self):
        """Any failure discards the temporary file; an OSError names the destination."""
        try:
            yield
        except BaseException as exc:
            self.discard()
            if isinstance(exc, OSError) and not isinstance(exc, BrokenPipeError):
                raise OSError(exc.errno, exc.strerror, str(self.path)) from None
            raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (:class:`AtomicFile`); parent folders are created.
    Returns the path written."""
    f = AtomicFile(path, binary=True)
    f.write(data)
    return f.commit()


def ensure_writable(path: str | os.PathLike) -> Path:
    """Prove now that ``path`` can be written later: its folder is made and a file can be created
    in it.  Commands that write at the end of long work call this first, so a bad ``-o`` is
    refused before the work (``OSError`` naming ``path``)."""
    AtomicFile(path).discard()
    return Path(path)


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


class OutputFolder:
    """A run's output folder, made ready before the run starts.

    ``out`` as given, or a fresh ``runs/<name>`` (``{time}`` in ``name`` becomes the UTC time; a
    suffix ``-2``, ``-3`` ... when it exists): created with its parents and proved writable at
    once, so a run never plays for minutes and then fails to save (an ``OSError`` naming the
    folder, exit status 2, before anything runs).  Files go in atomically (:meth:`write_text`,
    :meth:`write_png`).  ``owned`` names every file the run may write: :meth:`close` removes those
    this run did not write, so a folder reused by ``--out`` holds one run, not a mixture (a dry
    run's report beside an earlier PyBullet run's ``eye.png``).  Files it does not own are left
    alone.
    """

    def __init__(self, out, name: str, owned=()) -> None:
        import time

        if out is not None:
            folder = Path(out)
        else:
            stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
            base = Path("runs") / name.replace("{time}", stamp)
            folder, k = base, 1
            while folder.exists():
                k += 1
                folder = base.with_name(f"{base.name}-{k}")
        probe = folder / ".hila-write-test"
        if folder.exists() and not folder.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, "expected a folder, got a file", str(folder))
        _make_folder(folder, folder)
        try:
            AtomicFile(probe).discard()
        except OSError as exc:
            raise OSError(exc.errno, f"cannot write in this folder: {exc.strerror}", str(folder)) from None
        self.path = folder
        self.owned = set(owned)
        self.written: list[str] = []

    def file(self, name: str) -> Path:
        """The path of ``name`` inside the folder, recorded as written by this run."""
        if name not in self.written:
            self.written.append(name)
        return self.path / name

    def write_text(self, name: str, text: str) -> Path:
        return atomic_write_text(self.file(name), text)

    def write_png(self, name: str, image, *, bgr: bool = False) -> Path:
        return write_png(self.file(name), image, bgr=bgr)

    def close(self) -> list[str]:
        """Remove owned files this run did not write; returns the names written, sorted."""
        for name in sorted(self.owned - set(self.written)):
            try:
                (self.path / name).unlink()
            except FileNotFoundError:
                pass
        return sorted(self.written)


def output_folder(out, name: str) -> Path:
    """``out`` as given (created), or a fresh ``runs/<name>-<UTC time>[-k]`` folder (created),
    proved writable (:class:`OutputFolder`).

    A run that writes files by default writes them where the user will find them and never over
    an earlier run's.
    """
    return OutputFolder(out, name).path
