"""A route drawn on a picture uploaded to the Demonstrate page made a world's scene (issue 30).

The route is saved as any drawing (a 2-D template in the picture's plane, x right and y up from
its bottom-left corner, :data:`.demonstrate.SHEET_M_PER_PX` metres a pixel).  ``POST
/api/picture-scene`` ``{template, image[, world][, overwrite]}`` (the route, the picture) hands
it to a world that takes a person's picture -- its :class:`~hila_lang.plugins.studio.StudioView` ``picture_hook`` (the
picture world's: the picture printed on the sheet the robot sees, the robot's eyes' features of
it as the ICPs, found again by scene matching when it runs) -- in a worker (it renders the
scene), on private copies of the two files; writes the world's template ``NAME_WORLD.yaml`` and
the program ``NAME_WORLD.hila`` that runs it beside the route (never over a file without
``overwrite``: 409); and answers the command that runs it (``hila exec ... --set
SETTING=PICTURE``, the folder's paths) and the setting the Run page starts it with (which it
offers with :func:`pictures`, :func:`hila_lang.studio.run.analyse`).  A route that does not fit
(3-D, leaving the picture) or a file that is no picture is a 400 naming the file.
"""

from __future__ import annotations

from pathlib import Path, PurePosixPath

from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route

from ..core.errors import InputError
from ..plugins import registry
from . import files, worker
from .page import read_json, studio_of
from .security import inside

#: what an uploaded picture may be
PICTURES = (".png", ".jpg", ".jpeg")


def pictures(folder: Path | None) -> list[str]:
    """The pictures in ``folder`` itself (where an upload goes), not in its subfolders (what runs
    wrote: a game's eye.png, ...): the subfolders are not walked (this runs at each check of a
    picture world's program), and a deep folder's 2000-file cap hides none of them."""
    return [] if folder is None else [f for f in files.listing(folder, depth=1) if f.lower().endswith(PICTURES)]


def picture_worlds() -> list[str]:
    """The worlds that take a person's picture as a scene (a picture hook in their studio view)."""
    return [info.name for info in registry.declarations("world") if info.studio is not None and info.studio.picture_hook]


def _picture_texts(world: str, route: tuple[str, bytes], picture: tuple[str, bytes], name: str) -> tuple[str, str]:
    """The world's template text and program for a route drawn on a picture, each given as
    ``(file name, bytes)``: the hook run on private copies (a worker: it renders the scene)."""
    # lazy: only this worker's call needs them
    import tempfile

    from ..core.errors import HilaError

    with tempfile.TemporaryDirectory(prefix="hila-picture-") as tmp:
        copies = []
        for file, data in (route, picture):
            copy = Path(tmp) / PurePosixPath(file).name
            copy.write_bytes(data)
            copies.append(copy)
        out = Path(tmp) / f"{name}.yaml"
        try:
            program = registry.world(world).studio.load("picture_hook")(copies[1], copies[0], out)
        except HilaError as exc:  # said of the studio's files (the page shows the message), not the copies
            names = {str(copies[0]): route[0], str(copies[1]): picture[0]}
            for copy, shown in names.items():
                exc.message = exc.message.replace(copy, shown)
            if exc.file is not None:
                exc.message, exc.file = f"{names.get(str(exc.file), exc.file)}: {exc.message}", None
            exc.args = (exc.message,)
            raise
        # the template's description names the studio's files, not the private copies
        return out.read_text(encoding="utf-8").replace(f"{tmp}/", ""), program


def picture_names(doc: dict) -> tuple[str, str, str, str]:
    """``(world, NAME_WORLD, NAME_WORLD.yaml, NAME_WORLD.hila)`` of a picture-scene request, checked."""
    # lazy: loads lark, which importing this module does not
    from ..language.transformer import usable_as_tag

    worlds = picture_worlds()
    world = doc.get("world") or (worlds[0] if worlds else "")
    if world not in worlds:
        raise InputError(f"world {world!r} takes no person's picture as a scene; "
                         f"{'these do: ' + ', '.join(worlds) if worlds else 'no installed world does'}")
    route, picture = str(doc["template"]), str(doc["image"])
    if not route.endswith((".yaml", ".csv")):
        raise InputError(f"{route}: expected the route as a template (NAME.yaml) or a demonstration CSV")
    if not picture.lower().endswith(PICTURES):
        raise InputError(f"{picture}: expected the picture as {', '.join(PICTURES)}")
    name = f"{PurePosixPath(route).name.split('.')[0]}_{world}"
    if not usable_as_tag(name):
        raise InputError(f"{route}: a program imports the scene's template by name, and {name!r} is not one "
                         "(a letter or '_', then letters, digits or '_'): save the route under such a name")
    folder = str(PurePosixPath(route).parent)
    prefix = "" if folder == "." else folder + "/"
    return world, name, f"{prefix}{name}.yaml", f"{prefix}{name}.hila"


async def _picture_scene(request: Request) -> Response:
    doc, folder = await read_json(request), studio_of(request).folder
    world, name, template, program = picture_names(doc)
    overwrite = bool(doc.get("overwrite"))
    files.refuse_existing(folder, (template, program), overwrite)  # 409 before the work
    route = await run_in_threadpool(files.read, folder, doc["template"], "route")
    picture = await run_in_threadpool(files.read, folder, doc["image"], "uploaded image")
    texts = await worker.run(_picture_texts, world, (doc["template"], route), (doc["image"], picture), name)
    await run_in_threadpool(lambda: files.write(folder, {template: texts[0], program: texts[1]}, overwrite=overwrite))
    return JSONResponse(picture_answer(folder, world, template, program, doc["image"]))


def picture_answer(folder: Path, world: str, template: str, program: str, picture: str) -> dict:
    """What the page says of a picture scene made: the files, the command that runs it (the
    folder's paths) and the setting that names the picture (the Run page starts it with it)."""
    setting = registry.world(world).studio.picture_setting
    root = folder.resolve()
    return dict(world=world, template=template, program=program, settings={setting: picture},
                command=f"hila exec {root / program} --set {setting}={root / picture}")


def offer_pictures(view, folder: Path | None, text: str) -> dict:
    """The settings a world's studio view offers on the Run page ({setting: {value: label}}), with,
    for a world that takes a person's picture (``view.picture_setting``), the pictures of
    ``folder``: the one the program ``text`` names (``SETTING=FILE``, as the studio writes its
    command in the program) first, the menu's default."""
    offered = {k: dict(v) for k, v in view.settings.items()}
    if view.picture_setting:
        found = pictures(folder)
        named = [f for f in found if f"{view.picture_setting}={f}" in text][:1]
        offered[view.picture_setting] = {f: f"picture {f}" for f in named + [f for f in found if f not in named]}
    return offered


def picture_file(folder: Path, settings: dict, setting: str | None) -> None:
    """A run's ``settings`` with the picture ``setting`` names (a file of the page's menu) as its
    path inside ``folder``: the studio prints no file from elsewhere (:func:`.security.inside`)."""
    if setting and settings.get(setting):
        settings[setting] = str(inside(folder, settings[setting]))


ROUTES = [Route("/api/picture-scene", _picture_scene, methods=["POST"])]
