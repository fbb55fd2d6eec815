"""The studio's folder: what the pages list, read and write in it, and the one place files are written.

Routes:

- ``GET /api/files`` the folder's templates, programs, demonstrations, pictures and recordings
  (:data:`LISTED`; hidden files, links out of the folder and anything deeper than 3 levels left
  out);
- ``GET|PUT /api/file?path=(&overwrite=1)`` a text file (a program) read, or written;
- ``GET /api/raw?path=`` a file's bytes (an uploaded picture); ``POST
  /api/upload?path=(&overwrite=1)`` a file up to :data:`.security.MAX_UPLOAD` bytes.

Every file the studio writes goes through :func:`write` (a page's save as well as an upload):
one :class:`Transaction` per action, all its files published together or none, under per-name
locks; a name that exists is replaced only with ``overwrite`` (else :class:`Exists`, answered
409).  Every file it reads, :func:`read` opens once, inside the folder, following no link.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import stat
import threading
from pathlib import Path, PurePosixPath

from starlette.requests import Request
from starlette.responses import JSONResponse, PlainTextResponse, Response
from starlette.routing import Route

from ..core.errors import InputError
from ..core.fileio import read_bytes, staging_name
from ..language.source import read_source
from ..session.recording import read_record
from .page import read_body, studio_of
from .schema import FILE_QUERY, query
from .security import inside, open_folder, opened

LISTED = (".yaml", ".hila", ".csv", ".hilarec", ".png", ".jpg", ".jpeg")


def listing(folder: Path, depth: int = 3) -> list[str]:
    """The files a page may open, relative to ``folder``, sorted, at most 2000, at most ``depth``
    folders down (``depth=1``: ``folder`` itself, its subfolders not walked)."""
    found = []
    for p in sorted(folder.glob("*") if depth == 1 else folder.rglob("*")):
        rel = p.relative_to(folder)
        if any(part.startswith(".") for part in rel.parts) or not p.is_file() or p.suffix.lower() not in LISTED:
            continue
        if len(rel.parts) > depth:
            continue
        try:
            inside(folder, rel.as_posix())
        except InputError:
            continue  # a symlink out is not listed
        found.append(rel.as_posix())
    return found[:2000]


class Exists(InputError):
    """A write that would replace a file without ``overwrite``: answered 409 (the page asks the
    person, then sends ``overwrite``)."""


_locks: dict[tuple[str, str], threading.Lock] = {}
_locks_guard = threading.Lock()


def _lock(folder: Path, name: str) -> threading.Lock:
    key = (str(folder), PurePosixPath(name.replace("\\", "/")).as_posix())
    with _locks_guard:
        return _locks.setdefault(key, threading.Lock())


class Transaction:
    """Every file one action writes, published together or not at all.

    ``stage(name, data)`` writes a file (fsynced) into a private staging folder
    (:func:`hila_lang.core.fileio.staging_name` in FOLDER, so publishing is a rename on one file
    system; one a crash left behind is removed at the studio's next start:
    :func:`hila_lang.core.fileio.remove_stale_staging`).  Leaving the
    ``with`` block publishes:
    under the per-name locks of every name (taken in sorted order, so two saves of one name
    wait for each other and neither sees the other's half), each name is checked (it must not
    exist unless ``overwrite``: :class:`Exists`, nothing replaced), then renamed into place
    from the staging folder into the folder opened with :func:`.security.open_folder` (no link
    followed).  If one rename fails the ones done are undone from hard links of the old files.
    An error inside the block publishes nothing."""

    def __init__(self, folder: Path, *, overwrite: bool) -> None:
        self.folder, self.overwrite = folder.resolve(), bool(overwrite)
        self.staged: dict[str, str] = {}  # name -> staged file name
        self._root = os.open(self.folder, os.O_RDONLY | os.O_DIRECTORY)
        self._stage_name = staging_name()  # .hila-staging-<pid>-<random>: removed at a start once its process is gone
        try:
            os.mkdir(self._stage_name, 0o700, dir_fd=self._root)
            self._stage = os.open(self._stage_name, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW,
                                  dir_fd=self._root)
        except BaseException:
            os.close(self._root)
            raise

    def stage(self, name: str, data: str | bytes) -> None:
        inside(self.folder, name)  # a bad name refused now; the write itself opens it again without links
        staged = str(len(self.staged))
        # 0666 less the umask, as any new file (the staging folder itself is 0700 meanwhile)
        fd = os.open(staged, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666, dir_fd=self._stage)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode("utf-8") if isinstance(data, str) else data)
            fh.flush()
            os.fsync(fh.fileno())
        self.staged[name] = staged

    def __enter__(self) -> "Transaction":
        return self

    def __exit__(self, kind, exc, tb) -> None:
        try:
            if kind is None:
                self.publish()
        finally:
            for staged in os.listdir(self._stage):
                os.unlink(staged, dir_fd=self._stage)
            os.close(self._stage)
            os.rmdir(self._stage_name, dir_fd=self._root)
            os.close(self._root)

    def publish(self) -> list[str]:
        names = sorted(self.staged)
        folders = {}
        locks = [_lock(self.folder, n) for n in names]
        for lock in locks:
            lock.acquire()
        try:
            for name in names:  # every name checked (and its folder opened) before anything is replaced
                folders[name] = open_folder(self.folder, name, create=True)
                dfd, leaf = folders[name]
                try:
                    st = os.stat(leaf, dir_fd=dfd, follow_symlinks=False)
                except FileNotFoundError:
                    st = None
                if st is not None and stat.S_ISDIR(st.st_mode):
                    raise InputError(f"cannot write {name!r}: it is a folder")
                if st is not None and not self.overwrite:
                    raise _exists(name)
                if st is not None and stat.S_ISREG(st.st_mode):  # the file replaced keeps its mode
                    os.chmod(self.staged[name], st.st_mode & 0o7777, dir_fd=self._stage)
            done: list[tuple[str, str | None]] = []  # (name, its backup's name or None: it was new)
            try:
                for name in names:
                    dfd, leaf = folders[name]
                    try:
                        backup = f".{leaf}.{secrets.token_hex(4)}.old"
                        os.link(leaf, backup, src_dir_fd=dfd, dst_dir_fd=dfd, follow_symlinks=False)
                    except FileNotFoundError:
                        backup = None
                    os.rename(self.staged[name], leaf, src_dir_fd=self._stage, dst_dir_fd=dfd)
                    done.append((name, backup))
            except BaseException:
                for name, backup in reversed(done):  # undo: the old files back, the new ones gone
                    dfd, leaf = folders[name]
                    if backup is None:
                        os.unlink(leaf, dir_fd=dfd)
                    else:
                        os.rename(backup, leaf, src_dir_fd=dfd, dst_dir_fd=dfd)
                raise
            for name, backup in done:
                if backup is not None:
                    os.unlink(backup, dir_fd=folders[name][0])
            for dfd, _ in folders.values():
                os.fsync(dfd)
            return names
        finally:
            for dfd, _ in folders.values():
                os.close(dfd)
            for lock in reversed(locks):
                lock.release()


def _exists(name: str) -> Exists:
    return Exists(f"{name} exists: saving would replace it (send overwrite to replace it)")


def refuse_existing(folder: Path, names, overwrite: bool) -> None:
    """Refuse now (:class:`Exists`) when one of ``names`` exists and ``overwrite`` is not set:
    before the work of making them (publishing checks again, under the names' locks)."""
    if overwrite:
        return
    for name in names:
        try:
            dfd, leaf = open_folder(folder, name)
        except InputError as exc:
            if exc.message.startswith("no file"):
                continue  # its folder is not there: neither is it
            raise
        try:
            os.stat(leaf, dir_fd=dfd, follow_symlinks=False)
        except FileNotFoundError:
            continue
        finally:
            os.close(dfd)
        raise _exists(name)


def write(folder: Path, contents: dict[str, str | bytes], *, overwrite: bool) -> list[str]:
    """Write each ``name -> text or bytes`` inside ``folder`` as one :class:`Transaction`;
    returns the names written."""
    with Transaction(folder, overwrite=overwrite) as t:
        for name, data in contents.items():
            t.stage(name, data)
    return sorted(contents)


def read(folder: Path, name: str, what: str = "file") -> bytes:
    """The bytes of the file ``name`` in ``folder``, opened once (:func:`.security.opened`)."""
    with opened(folder, name, what) as path:
        return read_bytes(path, what)


def read_program(folder: Path, name: str) -> str:
    """The text of the program ``name`` in ``folder``: opened once (:func:`.security.opened`),
    decoded as ``hila exec`` decodes a program."""
    with opened(folder, name, "program") as file:
        return read_source(file)


def program_loader(folder: Path, env):
    """``load(file) -> (checked, fsm)`` for the REPL's ``reload`` of a program in ``folder``: its
    text read again through :func:`read_program`, its imports by ``env`` (the studio's)."""
    return lambda file: env.load(file, read_program(folder, Path(file).relative_to(folder).as_posix()))


def read_recording(folder: Path, name: str) -> tuple[dict, contextlib.ExitStack]:
    """(the recording ``name`` in ``folder`` read (:func:`hila_lang.session.recording.read_record`),
    what holds its file open): opened once without following a link, its eye images are read
    later from that very file; closing the second closes it.  An error names the file."""
    with contextlib.ExitStack() as stack:
        file = stack.enter_context(opened(folder, name, "recording"))
        record = read_record(file)
        return record, stack.pop_all()


async def files(request: Request) -> Response:
    folder = studio_of(request).folder
    return JSONResponse({"folder": str(folder), "files": listing(folder)})


async def file(request: Request) -> Response:
    studio = studio_of(request)
    q = query(request, FILE_QUERY)
    if request.method == "PUT":
        data = await read_body(request)
        try:
            data.decode("utf-8")
        except UnicodeDecodeError:
            raise InputError("expected UTF-8 text") from None
        (name,) = write(studio.folder, {q["path"]: data}, overwrite=q.get("overwrite", False))
        return JSONResponse({"saved": name, "bytes": len(data)})
    try:
        return PlainTextResponse(read(studio.folder, q["path"]).decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(f"{q['path']} is not UTF-8 text") from None


async def raw(request: Request) -> Response:
    name = query(request, FILE_QUERY)["path"]
    return Response(read(studio_of(request).folder, name), media_type="application/octet-stream")


async def upload(request: Request) -> Response:
    studio = studio_of(request)
    q = query(request, FILE_QUERY)
    data = await read_body(request)
    (name,) = write(studio.folder, {q["path"]: data}, overwrite=q.get("overwrite", False))
    return JSONResponse({"saved": name, "bytes": len(data)})


ROUTES = [
    Route("/api/files", files),
    Route("/api/file", file, methods=["GET", "PUT"]),
    Route("/api/raw", raw),
    Route("/api/upload", upload, methods=["POST"]),
]
