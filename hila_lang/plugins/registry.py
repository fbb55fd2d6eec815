"""Worlds, back ends and robots found through entry points, declared without being built.

A plug-in is a :class:`WorldInfo`, :class:`BackendInfo` or :class:`RobotInfo` object named by an
entry point in the group ``hila.worlds``, ``hila.backends`` or ``hila.robots`` (hila's own are in its ``pyproject.toml``; a
third-party package adds its own the same way, without editing hila).  The declaration says,
without building anything or starting a simulator: the plug-in's one-line doc, its settings
(:class:`~hila_lang.plugins.settings.Setting`), for a world the questions (``ask``) and events
(``wait``) it answers, each with a one-line doc, and its default back end.  ``factory`` names the
callable that builds it (``"module:callable"``), imported only when a run needs it, so listing
plug-ins (``--backend`` choices, ``check``) stays light.

Names come from the entry points alone (:func:`names`); declarations are loaded on demand
(:func:`world`, :func:`backend`).  :func:`refresh` forgets what was found (tests that install a
throwaway distribution call it).
"""

from __future__ import annotations

import difflib
import functools
import importlib
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Any, Mapping

from ..core.errors import InputError
from .names import Names
from .protocols import Backend, conformance, World
from .settings import parse_settings, Setting
from .studio import StudioView

GROUPS = {"world": "hila.worlds", "back end": "hila.backends", "robot": "hila.robots"}
#: the world of a program without ``world NAME``
DEFAULT_WORLD = "scripted"


def _import(target: str):
    """``"module:attr"`` -> the object; a module that is not installed is an InputError."""
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise InputError(f"{target} is not available in this installation: it needs the module "
                         f"{exc.name!r}") from None
    return getattr(module, attr)


def _check_conforms(obj: Any, protocol: type, what: str) -> None:
    problems = conformance(obj, protocol)
    if problems:  # a plug-in bug, not a user error: it propagates as an internal error
        raise TypeError(f"{what} ({type(obj).__module__}.{type(obj).__qualname__}) does not implement "
                        f"{protocol.__name__}: " + "; ".join(problems))


@dataclass(frozen=True)
class Declared:
    """What a world answers, known before it is built: what ``hila check`` checks a program by.

    Attributes
    ----------
    questions, events : mapping name -> one-line doc
        Every name ``ask`` and ``wait`` may use.
    points : frozenset of str, or None
        Every scene point the world names, when it is known before the run (a script's);
        None when the world makes them as it goes (a board it reads with its eyes).
    drawing_surface : bool
        The world's scene has a drawing surface (paper): a 2-D template runs on it.
    source : str
        Who answers, for messages ("the tictactoe world", "the scripted world (s.yaml)").
    advice : str or None
        What to do when a name is missing and the world has none of its kind.
    question_dims, event_dims : mapping name -> 2 or 3
        The answers that are always points of one size (a script's); others are not known.
    arities : mapping (kind, name) -> int
        How many arguments a question (kind ``"question"``) or event takes, where the world's
        table declares it.
    """

    questions: Mapping[str, str]
    events: Mapping[str, str]
    points: frozenset | None = None
    drawing_surface: bool = False
    source: str = ""
    advice: str | None = None
    question_dims: Mapping[str, int] = field(default_factory=dict)
    event_dims: Mapping[str, int] = field(default_factory=dict)
    arities: Mapping[tuple[str, str], int] = field(default_factory=dict)


@dataclass(frozen=True)
class WorldInfo:
    """A world plug-in's declaration.

    Attributes
    ----------
    name : str
        As written in ``world NAME``.
    factory : str
        ``"module:callable"``; ``callable(options: RunOptions, settings: dict) -> World``.
    doc : str
        One line.
    settings : tuple of Setting
    questions, events : Names (or a mapping name -> one-line doc, made into one)
        What ``ask NAME`` and ``wait NAME`` may name: arguments, doc and the world's method that
        answers (:mod:`hila_lang.plugins.names`); the world, ``hila check``, ``hila show world``
        and the language server all read this one table.
    points : Names
        The scene points the world names, as patterns (``board.cellN.tl|tr|br|bl``) with docs.
    default_backend : str
        The back end when ``--backend`` is not given.
    dynamic_names : bool
        The world's questions and events are known only when it runs, so ``questions`` and
        ``events`` are not the whole list (unless ``declare`` knows them from the settings).
    drawing_surface : bool
        Its scene has a drawing surface (paper) that 2-D templates run on.
    declare : str or None
        ``"module:callable"``; ``callable(settings: dict) -> Declared``, for a world whose names
        follow from its settings (the scripted world's script); None: the fields above say it all.
    recorder : str or None
        ``"module:callable"``: records the world's seeded demonstration in simulation through the
        robot's eyes and learns it (``hila learn --from-sim --world NAME``);
        ``callable(seed, *, k, tags, contact, name, method, recording_dir) -> Template``.
    icp_reader : str or None
        ``"module:callable"``: reads a demonstration scene's ICPs from recorded frames
        (``hila learn --frames/--left/--right --world NAME``), the ``read_icps`` of
        :func:`hila_lang.perception.learn.template_from_frames`.
    mark_check : str or None
        ``"module:callable"``: ``callable(ref, template) -> str | None`` says why the world cannot
        play a pen-down (sub-)template ``ref`` (``"tri.draw"``) a program draws with, or None;
        ``hila check`` reports it at the run statement (e.g. tic-tac-toe: a mark too like the
        opponent's cross to be told apart).
    studio : StudioView or None
        What the world shows in ``hila studio`` (:mod:`hila_lang.plugins.studio`): a scene to
        demonstrate on, its board during a run, the settings the Run page offers; None: nothing.
    tracking : bool
        The world shows the robot its points again while a step runs (its worlds have a
        ``tracking`` capability, :class:`hila_lang.plugins.protocols.Tracking`): ``hila check``
        refuses a ``track`` clause in a world that does not declare it.
    """

    name: str
    factory: str
    doc: str
    settings: tuple[Setting, ...] = ()
    questions: Mapping[str, str] = field(default_factory=dict)
    events: Mapping[str, str] = field(default_factory=dict)
    default_backend: str = "dry"
    dynamic_names: bool = False
    drawing_surface: bool = False
    declare: str | None = None
    points: Mapping[str, str] = field(default_factory=dict)
    recorder: str | None = None
    icp_reader: str | None = None
    mark_check: str | None = None
    studio: StudioView | None = None
    tracking: bool = False

    def __post_init__(self) -> None:
        for kind, attr in (("question", "questions"), ("event", "events"), ("point", "points")):
            object.__setattr__(self, attr, Names.of(kind, getattr(self, attr)))

    def parse(self, given: dict[str, str]) -> dict[str, Any]:
        return parse_settings(self.settings, given, f"world {self.name}")

    def declared(self, settings: dict[str, Any] | None = None) -> Declared | None:
        """What the world answers with these (parsed) settings, or None when only the running
        world knows (``dynamic_names`` without ``declare``, or no settings to ask with)."""
        if self.declare is not None:
            return None if settings is None else _import(self.declare)(settings)
        if self.dynamic_names:
            return None
        return Declared(dict(self.questions), dict(self.events), None, self.drawing_surface,
                        f"the {self.name} world",
                        arities={**self.questions.arities(), **self.events.arities()})

    def check_mark(self, ref: str, template) -> str | None:
        """Why this world cannot play the pen-down (sub-)template ``ref`` (its ``mark_check``), or None."""
        return None if self.mark_check is None else _import(self.mark_check)(ref, template)

    def capability(self, attr: str, what: str, flag: str):
        """The callable the world declares as ``attr`` (``recorder``, ``icp_reader``); an
        InputError naming the worlds that have one when this world has none."""
        target = getattr(self, attr)
        if target is None:
            having = [n for n in names("world") if getattr(world(n), attr) is not None]
            raise InputError(f"world '{self.name}' has no {what}, so {flag} cannot learn in it",
                             hint=f"worlds that have one: {', '.join(having)}" if having else None)
        return _import(target)

    def build(self, options, settings: dict[str, Any]):
        """The world for a run (``settings`` as :meth:`parse` returns them), checked to be a World."""
        world = _import(self.factory)(options, settings)
        _check_conforms(world, World, f"world {self.name!r}")
        return world


@dataclass(frozen=True)
class BackendInfo:
    """A back-end plug-in's declaration.

    Attributes
    ----------
    name : str
        As given to ``--backend``.
    factory : str
        ``"module:callable"``; ``callable(scene: Scene | None, options: RunOptions, settings: dict) -> Backend``.
    doc : str
        One line.
    settings : tuple of Setting
    reach : ((x, y, z), radius) or None
        A ball (world frame, metres) that holds every point the back end's hand can reach, when
        it moves a robot's arm: ``hila check`` refuses a target bound outside it, at the
        statement that binds it (:mod:`hila_lang.language.worldcheck`).  None: no such bound.
        The iCub's; a run that names its robot (``--robot``) is checked against that robot's
        reach instead (:meth:`hila_lang.robot.spec.RobotSpec.reach`).
    streaming : bool
        Its back ends can change the path they follow while the arm moves (a ``streaming``
        capability, :class:`hila_lang.plugins.protocols.Streaming`): ``hila check`` refuses a
        ``track`` clause on a back end that does not declare it.
    """

    name: str
    factory: str
    doc: str
    settings: tuple[Setting, ...] = ()
    reach: tuple | None = None
    streaming: bool = False

    def parse(self, given: dict[str, str]) -> dict[str, Any]:
        return parse_settings(self.settings, given, f"back end {self.name}")

    def build(self, scene, options, settings: dict[str, Any]):
        """The back end for a run, checked to be a Backend (capabilities included)."""
        backend = _import(self.factory)(scene, options, settings)
        try:
            _check_conforms(backend, Backend, f"back end {self.name!r}")
        except TypeError:
            backend.close()
            raise
        return backend


@dataclass(frozen=True)
class RobotInfo:
    """A robot plug-in's declaration (``--robot NAME``).

    Attributes
    ----------
    name : str
        As given to ``--robot``.
    factory : str
        ``"module:callable"``; ``callable() -> RobotSpec`` (:mod:`hila_lang.robot.spec`).
    doc : str
        One line.
    """

    name: str
    factory: str
    doc: str

    def spec(self):
        """The robot's :class:`~hila_lang.robot.spec.RobotSpec`."""
        return _import(self.factory)()


@functools.lru_cache(maxsize=None)
def _entry_points(group: str) -> dict:
    found: dict = {}
    for ep in entry_points(group=group):
        found.setdefault(ep.name, ep)
    return found


def names(kind: str) -> list[str]:
    """Registered names of ``kind`` ("world" or "back end"), sorted; nothing is imported."""
    return sorted(_entry_points(GROUPS[kind]))


@functools.lru_cache(maxsize=None)
def _info(kind: str, name: str):
    eps = _entry_points(GROUPS[kind])
    if name not in eps:
        close = difflib.get_close_matches(name, list(eps), n=1)
        raise InputError(f"unknown {kind} {name!r}; known: {', '.join(sorted(eps)) or 'none'}",
                         hint=f"did you mean {close[0]!r}?" if close else None)
    ep = eps[name]
    try:
        info = ep.load()
    except ModuleNotFoundError as exc:
        raise InputError(f"{kind} {name!r} is not available in this installation "
                         f"({ep.value} needs the module {exc.name!r})") from None
    wanted = {"world": WorldInfo, "back end": BackendInfo, "robot": RobotInfo}[kind]
    if not isinstance(info, wanted) or info.name != name:
        raise TypeError(f"entry point {GROUPS[kind]}:{name} = {ep.value} is not a {wanted.__name__} named {name!r}")
    return info


def world(name: str) -> WorldInfo:
    """The declaration of world ``name`` (InputError with "did you mean" when unknown)."""
    return _info("world", name)


def backend(name: str) -> BackendInfo:
    """The declaration of back end ``name`` (InputError with "did you mean" when unknown)."""
    return _info("back end", name)


def robot(name: str) -> RobotInfo:
    """The declaration of robot ``name`` (InputError with "did you mean" when unknown)."""
    return _info("robot", name)


def declarations(kind: str) -> list:
    """Every declaration of ``kind`` that loads (for help texts); broken plug-ins are skipped."""
    out = []
    for name in names(kind):
        try:
            out.append(_info(kind, name))
        except Exception:  # noqa: BLE001 - a broken third-party plug-in must not break --help
            continue
    return out


def refresh() -> None:
    """Forget the entry points and declarations found so far."""
    _entry_points.cache_clear()
    _info.cache_clear()
