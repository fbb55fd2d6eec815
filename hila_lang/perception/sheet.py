"""The printable pen sheet: ArUco markers at the corners, optionally a 3x3 grid; PNG and PDF.

A person prints the sheet (``hila sheet --out sheet.pdf``), lays it on the table in front of a
camera and draws on it with a capped pen; :mod:`hila_lang.perception.pen` finds the markers in
every frame and maps the image to the paper's plane through them.

Layout (:class:`SheetLayout`), in the *sheet frame*: millimetres, origin at the paper's
bottom-left corner, x to the right, y up the page (away from the person drawing), z out of the
paper.  Four ArUco markers (OpenCV's ``DICT_4X4_50``) of :data:`MARKER_MM` sit at the corners,
their outer edges :data:`MARGIN_MM` from the paper's edges (out of the printers' unprintable
border, with a white quiet zone around each).  Which four ids a sheet carries says which sheet
it is (:data:`SHEET_IDS`): A4 or Letter, with or without the grid, so the tracker needs no
option to know the paper.  Ids go top-left, top-right, bottom-right, bottom-left.

Printed features (:meth:`SheetLayout.features`, the ICPs a demonstration may use): the markers'
centres ``tl``, ``tr``, ``br``, ``bl``; on a grid sheet the 16 crossings of the grid's lines,
each named by every cell it is a corner of (``cell5.tl`` is ``cell1.br``), cells numbered 1..9
row by row from the top-left as the person reads the sheet, like the tic-tac-toe world's.

Rendering: one list of shapes (filled rectangles, lines, text) drawn two ways: a raster
(:func:`raster`: exact area coverage for the rectangles, so the markers' edges are where the
layout says at any resolution; the PNG carries its DPI in a ``pHYs`` chunk) and a vector PDF
(:func:`pdf_bytes`: a minimal hand-written PDF 1.4 -- rectangles and lines as paths, text in the
standard Helvetica font that every PDF reader has, no embedded fonts, no dependency).  Why not a
PDF library: none is among hila's dependencies; matplotlib or Pillow would draw the markers as a
raster or need a 50 MB install for what fits in 60 lines, and a vector page prints the markers'
edges exactly at any printer's resolution.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError

#: paper sizes (width, height) in millimetres, portrait
PAPERS = {"a4": (210.0, 297.0), "letter": (215.9, 279.4)}
#: OpenCV's ArUco dictionary of the markers
DICTIONARY = "DICT_4X4_50"
#: side of a marker, black border included, millimetres: about 35 pixels across in a 640x480
#: webcam image of the whole sheet from 45 cm, where OpenCV finds it in every frame
MARKER_MM = 30.0
#: from the paper's edge to a marker's outer edge, millimetres (printers leave 3-6 mm unprinted)
MARGIN_MM = 12.0
#: side of a grid cell, millimetres (a 3x3 grid of 180 mm fits between the markers of A4 and Letter)
CELL_MM = 60.0
#: width of the grid's printed lines, millimetres
LINE_MM = 0.6
#: ids (top-left, top-right, bottom-right, bottom-left) of each sheet: (paper, grid) -> ids
SHEET_IDS = {("a4", False): (0, 1, 2, 3), ("letter", False): (4, 5, 6, 7),
             ("a4", True): (8, 9, 10, 11), ("letter", True): (12, 13, 14, 15)}
CORNERS = ("tl", "tr", "br", "bl")
#: length of the printed scale bar, millimetres (the person checks the print's scale with a ruler)
SCALE_BAR_MM = 100.0
PT_PER_MM = 72.0 / 25.4


@dataclass(frozen=True)
class SheetLayout:
    """What is printed where on one sheet (see the module docstring).

    Attributes
    ----------
    paper : str
        ``"a4"`` or ``"letter"``.
    grid : bool
        Whether the 3x3 grid is printed.
    """

    paper: str = "a4"
    grid: bool = False

    def __post_init__(self) -> None:
        if self.paper not in PAPERS:
            raise InputError(f"unknown paper {self.paper!r}; expected one of {', '.join(PAPERS)}")

    @property
    def size(self) -> tuple[float, float]:
        """(width, height) of the paper, millimetres."""
        return PAPERS[self.paper]

    @property
    def ids(self) -> tuple[int, int, int, int]:
        """Marker ids at the top-left, top-right, bottom-right and bottom-left corners."""
        return SHEET_IDS[(self.paper, self.grid)]

    @property
    def name(self) -> str:
        return f"{'A4' if self.paper == 'a4' else 'Letter'}{' with grid' if self.grid else ''}"

    def marker_origin(self, corner: str) -> tuple[float, float]:
        """Bottom-left point (x, y) of the marker at ``corner``, millimetres."""
        w, h = self.size
        x = MARGIN_MM if corner in ("tl", "bl") else w - MARGIN_MM - MARKER_MM
        y = MARGIN_MM if corner in ("bl", "br") else h - MARGIN_MM - MARKER_MM
        return x, y

    def marker_corners(self) -> dict[int, np.ndarray]:
        """id -> its four corners (4, 2), millimetres, in ArUco's order: the marker's own
        top-left, top-right, bottom-right, bottom-left (printed upright: its top is up the page)."""
        out = {}
        for marker_id, corner in zip(self.ids, CORNERS):
            x, y = self.marker_origin(corner)
            s = MARKER_MM
            out[marker_id] = np.array([[x, y + s], [x + s, y + s], [x + s, y], [x, y]])
        return out

    def grid_lines(self) -> list[float]:
        """Positions of the grid's 4 vertical lines (x) and 4 horizontal ones (y), millimetres:
        (x0, x1, x2, x3, y0, y1, y2, y3), x from the left, y from the bottom."""
        w, h = self.size
        x0, y0 = w / 2 - 1.5 * CELL_MM, h / 2 - 1.5 * CELL_MM
        return [x0 + i * CELL_MM for i in range(4)] + [y0 + i * CELL_MM for i in range(4)]

    def features(self) -> dict[str, np.ndarray]:
        """The printed points an ICP may name: name -> (x, y), millimetres (module docstring)."""
        out = {}
        for marker_id, corner in zip(self.ids, CORNERS):
            out[corner] = self.marker_corners()[marker_id].mean(axis=0)
        if self.grid:
            xs, ys = self.grid_lines()[:4], self.grid_lines()[4:]
            for cell in range(1, 10):
                row, col = divmod(cell - 1, 3)  # row 0 is the top row
                top, bottom = ys[3 - row], ys[2 - row]
                left, right = xs[col], xs[col + 1]
                for name, p in (("tl", (left, top)), ("tr", (right, top)), ("br", (right, bottom)),
                                ("bl", (left, bottom))):
                    out[f"cell{cell}.{name}"] = np.array(p, float)
        return out

    def legend(self) -> list[str]:
        """The lines of text printed on the sheet: what it is and how to check the print."""
        ids = ", ".join(f"{i} {c}" for i, c in zip(self.ids, ("top left", "top right", "bottom right", "bottom left")))
        return [f"hila pen sheet, {self.name} ({self.size[0]:g} x {self.size[1]:g} mm).  "
                f"ArUco {DICTIONARY}: ids {ids}.",
                f"Markers {MARKER_MM:g} mm square (black border included), {MARGIN_MM:g} mm from the edges"
                + (f"; grid cells {CELL_MM:g} mm." if self.grid else "."),
                f"Print at 100 % (not 'fit to page'): the bar below must measure {SCALE_BAR_MM:g} mm.",
                "Keep the four markers in the camera's view; draw with a coloured ball on the pen's tip."]


def layout_for_ids(ids) -> SheetLayout | None:
    """The sheet whose markers include any of ``ids``, or None (no marker of a hila sheet)."""
    seen = set(int(i) for i in ids)
    for (paper, grid), sheet_ids in SHEET_IDS.items():
        if seen & set(sheet_ids):
            return SheetLayout(paper, grid)
    return None


def marker_bits(marker_id: int) -> np.ndarray:
    """The marker's modules (6, 6) bool, True where black, row 0 at the marker's top (border included)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY))
    image = cv2.aruco.generateImageMarker(dictionary, int(marker_id), 6)
    return image < 128


# -- shapes: what both renderers draw ----------------------------------------------------------

@dataclass(frozen=True)
class Rect:
    """A filled rectangle, millimetres, grey level 0 (black) .. 1 (white)."""

    x: float
    y: float
    w: float
    h: float
    grey: float = 0.0


@dataclass(frozen=True)
class Text:
    """A line of text whose baseline starts at (x, y), millimetres; ``size`` in points."""

    x: float
    y: float
    text: str
    size: float = 7.0


def shapes(layout: SheetLayout) -> list:
    """Everything printed on ``layout``'s sheet, as :class:`Rect` and :class:`Text`."""
    out: list = []
    module = MARKER_MM / 6
    for marker_id, corner in zip(layout.ids, CORNERS):
        x0, y0 = layout.marker_origin(corner)
        for row, bits in enumerate(marker_bits(marker_id)):
            col = 0
            while col < 6:  # runs of black modules in a row: one rectangle each
                if not bits[col]:
                    col += 1
                    continue
                end = col
                while end < 6 and bits[end]:
                    end += 1
                out.append(Rect(x0 + col * module, y0 + (5 - row) * module, (end - col) * module, module))
                col = end
    w, h = layout.size
    if layout.grid:
        lines = layout.grid_lines()
        xs, ys = lines[:4], lines[4:]
        for x in xs:
            out.append(Rect(x - LINE_MM / 2, ys[0] - LINE_MM / 2, LINE_MM, ys[3] - ys[0] + LINE_MM, 0.2))
        for y in ys:
            out.append(Rect(xs[0] - LINE_MM / 2, y - LINE_MM / 2, xs[3] - xs[0] + LINE_MM, LINE_MM, 0.2))
        for cell in range(1, 10):
            p = layout.features()[f"cell{cell}.tl"]
            out.append(Text(p[0] + 1.5, p[1] - 4.0, str(cell), 6.0))
    left = MARGIN_MM + MARKER_MM + 4.0
    for i, line in enumerate(layout.legend()):
        out.append(Text(left, MARGIN_MM + MARKER_MM - 3.0 - 3.6 * i, line, 6.0))
    bar_y = MARGIN_MM + 2.0
    out.append(Rect(left, bar_y, SCALE_BAR_MM, 1.0))
    for k in range(0, int(SCALE_BAR_MM) + 1, 10):
        out.append(Rect(left + k - 0.15, bar_y, 0.3, 3.0 if k % 50 == 0 else 2.0))
    out.append(Text(left + SCALE_BAR_MM + 2.0, bar_y, f"{SCALE_BAR_MM:g} mm", 6.0))
    return out


# -- raster ------------------------------------------------------------------------------------

def _coverage(a: float, b: float, n: int) -> np.ndarray:
    """How much of each pixel [i, i+1) of ``n`` the interval [a, b) covers (0..1)."""
    i = np.arange(n, dtype=float)
    return np.clip(np.minimum(i + 1, b) - np.maximum(i, a), 0.0, 1.0)


def raster(layout: SheetLayout, px_per_mm: float, *, text: bool = True) -> np.ndarray:
    """The sheet as a grey image (H, W) uint8 at ``px_per_mm``; row 0 is the paper's top edge.

    Rectangles are drawn with their exact area coverage of each pixel, so an edge at x mm falls
    at x * px_per_mm pixels from the left edge of pixel 0.  Text (OpenCV's Hershey font) is
    approximate; ``text=False`` leaves it out.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    w_mm, h_mm = layout.size
    W, H = int(round(w_mm * px_per_mm)), int(round(h_mm * px_per_mm))
    ink = np.zeros((H, W), float)  # 0 white .. 1 black
    for s in shapes(layout):
        if isinstance(s, Rect):
            cx = _coverage(s.x * px_per_mm, (s.x + s.w) * px_per_mm, W)
            cy = _coverage((h_mm - s.y - s.h) * px_per_mm, (h_mm - s.y) * px_per_mm, H)
            c0, c1 = np.flatnonzero(cx)[[0, -1]]
            r0, r1 = np.flatnonzero(cy)[[0, -1]]
            # coverages add up: two rectangles that meet inside a pixel fill it, with no seam
            ink[r0:r1 + 1, c0:c1 + 1] += (1.0 - s.grey) * np.outer(cy[r0:r1 + 1], cx[c0:c1 + 1])
    img = np.round(255 * (1.0 - np.clip(ink, 0, 1))).astype(np.uint8)
    if text:
        for s in shapes(layout):
            if isinstance(s, Text):
                # Hershey simplex: a capital is about 22 units tall at scale 1 -> points to scale
                height_px = s.size / PT_PER_MM * 0.72 * px_per_mm
                scale = height_px / 22.0
                org = (int(round(s.x * px_per_mm)), int(round((h_mm - s.y) * px_per_mm)))
                cv2.putText(img, s.text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, 0,
                            max(1, int(round(scale * 1.5))), cv2.LINE_AA)
    return img


def png_bytes(layout: SheetLayout, dpi: float) -> bytes:
    """The sheet as a PNG at ``dpi`` dots per inch, with its resolution in a ``pHYs`` chunk
    (so a printer prints it at its real size)."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    img = raster(layout, dpi / 25.4)
    ok, buf = cv2.imencode(".png", img)
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
        raise InputError("cannot encode the sheet as PNG")
    data = buf.tobytes()
    ppm = int(round(dpi / 0.0254))
    body = b"pHYs" + ppm.to_bytes(4, "big") * 2 + b"\x01"
    chunk = (9).to_bytes(4, "big") + body + zlib.crc32(body).to_bytes(4, "big")
    end_ihdr = 8 + 8 + 13 + 4  # signature, IHDR length+type, its 13 bytes, its CRC
    return data[:end_ihdr] + chunk + data[end_ihdr:]


# -- PDF -----------------------------------------------------------------------------------------

def _pdf_text(text: str) -> str:
    """A PDF string literal body: Latin-1 only, backslash and parentheses escaped."""
    safe = text.encode("latin-1", "replace").decode("latin-1")
    return safe.replace("\\", "\\\\").replace("(", "\\(").replace(")", "\\)")


def pdf_bytes(layout: SheetLayout) -> bytes:
    """The sheet as a one-page vector PDF (PDF 1.4), page size the paper's, content compressed."""
    w_mm, h_mm = layout.size
    ops: list[str] = []
    grey = None
    for s in shapes(layout):
        if isinstance(s, Rect):
            # rectangles of one grey in a row are one path, filled once: no seams where they meet
            if grey != s.grey:
                ops.append(("f " if grey is not None else "") + f"{s.grey:.3f} g")
                grey = s.grey
            ops.append(f"{s.x * PT_PER_MM:.3f} {s.y * PT_PER_MM:.3f} {s.w * PT_PER_MM:.3f} {s.h * PT_PER_MM:.3f} re")
        else:
            if grey is not None:
                ops.append("f")
                grey = None
            ops.append(f"0 g BT /F1 {s.size:g} Tf {s.x * PT_PER_MM:.3f} {s.y * PT_PER_MM:.3f} Td "
                       f"({_pdf_text(s.text)}) Tj ET")
    if grey is not None:
        ops.append("f")
    content = zlib.compress("\n".join(ops).encode("latin-1"))
    objects = [
        b"<< /Type /Catalog /Pages 2 0 R >>",
        b"<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
        (f"<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {w_mm * PT_PER_MM:.3f} {h_mm * PT_PER_MM:.3f}] "
         f"/Resources << /Font << /F1 5 0 R >> >> /Contents 4 0 R >>").encode(),
        f"<< /Length {len(content)} /Filter /FlateDecode >>\nstream\n".encode() + content + b"\nendstream",
        b"<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica /Encoding /WinAnsiEncoding >>",
        f"<< /Title ({_pdf_text('hila pen sheet, ' + layout.name)}) /Producer (hila) >>".encode(),
    ]
    out = bytearray(b"%PDF-1.4\n%\xe2\xe3\xcf\xd3\n")
    offsets = []
    for number, body in enumerate(objects, start=1):
        offsets.append(len(out))
        out += f"{number} 0 obj\n".encode() + body + b"\nendobj\n"
    xref = len(out)
    out += f"xref\n0 {len(objects) + 1}\n0000000000 65535 f \n".encode()
    out += b"".join(f"{o:010d} 00000 n \n".encode() for o in offsets)
    out += (f"trailer\n<< /Size {len(objects) + 1} /Root 1 0 R /Info {len(objects)} 0 R >>\n"
            f"startxref\n{xref}\n%%EOF\n").encode()
    return bytes(out)
