"""``hila studio [FOLDER]``: the local browser app (:mod:`hila_lang.studio`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..core.errors import InputError

HELP = "a local browser app: draw a demonstration, see OSILA's warp live, run and watch a program"
DESCRIPTION = """\
Serve a local web app over the templates (*.yaml) and programs (*.hila) in FOLDER (default: the
current folder): draw a demonstration and save it as a template (the file 'hila learn' writes),
drag a task scene's ICPs and watch OSILA's path follow, edit and run a program on the dry or the
PyBullet back end with the state machine lit as it runs, open a recording (.hilarec) and scrub it.

The first line printed is 'hila studio: http://127.0.0.1:PORT/?token=TOKEN'; open it in a browser.
The studio serves 127.0.0.1 only, refuses a request without this start's token or from another
host or page, and reads and writes only inside FOLDER.  Needs the 'studio' extra:
pip install 'hila-lang[studio]'.  Ctrl-C stops it (exit 130)."""


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"expected a port 0..65535 (0: a free one), got {text!r}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("folder", nargs="?", default=".", metavar="FOLDER",
                        help="the folder of templates and programs to serve (default: the current folder)")
    parser.add_argument("--port", type=_port, default=0, help="port on 127.0.0.1 (default 0: a free one)")
    parser.add_argument("--open", action="store_true", help="open the page in a browser")


def run(args: argparse.Namespace) -> int:
    folder = Path(args.folder)
    if not folder.is_dir():
        raise InputError(f"expected FOLDER to be a folder, got {args.folder!r}"
                         + (" (it does not exist)" if not folder.exists() else ""))
    try:
        # lazy: loads starlette and uvicorn (the 'studio' extra), which importing this module does not
        import starlette  # noqa: F401
        import uvicorn  # noqa: F401
    except ImportError:
        raise InputError("hila studio needs Starlette and uvicorn",
                         hint="pip install 'hila-lang[studio]'") from None
    # lazy: loads starlette, numpy, which importing this module does not
    from ..studio.app import serve

    return serve(folder, args.port, open_browser=args.open)
