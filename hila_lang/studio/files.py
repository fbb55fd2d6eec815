"""The studio's folder: what the pages list, read and write in it, and the one place files are written.

Routes:

- ``GET /api/files`` the folder's templates, programs, demonstrations, pictures and recordings
  (:data:`LISTED`; hidden files, links out of the folder and anything deeper than 3 levels left
  out);
- ``GET|PUT /api/file?path=`` a text file (a program) read, or written atomically;
- ``GET /api/raw?path=`` a file's bytes (an uploaded picture); ``POST /api/upload?path=`` a file
  up to :data:`.security.MAX_UPLOAD` bytes, written atomically.

Every file the studio writes goes through :func:`write` (a page's save as well as an upload), each
atomically (:mod:`hila_lang.core.fileio`), each inside the folder (:func:`.security.inside`):
that is where several files saved together become one transaction.
"""

from __future__ import annotations

from pathlib import Path

from starlette.requests import Request
from starlette.responses import JSONResponse, PlainTextResponse, Response
from starlette.routing import Route

from ..core.errors import InputError
from ..core.fileio import atomic_write_bytes, atomic_write_text, read_bytes, read_text
from .page import read_body, studio_of
from .security import inside

LISTED = (".yaml", ".hila", ".csv", ".hilarec", ".png", ".jpg", ".jpeg")


def listing(folder: Path) -> list[str]:
    """The files a page may open, relative to ``folder``, sorted, at most 2000."""
    found = []
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder)
        if any(part.startswith(".") for part in rel.parts) or not p.is_file() or p.suffix.lower() not in LISTED:
            continue
        if len(rel.parts) > 3:
            continue
        try:
            inside(folder, rel.as_posix())
        except InputError:
            continue  # a symlink out is not listed
        found.append(rel.as_posix())
    return found[:2000]


def write(folder: Path, contents: dict[str, str | bytes]) -> list[Path]:
    """Write each ``name -> text or bytes`` inside ``folder``, atomically; returns the paths written."""
    paths = [inside(folder, name) for name in contents]  # every name checked before anything is written
    for path, data in zip(paths, contents.values()):
        (atomic_write_bytes if isinstance(data, bytes) else atomic_write_text)(path, data)
    return paths


async def files(request: Request) -> Response:
    folder = studio_of(request).folder
    return JSONResponse({"folder": str(folder), "files": listing(folder)})


async def file(request: Request) -> Response:
    studio = studio_of(request)
    name = request.query_params.get("path", "")
    path = studio.path(name)
    if request.method == "PUT":
        data = await read_body(request)
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            raise InputError("expected UTF-8 text") from None
        write(studio.folder, {name: text})
        return JSONResponse({"saved": path.relative_to(studio.folder).as_posix(), "bytes": len(data)})
    return PlainTextResponse(read_text(path, "file"))


async def raw(request: Request) -> Response:
    path = studio_of(request).path(request.query_params.get("path", ""))
    return Response(read_bytes(path, "file"), media_type="application/octet-stream")


async def upload(request: Request) -> Response:
    studio = studio_of(request)
    name = request.query_params.get("path", "")
    path = studio.path(name)
    data = await read_body(request)
    write(studio.folder, {name: data})
    return JSONResponse({"saved": path.relative_to(studio.folder).as_posix(), "bytes": len(data)})


ROUTES = [
    Route("/api/files", files),
    Route("/api/file", file, methods=["GET", "PUT"]),
    Route("/api/raw", raw),
    Route("/api/upload", upload, methods=["POST"]),
]
