"""A virtual X display (Xvfb) and a screenshot of it, for the ``--gui`` test (no X tools needed
beyond Xvfb itself: the screen is read with libX11 through ctypes)."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import shutil
import subprocess
import time

import numpy as np


def xvfb_missing() -> str | None:
    """Why a virtual display cannot be had here, or None."""
    if shutil.which("Xvfb") is None:
        return "Xvfb is not installed (Debian: apt-get install xvfb)"
    if ctypes.util.find_library("X11") is None:
        return "libX11 is not installed"
    return None


class VirtualDisplay:
    """``with VirtualDisplay(1280, 800) as d:`` runs Xvfb on a free display number ``d.name``."""

    def __init__(self, width: int = 1280, height: int = 800) -> None:
        self.width, self.height = width, height
        self.proc = None
        self.name = ""

    def __enter__(self) -> "VirtualDisplay":
        for number in range(99, 140):
            if os.path.exists(f"/tmp/.X11-unix/X{number}") or os.path.exists(f"/tmp/.X{number}-lock"):
                continue
            proc = subprocess.Popen(["Xvfb", f":{number}", "-screen", "0", f"{self.width}x{self.height}x24",
                                     "-nolisten", "tcp"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for _ in range(100):
                if os.path.exists(f"/tmp/.X11-unix/X{number}") or proc.poll() is not None:
                    break
                time.sleep(0.05)
            if proc.poll() is None:
                self.proc, self.name = proc, f":{number}"
                return self
        raise RuntimeError("no free X display number for Xvfb")

    def __exit__(self, *exc) -> None:
        if self.proc is not None:
            self.proc.terminate()
            self.proc.wait(timeout=10)

    def screenshot(self) -> np.ndarray:
        """The whole screen (height, width, 3) uint8 RGB."""
        return screenshot(self.name)


def screenshot(display: str) -> np.ndarray:
    x11 = ctypes.cdll.LoadLibrary(ctypes.util.find_library("X11"))
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XDefaultRootWindow.restype = ctypes.c_ulong
    x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
    x11.XGetImage.restype = ctypes.c_void_p
    x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int, ctypes.c_uint,
                              ctypes.c_uint, ctypes.c_ulong, ctypes.c_int]
    x11.XDisplayWidth.argtypes = x11.XDisplayHeight.argtypes = [ctypes.c_void_p, ctypes.c_int]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    x11.XDestroyImage = getattr(x11, "XDestroyImage", None)

    class XImage(ctypes.Structure):
        _fields_ = [("width", ctypes.c_int), ("height", ctypes.c_int), ("xoffset", ctypes.c_int),
                    ("format", ctypes.c_int), ("data", ctypes.POINTER(ctypes.c_ubyte)),
                    ("byte_order", ctypes.c_int), ("bitmap_unit", ctypes.c_int),
                    ("bitmap_bit_order", ctypes.c_int), ("bitmap_pad", ctypes.c_int), ("depth", ctypes.c_int),
                    ("bytes_per_line", ctypes.c_int), ("bits_per_pixel", ctypes.c_int)]

    dpy = x11.XOpenDisplay(display.encode())
    if not dpy:
        raise RuntimeError(f"cannot open display {display}")
    try:
        w, h = x11.XDisplayWidth(dpy, 0), x11.XDisplayHeight(dpy, 0)
        ptr = x11.XGetImage(dpy, x11.XDefaultRootWindow(dpy), 0, 0, w, h, 0xFFFFFFFF, 2)  # ZPixmap
        img = ctypes.cast(ptr, ctypes.POINTER(XImage)).contents
        raw = np.ctypeslib.as_array(img.data, shape=(img.height * img.bytes_per_line,)).copy()
        pixels = raw.reshape(img.height, img.bytes_per_line)[:, : img.width * 4].reshape(img.height, img.width, 4)
        return pixels[:, :, [2, 1, 0]].copy()  # BGRX -> RGB
    finally:
        x11.XCloseDisplay(dpy)
