"""The grammar's LALR tables, built once per installation and kept in the cache folder.

Building hila's parser from ``grammar/hila.lark`` (lark's grammar analysis and LALR table
construction) is most of what the front end costs a fresh process: 0.26-0.37 s of a 1.0-1.6 s
start-up of ``hila exec programs/game.hila`` here (cProfile of ``session.runner.prepare``), paid by
every ``hila`` command, the REPL, the studio's worker and the language server.  The tables depend
only on the grammar's text, the parser's options and lark's version, so lark's own ``cache=``
option keeps them in ``$HILA_CACHE_DIR/hila/grammar`` (else ``~/.cache/hila/grammar``, the folder
the robot model and the lens calibration use: :func:`hila_lang.core.fileio.cache_folders`), under a
name that hashes all of these, and they load in 0.01-0.03 s after that (0.13-0.37 s to build).
lark writes the file in place, so building and reading it hold the folder's lock (``flock``): no
process reads a half-written file; a file that does not load (damaged, e.g. by a crash while it
was written) is built again by lark and written whole; a folder that cannot be written only
costs the build.
The parser's transformer (the AST builder) is never saved: it is given again at each load.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import stat
import sys
from pathlib import Path

import lark as lark_module
from lark import Lark

from ..core.fileio import cache_folders

#: bump when what is saved changes meaning (not needed for a new grammar or lark: both are hashed)
_VERSION = 1


def cache_name(text: str, options: dict) -> str:
    """The cache file's name for the grammar ``text`` built with ``options`` by this lark."""
    what = {"grammar": text, "options": {k: repr(v) for k, v in sorted(options.items())},
            "lark": lark_module.__version__, "python": list(sys.version_info[:2]), "version": _VERSION}
    return f"parser-{hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()[:16]}.pickle"


def build(path: Path, transformer, **options) -> Lark:
    """lark's parser of the grammar at ``path`` (``transformer`` and ``options`` as lark takes
    them), its tables read from the cache folder when they are there (lark's own ``cache=``
    option) and saved there when they were built.  lark writes the file in place, so reading and
    building hold the folder's lock: a process never reads a file another is writing."""
    final = _where(cache_name(path.read_text(encoding="utf-8"), options))
    with _locked(final):
        return Lark.open(str(path), cache=str(final) if final else False, transformer=transformer, **options)


def _where(name: str) -> Path | None:
    """The cache file ``name`` in the first cache folder that is there or can be made; None: no cache."""
    for folder in cache_folders("grammar"):
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        return folder / name
    return None


@contextlib.contextmanager
def _locked(final: Path | None):
    """The cache folder's lock (``.lock`` beside ``final``, flock, exclusive) held while inside;
    nothing when there is no cache or no lock can be taken (then lark's own check of what it
    reads, which builds again from a file it cannot load, is what is left)."""
    fd = None
    try:
        # lazy: POSIX only; elsewhere the cache is used without the lock
        import fcntl

        if final is not None:
            # never through a symlink, never blocking on a FIFO put there: only a regular file locks
            fd = os.open(final.parent / ".lock", os.O_WRONLY | os.O_CREAT | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0),
                         0o644)
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise OSError(f"{final.parent / '.lock'} is not a regular file")
            fcntl.flock(fd, fcntl.LOCK_EX)
    except (ImportError, OSError):  # no fcntl, a folder not writable, a file system without locks
        pass
    try:
        yield
    finally:
        if fd is not None:
            os.close(fd)  # which unlocks it
