"""The studio's door: what every request body, query and websocket message may hold, checked
before a handler runs (a 400 with the reason, never a handler that meets a bad value).

A schema is built from a few declarative pieces -- :class:`Num`, :class:`Int`, :class:`Str`,
:class:`Bool`, :class:`List`, :class:`Map`, :class:`Obj`, :class:`Either` -- and
:func:`check` returns the value or raises :class:`InputError` naming the field
(``icps.a[1]: expected a finite number from -1e+06 to 1e+06, got 1e+308``).  :func:`parse_json`
refuses a document nested beyond the parser's limit (a 100 000-deep array is a 400, not a
``RecursionError`` in the server).

The limits are stated once, here, from the command line's where it has them
(:mod:`hila_lang.core.argtypes`: seeds; :data:`hila_lang.osila.template.MAX_COORDINATE`: the
±1e6 of every coordinate); the rest are sized by what a person does on a page (see
docs/limits.md: a demonstration of 10 minutes at 20 Hz, 100 via points, ...).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Callable

from ..core.argtypes import SEED_MAX
from ..core.errors import InputError
from ..osila.segmentation import METHODS
from ..osila.template import MAX_COORDINATE

#: deepest nesting of arrays and objects in a request (a scene is 4 deep: {avoid: [{centre: [x]}]});
#: the shapes enforce it, as each expects a number where a deeper document has a list
MAX_DEPTH = 4
#: pointer samples in one demonstration: 10 minutes of a 60 Hz pointer
MAX_SAMPLES = 36_000
#: points of a path (a demonstration at 20 Hz): 10 minutes
MAX_POINTS = 12_000
#: longest demonstration, seconds, from the samples' time stamps (what MAX_POINTS holds at 20 Hz)
MAX_SECONDS = 600.0
#: ICPs of a scene, via points, avoided discs: far more than a person places by hand
MAX_ICPS = 100
MAX_VIA = 100
MAX_AVOID = 100
#: segments of a template (-k) and tags
MAX_SEGMENTS = 100
#: characters of a name, tag, path, setting or command argument
MAX_NAME = 255
#: characters of a program's text sent to be checked (1 MB: a program is a few kB)
MAX_TEXT = 1_000_000
#: steps asked of a run in one message, and a recording scrubbed to
MAX_STEPS = 1_000_000
#: bytes of one JSON body or socket message.  The largest the limits above let through is a
#: program of MAX_TEXT non-ASCII characters sent to be checked (each escaped as \\uXXXX: 6.0 MB);
#: a demonstration of MAX_SAMPLES samples is 4.2 MB (parsed in 0.17 s and checked in 0.17 s at
#: load 7).  A bigger body is refused before it is parsed; a body under it is parsed and checked
#: in a thread (:func:`.page.read_json`), so other requests are answered meanwhile
MAX_JSON = 8 * 1024 * 1024


class Shape:
    what = "a value"

    def check(self, value: Any, where: str) -> Any:
        raise NotImplementedError


def _got(value: Any) -> str:
    text = json.dumps(value) if not isinstance(value, float) else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _fail(shape: Shape, value: Any, where: str) -> InputError:
    return InputError(f"{where}: expected {shape.what}, got {_got(value)}")


@dataclass
class Num(Shape):
    """A finite number in [low, high] (default: a coordinate, ±MAX_COORDINATE)."""

    low: float = -MAX_COORDINATE
    high: float = MAX_COORDINATE
    above: bool = False  # low itself is not allowed

    @property
    def what(self) -> str:
        return f"a finite number {'above' if self.above else 'from'} {self.low:g}" + f" {'and at most' if self.above else 'to'} {self.high:g}"

    def check(self, value, where):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _fail(self, value, where)
        v = float(value) if abs(value) < 1e300 else math.inf  # an int of 400 digits is no coordinate
        if not math.isfinite(v) or v < self.low or v > self.high or (self.above and v <= self.low):
            raise _fail(self, value, where)
        return v


@dataclass
class Int(Shape):
    """A whole number in [low, high] (a JSON number without a fraction)."""

    low: int = 0
    high: int = SEED_MAX

    @property
    def what(self) -> str:
        return f"a whole number from {self.low} to {self.high}"

    def check(self, value, where):
        if isinstance(value, float) and math.isfinite(value) and value.is_integer() and abs(value) < 2**53:
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int) or not self.low <= value <= self.high:
            raise _fail(self, value, where)
        return value


@dataclass
class Str(Shape):
    """Text of at most ``most`` characters; one of ``choices`` when given; passing ``test``
    (``test_says`` what it wants) when given."""

    most: int = MAX_NAME
    choices: tuple = ()
    test: Callable[[str], bool] | None = None
    test_says: str = ""

    @property
    def what(self) -> str:
        if self.choices:
            return "one of " + ", ".join(map(str, self.choices))
        return self.test_says or f"text of at most {self.most} characters"

    def check(self, value, where):
        if not isinstance(value, str) or len(value) > self.most or "\x00" in value:
            raise _fail(self, value, where)
        if (self.choices and value not in self.choices) or (self.test is not None and not self.test(value)):
            raise _fail(self, value, where)
        return value


@dataclass
class Bool(Shape):
    what = "true or false"

    def check(self, value, where):
        if not isinstance(value, bool):
            raise _fail(self, value, where)
        return value


@dataclass
class List(Shape):
    """A list of ``item``, with ``least`` to ``most`` entries."""

    item: Shape
    most: int
    least: int = 0

    @property
    def what(self) -> str:
        return f"a list of {self.least} to {self.most} items, each {self.item.what}"

    def check(self, value, where):
        if not isinstance(value, list):
            raise _fail(self, value, where)
        if not self.least <= len(value) <= self.most:
            raise InputError(f"{where}: expected {self.least} to {self.most} items, got {len(value)}")
        return [self.item.check(v, f"{where}[{i}]") for i, v in enumerate(value)]


@dataclass
class Map(Shape):
    """An object of at most ``most`` names (``key`` checks them), each ``value``."""

    value: Shape
    most: int
    key: Str = field(default_factory=Str)

    @property
    def what(self) -> str:
        return f"an object of at most {self.most} names, each {self.value.what}"

    def check(self, value, where):
        if not isinstance(value, dict) or len(value) > self.most:
            raise _fail(self, value, where)
        return {self.key.check(k, f"{where} name"): self.value.check(v, f"{where}.{k}") for k, v in value.items()}


@dataclass
class Obj(Shape):
    """An object with these ``fields`` (name -> shape); ``required`` ones must be there.  A field
    that is absent or null is left out (the handler's default holds); an unknown one is dropped."""

    fields: dict
    required: tuple = ()

    what = "a JSON object"

    def check(self, value, where):
        if not isinstance(value, dict):
            raise _fail(self, value, where)
        out = {}
        for name, shape in self.fields.items():
            v = value.get(name)
            if v is None:
                if name in self.required:
                    raise InputError(f"{where}: {name} is missing")
                continue
            out[name] = shape.check(v, f"{where}.{name}" if where else name)
        return out


@dataclass
class Either(Shape):
    """The first of ``shapes`` the value fits."""

    shapes: tuple

    @property
    def what(self) -> str:
        return " or ".join(s.what for s in self.shapes)

    def check(self, value, where):
        for shape in self.shapes:
            try:
                return shape.check(value, where)
            except InputError:
                continue
        raise _fail(self, value, where)


def Point() -> List:  # noqa: N802 - a shape, named like the others
    """A point: 2 or 3 coordinates."""
    return List(Num(), most=3, least=2)


def check(shape: Shape, value: Any, where: str = "") -> Any:
    """``value`` checked against ``shape`` (see the module's pieces); an :class:`InputError`
    names the field and what it expected."""
    return shape.check(value, where)


def parse_json(text: str | bytes) -> dict:
    """A JSON object from a request or a message.  Nesting is bounded twice: the parser refuses
    a document deeper than Python's recursion limit (about 1000 levels: a ``RecursionError``,
    answered here as a refusal), and every shape below refuses a list or an object where it
    expects a number, so nothing deeper than a request's shape reaches a handler."""
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"expected a JSON body: {exc}") from None
    except RecursionError:
        raise InputError("refused: the JSON is nested deeper than the studio reads (its requests are at "
                         f"most {MAX_DEPTH} levels deep)") from None
    if not isinstance(doc, dict):
        raise InputError("expected a JSON object")
    return doc


def query(request_or_socket, shape: Obj) -> dict:
    """A request's query parameters checked by ``shape`` (each a text; ``Int`` and ``Bool``
    fields are read from their text: ``1``/``0``/``true``/``false`` for a flag)."""
    params = request_or_socket.query_params
    doc: dict = {}
    for name, sub in shape.fields.items():
        raw = params.get(name)
        if raw is None:
            continue
        if isinstance(sub, Bool):
            if raw.lower() not in ("1", "0", "true", "false", ""):
                raise InputError(f"{name}: expected 1 or 0, got {_got(raw)}")
            doc[name] = raw.lower() in ("1", "true")
        elif isinstance(sub, Int):
            if not raw.lstrip("-").isdigit() or len(raw) > 41:
                raise InputError(f"{name}: expected {sub.what}, got {_got(raw)}")
            doc[name] = int(raw)
        else:
            doc[name] = raw
    return check(shape, doc)


# ----------------------------------------------------------------------------- the requests

def _tag(text: str) -> bool:
    # lazy: loads lark, which importing this module does not
    from ..language.transformer import usable_as_tag

    return len(text) <= 64 and usable_as_tag(text)


def _methods() -> tuple:
    return METHODS


class _Methods(Str):
    """A segmentation method (:data:`hila_lang.osila.segmentation.METHODS`, read when checked)."""

    def check(self, value, where):
        self.choices = _methods()
        return super().check(value, where)


NAME = Str(test=lambda s: bool(s.strip()), test_says="a file name relative to the studio's folder")
TAG = Str(most=64, test=_tag, test_says="a tag a program can write (a letter or '_', then letters, digits or '_')")
SEED = Int(0, SEED_MAX)
TIME = Num(0.0, 1e6)  # seconds from the start
STAMP = Num(-1e15, 1e15)  # a pointer event's time stamp, milliseconds (performance.now() or the epoch)
PATH = List(Point(), most=MAX_POINTS, least=2)
ICPS = Map(Point(), most=MAX_ICPS)
SCENE = dict(template=NAME, icps=ICPS, via=List(Point(), most=MAX_VIA),
             avoid=List(Obj(dict(centre=Point(), radius=Num(0.0, above=True)), required=("centre", "radius")),
                        most=MAX_AVOID),
             names=Map(Str(), most=MAX_ICPS), controls=Bool(), seq=Either((Int(-2**53, 2**53), Str())))

#: POST /api/save: a demonstration saved as a template
SAVE = Obj(dict(name=Str(most=64), path=PATH, times=List(TIME, most=MAX_POINTS), icps=ICPS,
                tags=List(TAG, most=MAX_SEGMENTS), contact=List(TAG, most=MAX_SEGMENTS), method=_Methods(),
                seed=SEED, cuts=List(Int(0, MAX_POINTS), most=MAX_SEGMENTS), pen=List(Either((Bool(), Int(0, 1))), most=MAX_POINTS),
                overwrite=Bool()),
           required=("name", "path", "times", "icps"))
#: POST /api/picture-scene: a route drawn on an uploaded picture made a world's scene (issue 30)
PICTURE_SCENE = Obj(dict(template=NAME, image=NAME, world=Str(most=64), overwrite=Bool()),
                    required=("template", "image"))
#: POST /api/demonstration: pointer samples (or a path) -> the path and its proposed cuts
DEMONSTRATION = Obj(dict(
    samples=List(Obj(dict(x=Num(), y=Num(), t=STAMP, down=Bool(), p=Num(0.0, 1.0)), required=("x", "y", "t")),
                 most=MAX_SAMPLES),
    path=PATH, times=List(TIME, most=MAX_POINTS), pen=List(Either((Bool(), Int(0, 1))), most=MAX_POINTS), z=Num(), lift=Num(0.0, 1.0),
    k=Int(1, MAX_SEGMENTS), method=_Methods(), seed=SEED))
#: POST /api/imitate/export and /explain, and each /ws/imitate message
IMITATE = Obj(SCENE, required=("template",))
#: POST /api/check
CHECK = Obj(dict(path=NAME, text=Str(most=MAX_TEXT)))
#: GET/PUT /api/file, GET /api/raw, POST /api/upload: ?path=P(&overwrite=1)
FILE_QUERY = Obj(dict(path=NAME, overwrite=Bool()), required=("path",))
#: GET /api/open?kind=&name=, /api/scene?name=, /api/scene-image?name=, /api/template?path=
OPEN_QUERY = Obj(dict(kind=Str(choices=("template", "csv", "lasa")), name=NAME), required=("kind", "name"))
SCENE_QUERY = Obj(dict(name=NAME))
TEMPLATE_QUERY = Obj(dict(path=NAME), required=("path",))
#: each /ws/run message
RUN = Obj(dict(cmd=Str(choices=("start", "open", "step", "run", "back", "reload", "break", "clear", "stop",
                                "answer", "view", "scrub")),
               path=NAME, backend=Str(), robot=Str(), settings=Map(Either((Str(), Num(-1e15, 1e15), Bool())), most=100),
               seed=SEED, n=Int(0, MAX_STEPS), state=Str(), text=Str(most=10_000), azimuth=Num(-1e6, 1e6)),
          required=("cmd",))

#: each /ws/camera message (the Camera scene, :mod:`.camera`: its frame's size is bounded there)
CAMERA = Obj(dict(op=Str(choices=("start", "frame", "stop")), ball=Str(most=32),
                  ball_mm=Either((Num(0.0, 1000.0, above=True), Str(most=32))), t=Num(-1e9, 1e9),
                  jpeg=Str(most=30_000_000), record=Bool(), cell=Either((Int(0, 10**6), Str(most=32)))),
             required=("op",))

#: each route's body shape (:func:`.page.read_json` checks a body by its route's)
BODIES = {"/api/save": SAVE, "/api/picture-scene": PICTURE_SCENE, "/api/demonstration": DEMONSTRATION, "/api/imitate/export": IMITATE,
          "/api/imitate/explain": IMITATE, "/api/check": CHECK}
#: each websocket's message shape (:class:`.page.JSONSocket` checks every message)
SOCKETS = {"/ws/imitate": IMITATE, "/ws/run": RUN, "/ws/camera": CAMERA}
