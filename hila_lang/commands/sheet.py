"""``hila sheet``: the printable pen sheet (ArUco markers at the corners) as PDF or PNG.

See :mod:`hila_lang.perception.sheet` for the layout and docs/camera.md for the whole recipe.
"""

from __future__ import annotations

from pathlib import Path

from ..core.argtypes import number, output_path
from ..core.errors import InputError
from ..core.fileio import atomic_write_bytes

HELP = "write the printable sheet (ArUco markers at the corners) for demonstrating with a pen before a camera"
DESCRIPTION = """\
Write the sheet to print for a camera demonstration (docs/camera.md): A4 or Letter, portrait,
four ArUco markers (OpenCV's DICT_4X4_50, 30 mm, 12 mm from the edges) at the corners, which
give the map from the camera's image to the paper in millimetres; with --grid also a 3x3 grid
of 60 mm cells whose corners are ICPs a demonstration can use (hila learn --sheet --cell N).
The markers' ids tell which sheet it is, so hila learn needs no option to know the paper.
The sheet says its dictionary, ids and sizes, and carries a 100 mm bar: print at 100 %
("actual size", not "fit to page") and check the bar with a ruler.

  --out FILE.pdf   a vector PDF (exact edges at any printer resolution)
  --out FILE.png   a picture at --dpi (default 300), its resolution stored in the file

Example: hila sheet --out sheet.pdf --paper letter --grid"""


def add_arguments(parser) -> None:
    parser.add_argument("--out", required=True, type=output_path, metavar="FILE.pdf|FILE.png",
                        help="the file to write (.pdf or .png)")
    parser.add_argument("--paper", choices=("a4", "letter"), default="a4", help="paper size (default a4)")
    parser.add_argument("--grid", action="store_true", help="also print a 3x3 grid of 60 mm cells")
    parser.add_argument("--dpi", type=number(72, 1200, " dots per inch"), default=300.0,
                        help="resolution of a PNG, dots per inch (default 300)")


def run(args) -> int:
    # lazy: loads numpy, which importing this module does not
    from ..perception.sheet import SheetLayout, pdf_bytes, png_bytes

    suffix = Path(args.out).suffix.lower()
    if suffix not in (".pdf", ".png"):
        raise InputError(f"--out {args.out}: expected a .pdf or .png file name, got {suffix or 'no suffix'!r}")
    layout = SheetLayout(args.paper, args.grid)
    data = pdf_bytes(layout) if suffix == ".pdf" else png_bytes(layout, args.dpi)
    out = atomic_write_bytes(args.out, data)
    w, h = layout.size
    what = "vector PDF" if suffix == ".pdf" else f"PNG at {args.dpi:g} dpi"
    print(f"sheet {layout.name} ({w:g} x {h:g} mm, markers {', '.join(map(str, layout.ids))}) -> {out} ({what})")
    print("print it at 100 % and check the 100 mm bar with a ruler")
    return 0
