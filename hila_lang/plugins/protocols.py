"""What a world and a back end are: :class:`World`, :class:`Backend` and the back-end capabilities.

The interpreter knows nothing about PyBullet or tic-tac-toe.  A *back end* moves the hand; a
*world* names scene points, answers questions and reports events.  Both are
``typing.Protocol`` s: a plug-in implements every member (a hook it does not need is a one-line
no-op), and ``tests/test_plugins.py`` checks every registered plug-in against them, member by
member and signature by signature.

What only some back ends have is a *capability*: an attribute of the back end holding an object
that implements a small protocol, or None.  ``backend.eyes`` (:class:`Eyes`: the robot's
cameras), ``backend.ink`` (:class:`Ink`: a drawing surface that keeps the ink and can be moved),
``backend.overview`` (:class:`Overview`: a camera outside the robot, for reports and never for
decisions), ``backend.lighting`` (:class:`Lighting`: the simulated scene's light, which a
world may change) and ``backend.streaming`` (:class:`Streaming`: following a path whose tail
changes while the arm moves, for the ``track`` clause).  A world asks ``if backend.eyes is not
None`` -- it never probes for methods.  A world's ``tracking`` (:class:`Tracking`: it shows the
robot its points again while a step runs, and its scene may move meanwhile) is optional: a world
without the attribute cannot be tracked (``hila check`` reads ``WorldInfo.tracking``).
``backend.view`` (:class:`View`) is a window a person watches (``--gui``).
Worlds and back ends both declare ``snapshots`` (:class:`Snapshots`: save what they are now and
restore it later, for the REPL's ``back``; :class:`hila_lang.plugins.snapshots.AttributeSnapshots`
does it for state held in a few attributes), or None when they cannot go back.

Lifecycle of a run (:mod:`hila_lang.session.runner`)::

    world = WorldInfo.build(options, settings)        # the world (and its scene) exists
    backend = BackendInfo.build(world.scene, options, settings)
    world.attach(backend)                             # e.g. park the arm, keep the back end
    world.notify("program", marks={...})              # what the program draws with (if it draws)
    ... interpreter: world.points/query/wait/notify, backend.hand_position/reset_hand/move ...
    world.finish(trace, fsm=fsm)                      # results, output files
    backend.close()

Units and frames: every point is a numpy array of shape (3,), metres, world frame (z up);
paths are arrays of shape (T, 3).
"""

from __future__ import annotations

import inspect
from typing import Any, Mapping, NamedTuple, Protocol, runtime_checkable, Sequence, TYPE_CHECKING

if TYPE_CHECKING:  # numpy and the scene types only for annotations: importing this stays light
    import numpy as np

    from ..sim.camera import CameraImage
    from ..sim.surface import Scene, Surface


@runtime_checkable
class Eyes(Protocol):
    """The robot's eye cameras.  An image carries what the robot may know about it: the
    camera's intrinsics and lens distortion as the robot calibrated them (``K``, ``dist``), its
    pose and the joint angles it was taken at (``CameraImage.joints``), so a caller can
    recompute the pose from the kinematic chain (:meth:`chain`)."""

    #: standard deviation of the sensor noise in every image, grey levels (0: none)
    noise: float

    def look_at(self, point: "np.ndarray") -> float:
        """Aim the eyes at ``point`` (3,); returns the angle (radians) the joint limits leave."""
        ...

    def camera_pose(self, eye: str = "left") -> "np.ndarray":
        """``world_T_camera`` (4, 4) of ``eye`` now (OpenCV camera frame)."""
        ...

    def camera_image(self, eye: str = "left") -> "CameraImage":
        """An image (240, 320, 3) of ``eye`` with its intrinsics, pose and joint angles."""
        ...

    def chain(self, eye: str = "left") -> Any:
        """The kinematic chain from the world to ``eye`` (:class:`hila_lang.robot.ik.KinematicChain`)."""
        ...

    def body_outline(self) -> Any:
        """The robot's own body parts that may come into view, as it knows them: a list of
        capsules ``(points (2, 3), radius)``, world frame, metres (an image reader treats what
        they cover as hidden)."""
        ...

    def stereo(self) -> Any:
        """The robot's calibration of the eye pair: an object with ``right_T_left`` (4, 4), the
        left camera's coordinates to the right one's (e.g.
        :class:`hila_lang.perception.calibration.StereoCalibration`)."""
        ...


@runtime_checkable
class Ink(Protocol):
    """A drawing surface that keeps what is drawn on it (the paper)."""

    surface: "Surface"

    def ink_polyline(self, points: "np.ndarray", color: Any = "opponent") -> None:
        """Draw a stroke through ``points`` (N, 3) on the surface without the robot."""
        ...

    def ink_image(self) -> "np.ndarray":
        """The surface's texture (H, W, 3) uint8 RGB, row 0 its far edge."""
        ...

    def move_to(self, surface: "Surface") -> None:
        """Put the surface, ink and all, at ``surface``'s pose (same size, same height)."""
        ...


@runtime_checkable
class Lighting(Protocol):
    """The light of a simulated scene (a world's perturbation, e.g. a lighting change)."""

    def set_light(self, level: float, direction: Any = None) -> None:
        """Light at ``level`` times the built one, from ``direction`` (3,) (None: unchanged)."""
        ...


class StreamProgress(NamedTuple):
    """Where a stream (:class:`Streaming`) is: ``t`` seconds since it began, ``index`` the first
    waypoint of its path not yet passed (``len(path)`` at the end), ``done`` when the path's end is
    reached (the arm may still settle in :meth:`Streaming.finish`)."""

    t: float
    index: int
    done: bool


@runtime_checkable
class Streaming(Protocol):
    """Following a path that may change while the arm moves along it (the ``track`` clause).

    One stream at a time: :meth:`begin` a path, :meth:`advance` the clock (the arm moves),
    :meth:`replace` the path's tail from a waypoint not yet passed, and :meth:`finish` it (or
    :meth:`stop` it where it is, after an error).  The clock is the back end's: whole control
    steps of ``dt`` seconds, the same for every run of the same command.
    """

    #: seconds per control step
    dt: float

    def begin(self, path: "np.ndarray", *, pen_down: bool = False, label: str = "") -> float:
        """Start following ``path`` (T, 3) from where the pen is; returns the planned duration,
        seconds.  Checks the path as :meth:`Backend.move` does (UnreachableError: the arm does not
        move)."""
        ...

    def advance(self, seconds: float, each_step: Any = None) -> StreamProgress:
        """Move on for ``seconds`` (whole control steps; fewer when the path ends), calling
        ``each_step(t)`` after every control step with the seconds since :meth:`begin`."""
        ...

    def replace(self, index: int, tail: "np.ndarray") -> None:
        """From waypoint ``index`` on (not yet passed) the path is ``tail`` (N, 3): the arm goes on
        from where it is towards ``tail[0]``.  UnreachableError when the arm cannot follow it (it
        then holds where it is)."""
        ...

    def finish(self, each_step: Any = None) -> "np.ndarray":
        """Run to the end of the path and settle (``each_step`` as :meth:`advance`); the executed
        pen-tip trace (T', 3), recorded and inked as :meth:`Backend.move` does."""
        ...

    def stop(self) -> "np.ndarray":
        """Stop where the arm is (after an error); the executed trace so far, recorded and inked."""
        ...


@runtime_checkable
class Tracking(Protocol):
    """A world that shows the robot its points again while a step runs (the ``track`` clause),
    and whose scene may move meanwhile (the world is the scene's referee: it moves things in
    :meth:`elapse`, never the robot)."""

    #: the scene moves while the robot moves (e.g. ``board.slide``): every step on a streaming back
    #: end is then streamed, tracked or not, so that the world's clock runs
    moving: bool
    # A world may also say ``latency`` (float, seconds): how old what a look shows is, its senses'
    # known delay (a camera's exposure and transfer, measured once); missing: 0 (hila's simulated
    # eyes render at the look).  :class:`hila_lang.engine.tracking.Prediction` carries moving
    # points over it.

    def begin(self, state: str, pen_down: bool, seconds: float) -> None:
        """A step starts moving the arm for a planned ``seconds``."""
        ...

    def elapse(self, t: float) -> None:
        """``t`` seconds of the step have passed (after every control step)."""
        ...

    def look(self) -> None:
        """The robot perceives the scene again, with its own senses; :meth:`World.points`
        answers from what it perceived until it looks again."""
        ...

    def end(self) -> None:
        """The step is over."""
        ...


@runtime_checkable
class Overview(Protocol):
    """A camera outside the robot, for reports only (never for the robot's decisions)."""

    def top_view_image(self, size_px: int = 480, *, arm_aside: bool = False) -> "CameraImage":
        """A square image straight down on the drawing surface; ``arm_aside``: with the robot's
        arm moved out of the picture for it (and put back after)."""
        ...


@runtime_checkable
class Snapshots(Protocol):
    """Saving and restoring the whole state of a world or a back end (the REPL's ``back``).

    ``save()`` returns an opaque token; ``restore(token)`` makes the owner what it was when the
    token was saved; ``discard(token)`` frees what the token holds (a simulator's saved state)
    once it will not be restored again.  The REPL goes back, never forward: before it restores a
    token it discards every token saved after it, and a token may be restored more than once.
    """

    def save(self) -> Any:
        ...

    def restore(self, saved: Any) -> None:
        ...

    def discard(self, saved: Any) -> None:
        ...


@runtime_checkable
class View(Protocol):
    """A window showing the run to a person (PyBullet's with ``--gui``): the runner tells it which
    FSM state is running, and where it is written in the program."""

    def show_state(self, name: str, where: str) -> None:
        ...


@runtime_checkable
class Backend(Protocol):
    """Executes Cartesian paths and reports where the hand (pen tip) is."""

    name: str
    #: capabilities: an object implementing the protocol, or None when the back end lacks it
    eyes: "Eyes | None"
    ink: "Ink | None"
    overview: "Overview | None"
    snapshots: "Snapshots | None"
    view: "View | None"
    lighting: "Lighting | None"
    streaming: "Streaming | None"

    def hand_position(self) -> "np.ndarray":
        """Current pen-tip position, shape (3,), metres, world frame."""
        ...

    def reset_hand(self, point: "np.ndarray") -> None:
        """Put the hand at ``point`` (3,) at once, without drawing (``hand at``, parking)."""
        ...

    def move(self, path: "np.ndarray", *, pen_down: bool = False, label: str = "") -> "np.ndarray":
        """Follow ``path`` (T, 3) and return the pen-tip trace actually executed (T', 3).

        ``pen_down`` says the segment is meant to touch the paper (drawing): ink is laid only
        where the pen is down and the tip touches the surface.  ``label`` names the FSM state,
        for traces and error messages.  Raises :class:`~hila_lang.core.errors.UnreachableError`
        when a waypoint cannot be reached.  A back end that stops part of the way (an error, or
        Ctrl-C while a real arm moves) may attach the part the hand made to the exception as
        ``exc.executed`` (T', 3): the run's trace and recording keep it.
        """
        ...

    def close(self) -> None:
        """Release resources (a PyBullet client, windows); safe to call twice."""
        ...


@runtime_checkable
class World(Protocol):
    """Named scene points, questions (``ask``), events (``wait``) and the scene to simulate."""

    #: what a simulating back end builds (the drawing surface, where the hand starts); None:
    #: the back end's default
    scene: "Scene | None"
    #: capability: saving and restoring the world's state (the REPL's ``back``), or None
    snapshots: "Snapshots | None"

    def attach(self, backend: Backend) -> None:
        """Called once the back end exists (park the arm, keep the back end for ink and eyes)."""
        ...

    def points(self) -> Mapping[str, "np.ndarray"]:
        """Every named scene point known now, e.g. ``{"board.cell5.tl": array([x, y, z]), ...}``;
        a name mapped to None is a point the world knows of but does not see now (binding an ICP
        to it leaves the ICP out, as ``icp = none`` does: the picture world's unmatched features)."""
        ...

    def query(self, name: str, *args: Any) -> Any:
        """Answer ``ask NAME(args)``; a name the world does not declare raises
        :class:`~hila_lang.core.errors.UnknownNameError`."""
        ...

    def wait(self, event: str, *args: Any) -> Any:
        """Block until ``event`` happens and return its value (``UnknownNameError`` likewise)."""
        ...

    def notify(self, event: str, **data: Any) -> None:
        """Told what the robot did: ``"program"`` (marks: ``{"template.tag": sub-template}`` of the
        program's pen-down runs) before it runs and when it is reloaded, if it draws at all;
        ``"state_done"`` (state, path, executed, kind, pen_down, icps, template, and ``replans`` for
        a streamed run: :class:`hila_lang.engine.tracking.Replan` s) after each run state;
        ``"program_done"`` at the end.  An event a world does not know it ignores."""
        ...

    def finish(self, trace: Sequence[Any], *, fsm: Any = None) -> "dict | None":
        """After the run: print results, write output files; returns a summary or None."""
        ...


#: the capability attributes of a back end and the protocol each must implement when not None
CAPABILITIES = {"eyes": Eyes, "ink": Ink, "overview": Overview, "lighting": Lighting, "snapshots": Snapshots,
                "view": View, "streaming": Streaming}
#: the same for a world (``tracking`` may also be missing: the world cannot be tracked)
WORLD_CAPABILITIES = {"snapshots": Snapshots, "tracking": Tracking}


def _members(protocol: type) -> list[str]:
    names = set(getattr(protocol, "__annotations__", {}))
    names |= {k for k, v in vars(protocol).items() if callable(v) and not k.startswith("_")}
    return sorted(names)


def _compatible(wanted, given) -> str | None:
    """Why signature ``given`` (an implementation) cannot be called as ``wanted``, or None."""
    P = inspect.Parameter
    have = list(given.parameters.values())
    has_var_pos = any(p.kind is P.VAR_POSITIONAL for p in have)
    has_var_kw = any(p.kind is P.VAR_KEYWORD for p in have)
    positional = [p for p in have if p.kind in (P.POSITIONAL_ONLY, P.POSITIONAL_OR_KEYWORD)]
    by_name = {p.name: p for p in have}
    used = set()
    for i, w in enumerate(p for p in wanted.parameters.values() if p.name != "self"):
        if w.kind in (P.POSITIONAL_ONLY, P.POSITIONAL_OR_KEYWORD):
            g = positional[i] if i < len(positional) else None
            if g is None and not has_var_pos:
                return f"takes no positional parameter {w.name!r}"
            if g is not None:
                if g.name != w.name and w.kind is P.POSITIONAL_OR_KEYWORD:
                    return f"names its parameter {i + 1} {g.name!r}, expected {w.name!r}"
                if w.default is not P.empty and g.default is P.empty:
                    return f"parameter {w.name!r} needs a default"
                used.add(g.name)
        elif w.kind is P.KEYWORD_ONLY:
            g = by_name.get(w.name)
            if g is None and not has_var_kw:
                return f"takes no keyword {w.name!r}"
            if g is not None:
                if g.kind not in (P.KEYWORD_ONLY, P.POSITIONAL_OR_KEYWORD):
                    return f"parameter {w.name!r} cannot be passed by keyword"
                if w.default is not P.empty and g.default is P.empty:
                    return f"parameter {w.name!r} needs a default"
                used.add(g.name)
        elif w.kind is P.VAR_POSITIONAL and not has_var_pos:
            return "takes no *args"
        elif w.kind is P.VAR_KEYWORD and not has_var_kw:
            return "takes no **keywords"
    extra = [p.name for p in have if p.name not in used and p.default is P.empty
             and p.kind in (P.POSITIONAL_ONLY, P.POSITIONAL_OR_KEYWORD, P.KEYWORD_ONLY)]
    if extra:
        return f"requires parameter {extra[0]!r}, which callers do not pass"
    return None


def conformance(obj: Any, protocol: type) -> list[str]:
    """What keeps ``obj`` from implementing ``protocol``: missing members and methods whose
    signature cannot be called as the protocol's; for a :class:`Backend` or a :class:`World`, its
    capabilities too.
    An empty list means it conforms."""
    problems = []
    for name in _members(protocol):
        if not hasattr(obj, name):
            problems.append(f"has no {name!r}")
            continue
        wanted = vars(protocol).get(name)
        if callable(wanted):
            given = getattr(obj, name)
            if not callable(given):
                problems.append(f"{name!r} is not a method")
                continue
            why = _compatible(inspect.signature(wanted), inspect.signature(given))
            if why:
                problems.append(f"{name}() {why}")
    capabilities = {Backend: CAPABILITIES, World: WORLD_CAPABILITIES}.get(protocol, {})
    for name, cap in capabilities.items():
        part = getattr(obj, name, None)
        if part is not None:
            problems += [f"{name} {p}" for p in conformance(part, cap)]
    return problems
