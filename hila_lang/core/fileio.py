"""Safe file input and output shared by every stage: atomic writes, bounded reads, safe YAML, output folders."""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import re
import secrets
import shutil
import stat
import stat as _stat
import tempfile
import time
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


#: paths that name one of this process's own open files (``/dev/stdout``, ``/dev/fd/3``):
#: written through the descriptor itself, never opened by name (that would truncate a file the
#: shell appends to) and never renamed over
_OWN_FD = re.compile(r"^/(?:dev/(?:std(in|out|err)|fd/(\d+))|proc/(?:self|thread-self|\d+)/fd/(\d+))$")


def _own_fd(path: Path) -> int | None:
    """The descriptor ``path`` names (``/dev/stdout`` -> 1, ``/proc/self/fd/3`` -> 3), or None."""
    m = _OWN_FD.match(os.path.normpath(str(path)))
    if m is None:
        return None
    if m.group(1):
        return {"in": 0, "out": 1, "err": 2}[m.group(1)]
    if m.group(3) and not str(path).startswith(("/proc/self/", "/proc/thread-self/", f"/proc/{os.getpid()}/")):
        return None  # another process's descriptor: an ordinary (special) path
    return int(m.group(2) or m.group(3))


def special_kind(path: str | os.PathLike) -> str | None:
    """What ``path`` names when it is not a regular file or a folder (symlinks followed):
    ``"FIFO"``, ``"character device"``, ``"block device"``, ``"socket"``; else None (a regular
    file, a folder, or nothing yet)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    for test, kind in ((stat.S_ISFIFO, "FIFO"), (stat.S_ISCHR, "character device"),
                       (stat.S_ISBLK, "block device"), (stat.S_ISSOCK, "socket")):
        if test(mode):
            return kind
    return None


class AtomicFile:
    """A file written in pieces and published whole: the pieces go to a temporary file beside
    ``path``; :meth:`commit` renames it over ``path`` (a crash leaves the old file or the new
    one, never half of one), :meth:`discard` drops it.

    Opening it creates the folder and the temporary file, so a destination that cannot be
    written fails at once (before any work), with an ``OSError`` naming ``path`` -- never the
    temporary file.  A long run streams its trace through one, so memory stays flat.

    What ``path`` names decides how (issue 20: an "atomic" write must never replace a node it
    was pointed at):

    - a symlink (or a chain of them) is followed: the file it points to is replaced atomically,
      and the link stays a link;
    - ``/dev/stdout``, ``/dev/stderr``, ``/dev/fd/N``: written through that descriptor of this
      process (a copy of it), so ``-o /dev/stdout >> log`` appends;
    - a FIFO, a character or block device: written directly (streamed), never renamed over.  A
      FIFO nobody reads is refused at once (``ENXIO``, "no reader"), rather than blocking or
      writing into nothing; a socket is refused.  ``commit`` flushes, ``discard`` only stops
      (what was streamed is gone);
    - a regular file keeps its permission bits; a new one gets the usual ``0666 & ~umask``.
    """

    def __init__(self, path: str | os.PathLike, *, binary: bool = False) -> None:
        self.path = Path(path)
        self.streamed = False
        self.failed: OSError | None = None  # the write that failed, if one did
        self._tmp = None
        mode = "wb" if binary else "w"
        kwargs = {} if binary else {"encoding": "utf-8"}
        fd = _own_fd(self.path)
        kind = special_kind(self.path)
        if fd is not None or kind is not None:
            self.streamed = True
            self._fh = os.fdopen(self._open_stream(fd, kind), mode, **kwargs)
            return
        target = Path(os.path.realpath(self.path)) if self.path.is_symlink() else self.path
        self.target = target
        _make_folder(target.parent, self.path)
        if target.is_dir():
            raise IsADirectoryError(errno.EISDIR, "is a folder, expected a file", str(self.path))
        try:
            fd, self._tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(self.path)) from None
        self._fh = os.fdopen(fd, mode, **kwargs)

    def _open_stream(self, fd: int | None, kind: str | None) -> int:
        """A descriptor to stream to: a copy of this process's ``fd``, or the node opened by name
        (a FIFO without blocking, so one with no reader fails now, by name)."""
        name = str(self.path)
        try:
            if fd is not None:
                return os.dup(fd)
            if kind == "socket":
                raise OSError(errno.EINVAL, "is a socket; expected a file, a FIFO or a device", name)
            if kind == "FIFO":
                out = os.open(self.path, os.O_WRONLY | os.O_NONBLOCK | os.O_CLOEXEC)
                os.set_blocking(out, True)
                return out
            return os.open(self.path, os.O_WRONLY | os.O_CLOEXEC)
        except OSError as exc:
            if exc.errno == errno.ENXIO and kind == "FIFO":
                raise OSError(exc.errno, "a FIFO with no reader (start the reader first)", name) from None
            if exc.errno == errno.EBADF:
                raise OSError(exc.errno, "names a file descriptor this process does not have open", name) from None
            raise OSError(exc.errno, exc.strerror, name) from None

    def write(self, data) -> None:
        with self._named():
            self._fh.write(data)

    def commit(self) -> Path:
        """Publish what was written at ``path``; returns it.  After a write that failed (a full
        disk), the same error again: nothing is published, the temporary file is gone."""
        if self.failed is not None:
            raise OSError(self.failed.errno, self.failed.strerror, str(self.path))
        with self._named():
            self._fh.flush()
            if self.streamed:
                self._fh.close()
                return self.path
            os.fsync(self._fh.fileno())
            try:  # the file replaced keeps its mode (mkstemp makes 0600)
                mode = os.stat(self.target).st_mode & 0o7777
            except FileNotFoundError:
                mode = 0o666 & ~_umask()
            os.fchmod(self._fh.fileno(), mode)
            self._fh.close()
            os.replace(self._tmp, self.target)
        return self.path

    def discard(self) -> None:
        """Drop what was written; ``path`` keeps what it held (a stream only stops)."""
        if not self._fh.closed:
            try:
                self._fh.close()
            except OSError:  # a stream's last flush failed (a full device): nothing to keep
                pass
        if self._tmp is None:
            return
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
                self.failed = exc
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
    refused before the work (``OSError`` naming ``path``).

    A FIFO or a device is only checked for write permission: opening a FIFO now would give its
    reader an end of file before the real write."""
    if _own_fd(Path(path)) is None and special_kind(path) is not None:
        if special_kind(path) == "socket" or not os.access(path, os.W_OK):
            AtomicFile(path).discard()  # raises, naming the problem
        return Path(path)
    AtomicFile(path).discard()
    return Path(path)


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Atomic :func:`atomic_write_bytes` for UTF-8 text."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def write_png(path: str | os.PathLike, image, *, bgr: bool = False) -> Path:
    """Write an image (H, W, 3) or (H, W) uint8 as PNG, atomically.

    ``image`` is RGB unless ``bgr`` (OpenCV's own channel order, for images drawn with cv2).
    """
    try:
        data = png_bytes(image, bgr=bgr)
    except InputError as exc:  # pragma: no cover - OpenCV encodes any uint8 image
        exc.file = str(path)
        raise
    return atomic_write_bytes(path, data)


def png_bytes(image, *, bgr: bool = False) -> bytes:
    """An image (H, W, 3) or (H, W) uint8 encoded as PNG; RGB unless ``bgr``."""
    # lazy: loads cv2 and numpy, which importing this module does not
    import cv2
    import numpy as np

    image = np.ascontiguousarray(image)
    if image.ndim == 3 and not bgr:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", image)
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise InputError(f"cannot encode a PNG image of shape {image.shape}")
    return buf.tobytes()


MB = 1 << 20
#: the largest file hila reads, by what it is (bytes): checked before reading, so a huge file
#: (or ``/dev/zero``) is refused at once instead of filling memory (issue 20).
#:
#: - a program: 8 MB.  ``bench/parse.py`` compiles a 5 MB program (270,000 states, near
#:   :data:`~hila_lang.language.limits.MAX_STATES`); the shipped ones are under 4 kB.
#: - a template (and any YAML file): 4 MB, about 60,000 waypoints at full precision.  PyYAML
#:   reads a 3.2 MB template (50,000 waypoints) in 15 s and 86 MB here (load 7 on 2 cores);
#:   10^6 waypoints took 199 s and 3.8 GB.  The shipped ones are under 8 kB.
#: - anything else (a demonstration CSV, a recording's members are bounded separately): 64 MB.
READ_LIMITS = {"program": 8 * MB, "template": 4 * MB}
YAML_LIMIT = 4 * MB
DEFAULT_READ_LIMIT = 64 * MB


def _size(n: int) -> str:
    return f"{n / MB:.1f} MB" if n >= MB else f"{n:,} bytes"


def check_regular(path: str | os.PathLike, what: str = "file") -> os.stat_result:
    """``os.stat(path)``, refusing what is not a regular file before anything opens it (a FIFO
    would block, ``/dev/zero`` never ends): :class:`InputError` naming ``what`` and the path."""
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{what} not found", file=str(path)) from None
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror}", file=str(path)) from None
    if _stat.S_ISDIR(st.st_mode):
        raise InputError(f"expected a {what}, got a directory", file=str(path))
    if not _stat.S_ISREG(st.st_mode):
        raise InputError(f"expected a {what} (a regular file), got a {special_kind(path) or 'special file'}",
                         file=str(path))
    return st


def read_bytes(path: str | os.PathLike, what: str = "file", limit: int | None = None) -> bytes:
    """Read a file, turning every OS failure into an :class:`InputError` naming ``what`` and the path.

    Only a regular file is read (:func:`check_regular`), and at most ``limit`` bytes (default:
    :data:`READ_LIMITS` for ``what``, else :data:`DEFAULT_READ_LIMIT`): a larger one is refused
    before it is read, with the limit in the message.
    """
    path = Path(path)
    if limit is None:
        limit = READ_LIMITS.get(what, DEFAULT_READ_LIMIT)
    st = check_regular(path, what)
    too_big = InputError(f"{what} is too large: {_size(st.st_size)}, more than hila reads ({_size(limit)})",
                         file=str(path), hint=f"a {what} this large is not one hila writes; check the file")
    if st.st_size > limit:
        raise too_big
    try:
        with open(path, "rb") as f:
            data = f.read(limit + 1)  # a file that grows (or /proc) is bounded too
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror}", file=str(path)) from None
    if len(data) > limit:
        raise too_big
    return data


def read_text(path: str | os.PathLike, what: str = "file", limit: int | None = None) -> str:
    """Read a UTF-8 text file, turning every OS or decoding failure into :class:`InputError`
    (at most ``limit`` bytes, see :func:`read_bytes`)."""
    data = read_bytes(path, what, limit)
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
    # lazy: loads yaml, which importing this module does not
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


#: most nodes a YAML document may hold with every alias expanded: a template of 60,000
#: waypoints (the :data:`YAML_LIMIT`) has about 240,000; nine nested anchors of nine aliases
#: each (685 bytes, "a billion laughs") would expand to 387 million and needed > 5.5 GB
MAX_YAML_NODES = 1_000_000


def _expanded_nodes(root) -> int:
    """How many nodes ``root`` (a composed YAML node) holds with every alias expanded, counted
    without expanding (each node once, iteratively); stops early past :data:`MAX_YAML_NODES`.
    A node that contains itself (a recursive alias) is a ``ValueError``."""
    # lazy: loads yaml, which importing this module does not
    import yaml

    sizes: dict[int, int] = {}
    open_: set[int] = set()
    stack = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = list(node.value)
        else:
            children = []
        if done:
            open_.discard(key)
            sizes[key] = min(1 + sum(sizes[id(c)] for c in children), MAX_YAML_NODES + 1)
            continue
        if key in sizes:
            continue
        if key in open_:
            raise ValueError("an alias refers to a node that contains it (a recursive alias)")
        open_.add(key)
        stack.append((node, True))
        for c in children:
            if id(c) in open_:
                raise ValueError("an alias refers to a node that contains it (a recursive alias)")
            if id(c) not in sizes:
                stack.append((c, False))
    return sizes[id(root)]


def load_yaml(path: str | os.PathLike, what: str = "YAML file", *, unique_keys: bool = False) -> Any:
    """``yaml.safe_load`` a file; syntax errors become :class:`InputError` with line and column.

    With ``unique_keys`` a key repeated in one mapping is an error too (plain YAML keeps the last
    one silently), reported at the repeated key's line and column.

    Bounded before anything is built (issue 20): the file is at most :data:`YAML_LIMIT` bytes
    (:data:`READ_LIMITS` for a template), the document at most :data:`MAX_YAML_NODES` nodes
    with its aliases expanded, and nested no deeper than Python's recursion allows.
    """
    # lazy: loads yaml, which importing this module does not
    import yaml

    text = read_text(path, what, READ_LIMITS.get(what, YAML_LIMIT))
    loader = None
    try:
        loader = (_unique_key_loader() if unique_keys else yaml.SafeLoader)(text)  # reads: may raise
        node = loader.get_single_node()
        if node is None:
            return None
        try:
            n = _expanded_nodes(node)
        except ValueError as exc:
            raise InputError(f"{what} is not valid for hila: {exc}", file=str(path)) from None
        if n > MAX_YAML_NODES:
            raise InputError(f"{what} expands to more than {MAX_YAML_NODES:,} values through its aliases "
                             "(*name): an alias bomb?", file=str(path),
                             hint="write the values out instead of repeating them by alias")
        return loader.construct_document(node)
    except RecursionError:
        raise InputError(f"{what} is nested too deeply (lists or mappings inside each other)",
                         file=str(path)) from None
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
    finally:
        if loader is not None:
            loader.dispose()


def yaml_text(data: Any, header: str = "") -> str:
    """``data`` as block-style YAML after an optional ``# comment`` header."""
    # lazy: loads yaml, which importing this module does not
    import yaml

    body = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    if header:
        header = "".join(f"# {ln}\n" if ln else "#\n" for ln in header.splitlines())
    return header + body


def dump_yaml(path: str | os.PathLike, data: Any, header: str = "") -> Path:
    """Write :func:`yaml_text` of ``data`` atomically."""
    return atomic_write_text(path, yaml_text(data, header))


def cache_folders(name: str) -> list[Path]:
    """Where hila may keep what it computes once and reuses (the generated robot model, the eyes'
    lens calibration): ``$HILA_CACHE_DIR/hila/<name>`` (else ``$XDG_CACHE_HOME`` or
    ``~/.cache``), then a temporary folder for when that one is not writable, in that order.

    The temporary one, ``hila-<uid>`` in the system's temporary folder (shared by every user),
    is created private (0700) and used only if it is a folder (not a link) this user owns that
    nobody else may write in or read (issue 20: another user could plant the robot model and the
    lens calibration a run trusts); otherwise it is left out, with a note.
    """
    base = os.environ.get("HILA_CACHE_DIR") or os.environ.get("XDG_CACHE_HOME")
    root = Path(base) if base else Path.home() / ".cache"
    folders = [root / "hila" / name]
    shared = Path(tempfile.gettempdir()) / f"hila-{os.getuid()}"
    why = _private_folder(shared)
    if why is None:
        folders.append(shared / name)
    else:
        # lazy: only this branch needs it
        import sys

        print(f"note: not using the cache folder {shared}: {why}", file=sys.stderr)
    return folders


def _private_folder(folder: Path) -> str | None:
    """Make ``folder`` 0700 if it is missing; None if it is a folder this user owns with no
    access for others, else why not."""
    try:
        folder.mkdir(mode=0o700)
    except FileExistsError:
        pass
    except OSError as exc:
        return f"cannot make it ({exc.strerror})"
    try:
        st = os.lstat(folder)
    except OSError as exc:
        return f"cannot read it ({exc.strerror})"
    if not stat.S_ISDIR(st.st_mode):
        return "it is not a folder (a link or a file is in its place)"
    if st.st_uid != os.getuid():
        return f"it belongs to another user (uid {st.st_uid})"
    if st.st_mode & 0o022:  # others could have written in it: what it holds cannot be trusted
        return f"others may write in it (mode {stat.S_IMODE(st.st_mode):04o}; expected 0700)"
    if st.st_mode & 0o077:  # readable by others (an older hila made it 0755): ours, made private
        try:
            os.chmod(folder, 0o700)
        except OSError as exc:
            return f"cannot make it private ({exc.strerror})"
    return None


#: the manifest of an output folder: which run wrote which file (:class:`OutputFolder`)
MANIFEST = ".hila-run.json"
_STAGING = ".hila-staging-"


class OutputFolder:
    """A run's output folder, made ready before the run starts.

    ``out`` as given, or a fresh ``runs/<name>`` (``{time}`` in ``name`` becomes the UTC time; a
    suffix ``-2``, ``-3`` ... when it exists): created with its parents and proved writable at
    once, so a run never plays for minutes and then fails to save (an ``OSError`` naming the
    folder, exit status 2, before anything runs).

    A folder reused by ``--out`` holds one run, never a mixture (issue 20):

    - the files (:meth:`write_text`, :meth:`write_png`, or a path from :meth:`file`) go to a
      hidden staging folder inside it, ``.hila-staging-<pid>-<run>``; a stop, a kill or a full
      disk while writing leaves the previous run's files untouched (the next run removes the
      staging folder of a process that is gone);
    - :meth:`close` publishes them: first the manifest ``.hila-run.json`` names this run and
      the SHA-256 of every file it is about to publish (``"complete": false``), then the owned
      files this run did not write are removed and the new ones renamed into place, then the
      manifest says ``"complete": true``.  A kill in that short window leaves a manifest that
      says which file is of which run.

    ``owned`` names every file the run may write; files it does not own are left alone.
    """

    def __init__(self, out, name: str, owned=()) -> None:
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
        self.run = f"{time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}/{os.getpid()}/{secrets.token_hex(3)}"
        self._staging = folder / staging_name()
        remove_stale_staging(folder)

    def file(self, name: str) -> Path:
        """Where to write ``name`` (in the staging folder), recorded as written by this run."""
        if name not in self.written:
            self.written.append(name)
        self._staging.mkdir(exist_ok=True)
        return self._staging / name

    def names(self) -> list[str]:
        """The names written so far, sorted."""
        return sorted(self.written)

    def write_text(self, name: str, text: str) -> Path:
        return self._staged(atomic_write_text, name, text)

    def write_png(self, name: str, image, *, bgr: bool = False) -> Path:
        return self._staged(write_png, name, image, bgr=bgr)

    def _staged(self, write, name, *args, **kwargs) -> Path:
        try:
            write(self.file(name), *args, **kwargs)
        except OSError as exc:  # a full disk: nothing of this run is published
            self.discard()
            raise OSError(exc.errno, exc.strerror, str(self.path / name)) from None
        return self.path / name

    def discard(self) -> None:
        """Drop what this run staged; the folder keeps the previous run's files."""
        shutil.rmtree(self._staging, ignore_errors=True)

    def close(self) -> list[str]:
        """Publish the files written (see the class docstring) and remove owned files this run
        did not write; returns the names written, sorted."""
        names = self.names()
        staged = [n for n in names if (self._staging / n).exists()]
        manifest = {"run": self.run, "complete": False,
                    "files": {n: hashlib.sha256((self._staging / n).read_bytes()).hexdigest() for n in staged}}
        try:
            atomic_write_text(self.path / MANIFEST, json.dumps(manifest, indent=1) + "\n")
            for name in sorted(self.owned - set(names)):
                try:
                    (self.path / name).unlink()
                except FileNotFoundError:
                    pass
            for name in staged:
                os.replace(self._staging / name, self.path / name)
            manifest["complete"] = True
            atomic_write_text(self.path / MANIFEST, json.dumps(manifest, indent=1) + "\n")
        finally:
            self.discard()
        return names


def staging_name() -> str:
    """A fresh name for a staging folder of this process (``.hila-staging-<pid>-<random>``):
    what :func:`remove_stale_staging` recognises once the process is gone."""
    return f"{_STAGING}{os.getpid()}-{secrets.token_hex(6)}"


_STAGING_NAME = re.compile(re.escape(_STAGING) + r"(\d+)-[0-9a-f]{1,64}")


def remove_stale_staging(folder: Path) -> list[str]:
    """Remove the staging folders in ``folder`` (not below) that a hila process killed while
    writing left behind; returns their names.

    Only hila's own are touched, each identified safely: the name is exactly
    :func:`staging_name`'s, it is a folder (not a link) that this user owns, the process it names
    is gone (a live one may be writing in it: a studio or a run beside this one), and it holds
    only regular files (hila stages files, never folders).  Its files are removed relative to the
    folder opened without following links, so a link swapped in meanwhile removes nothing else."""
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for name in names:
        match = _STAGING_NAME.fullmatch(name)
        if match is None:
            continue
        try:
            os.kill(int(match.group(1)), 0)
            continue  # its process is alive (or the number is another live process's): not stale
        except ProcessLookupError:
            pass
        except (OverflowError, PermissionError):  # not a pid, or another user's process: not ours
            continue
        try:
            fd = os.open(Path(folder) / name, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
        except OSError:
            continue  # a link, a file, or gone meanwhile
        try:
            st = os.fstat(fd)
            entries = os.listdir(fd)
            kinds = [os.stat(e, dir_fd=fd, follow_symlinks=False).st_mode for e in entries]
            if st.st_uid != os.getuid() or not all(stat.S_ISREG(k) for k in kinds):
                continue
            for entry in entries:
                os.unlink(entry, dir_fd=fd)
        except OSError:
            continue
        finally:
            os.close(fd)
        try:
            os.rmdir(Path(folder) / name)
            removed.append(name)
        except OSError:
            pass
    return removed


def output_folder(out, name: str) -> Path:
    """``out`` as given (created), or a fresh ``runs/<name>-<UTC time>[-k]`` folder (created),
    proved writable (:class:`OutputFolder`).

    A run that writes files by default writes them where the user will find them and never over
    an earlier run's.
    """
    return OutputFolder(out, name).path
