"""Silence C-level output (PyBullet's URDF importer and banner print through C stdio).

Python's ``contextlib.redirect_stdout`` cannot catch them: the file descriptors 1 and 2
themselves are pointed at ``/dev/null`` for the duration, after flushing C's buffers.
"""

from __future__ import annotations

import ctypes
import os
import sys
from contextlib import contextmanager

try:
    _LIBC = ctypes.CDLL(None)
except OSError:  # pragma: no cover - no C library to flush (not on Linux/macOS)
    _LIBC = None


def _flush_all() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, ValueError, OSError):
            pass
    if _LIBC is not None:
        _LIBC.fflush(None)


@contextmanager
def quiet_c_output():
    """Send everything written to file descriptors 1 and 2 inside the block to /dev/null."""
    _flush_all()
    saved = []
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:  # no usable fds (a detached process): nothing to silence
        for fd in saved:
            os.close(fd)
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        _flush_all()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def import_pybullet():
    """``import pybullet`` without its build-time banner on stdout."""
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    with quiet_c_output():
        # lazy: loads pybullet, numpy, which importing this module does not
        import pybullet
    return pybullet
