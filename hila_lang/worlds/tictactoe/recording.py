"""The circle demonstration seen by the iCub's eyes in simulation: the scene, the recording, learning.

The robot watches a *human* demonstrate; here the human is the seeded motion model of
:mod:`.demonstration`, performed by a green hand marker over the demonstrator's sheet
(:meth:`.board.Grid.demonstration`, on a low table).  :class:`DemonstrationScene` is what the eye
cameras look at -- the table, the sheet with its grid (and any circles and crosses on it), the
marker -- in its own :class:`~hila_lang.sim.scene.SimScene` (no robot loaded: recording does
not pay for the iCub).  :func:`record_demonstration` writes a recording folder through
:func:`hila_lang.perception.recording.write_recording`; :func:`learn_from_sim` records and then
learns the template by perception (``hila learn --from-sim``).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from ...core.errors import InputError
from ...osila.segmentation import DEFAULT_METHOD
from ...perception.learn import template_from_frames
from ...perception.recording import write_recording
from ...perception.rig import rig
from ...robot.rig import watching_poses
from ...robot.spec import resolve
from ...sim.camera import Camera, STUDIO
from ...sim.canvas import Canvas
from ...sim.scene import SimScene
from .board import cell_center, Grid
from .demonstration import demonstrate
from .marks import cross_strokes
from .vision import demonstration_icps

#: colour of the demonstrator's hand marker (RGBA, 0..1): saturated green (nothing else in the scene is green)
MARKER_RGBA = (0.05, 0.8, 0.1, 1.0)
#: radius of the hand marker, metres
MARKER_RADIUS = 0.012
#: the marker's centre sits this far above the pen tip (it is on the back of the pen), metres
MARKER_OFFSET = np.array([0.0, 0.0, MARKER_RADIUS + 0.004])
#: table colour (RGBA)
TABLE_RGBA = (0.45, 0.33, 0.22, 1.0)


def paper_texture(spec: Grid, marks=None, *, grid: bool = True, seed: int = 0) -> np.ndarray:
    """The sheet as the game draws it (:meth:`.board.Grid.paper` and its ink), RGB (H, W, 3) uint8.

    ``marks`` is a sequence of 9 strings in {"", "O", "X"} for cells 1..9: circles in the
    robot's ink, crosses (:func:`.marks.cross_strokes`) in the opponent's, both a little
    irregular (seeded) like hand-drawn ones.  Row 0 is the sheet's far edge.
    """
    canvas = Canvas(spec.paper(printed=grid))
    rng = np.random.default_rng(seed)
    cell = spec.grid_size / 3
    for i, mark in enumerate(list(marks or [])):
        if mark == "O":
            centre = spec.world_to_grid(cell_center(spec, i + 1)) + rng.normal(scale=0.04 * cell, size=2)
            a = rng.uniform(0, 2 * np.pi) + np.linspace(0, 2 * np.pi * rng.uniform(0.97, 1.06), 60)
            r = cell * rng.uniform(0.28, 0.34) * (1 + 0.06 * np.sin(2 * a + rng.uniform(0, 6)))
            pts = spec.grid_to_world(centre[0] + r * np.cos(a), centre[1] + r * np.sin(a))
            canvas.draw_polyline(pts, color="robot")
        elif mark == "X":
            for stroke in cross_strokes(spec, i + 1, rng):
                canvas.draw_polyline(stroke, color="opponent")
        elif mark:
            raise InputError(f"mark must be '', 'O' or 'X', got {mark!r}")
    return canvas.image.copy()


class DemonstrationScene:
    """The demonstrator's table, sheet and hand marker in their own PyBullet client.

    Parameters
    ----------
    spec : Grid
        Where the table, sheet and grid are (default: the demonstration board).
    marks : sequence of 9 str, optional
        Circles ("O") and crosses ("X") already on the sheet, cells 1..9.
    marker, table, paper : bool
        Which objects to add (the marker is hidden until :meth:`set_marker`).
    """

    def __init__(self, spec: Grid | None = None, marks=None, *, marker: bool = True, table: bool = True,
                 paper: bool = True, seed: int = 0) -> None:
        self.spec = spec or Grid.demonstration()
        self.sim = SimScene(style=STUDIO)
        s = self.spec
        self.paper = self.marker = None
        if table:  # 3 m square: a stereo rig on a stand sees table around the sheet, not the sky
            # (the iCub's eyes see the same pixels as with the 1.2 m table it was first given)
            half = (1.5, 1.5, 0.02)
            top = s.surface_z - 0.001
            self.sim.add_box(half, (s.grid_center[0] + 0.15, s.grid_center[1], top - half[2]), TABLE_RGBA)
        if paper:
            self.paper = self.sim.add_surface(s.paper(printed=False), paper_texture(s, marks, seed=seed))
        if marker:
            self.marker = self.sim.add_sphere(MARKER_RADIUS, MARKER_RGBA)

    def set_marker(self, point) -> None:
        """Put the hand marker's centre at ``point`` (3,), world, metres."""
        self.sim.set_position(self.marker, point)

    def render(self, camera: Camera) -> np.ndarray:
        """An ideal pinhole RGB image (height, width, 3) uint8 of ``camera``."""
        return self.sim.render(camera)

    def close(self) -> None:
        self.sim.close()

    def __enter__(self) -> "DemonstrationScene":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def demonstration_rig(spec: Grid | None = None, robot=None):
    """The robot's eyes while it watches (``robot``: a :class:`~hila_lang.robot.spec.RobotSpec`,
    default the iCub): the iCub's gaze aimed at the demonstration grid's centre, each eye placed
    by its joint angles through its kinematic chain (:func:`hila_lang.robot.eyes.eye_poses_looking_at`,
    the function that places the game's eyes); a stereo rig's cameras where they stand
    (:func:`hila_lang.robot.rig.watching_poses`)."""
    spec = spec or Grid.demonstration()
    robot = robot if robot is not None else resolve()
    return rig(watching_poses(robot, (spec.grid_center[0], spec.grid_center[1], spec.surface_z)))


def record_demonstration(out_dir, seed: int = 0, *, n_calibration: int = 40, n_stereo: int = 16,
                         overwrite: bool = False, frames: int | None = None, robot=None) -> Path:
    """Record the seeded demonstration (:func:`.demonstration.demonstrate`) to a recording folder.

    The hand marker's centre follows the pen tip plus :data:`MARKER_OFFSET` while the distorted
    left and right eye cameras take one image per demonstration sample (20 Hz).  ``frames``
    records only the first samples (quick tests); the rest is
    :func:`hila_lang.perception.recording.write_recording`'s.  ``truth.yaml`` holds the pen-tip
    path, times, ICPs and the demonstrated cell.
    """
    spec = Grid.demonstration()
    demo = demonstrate(seed, spec)
    n = len(demo.path) if frames is None else max(2, min(int(frames), len(demo.path)))
    truth = {"seed": seed, "times": demo.times[:n].tolist(), "path": demo.path[:n].tolist(),
             "icps": {k: v.tolist() for k, v in demo.icps.items()}, "cell": demo.cell}
    out = Path(out_dir)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise InputError("recording folder exists and is not empty (use overwrite)", file=str(out))
    with DemonstrationScene(spec, seed=seed) as scene:
        def render(i: int, camera: Camera) -> np.ndarray:
            scene.set_marker(demo.path[i] + MARKER_OFFSET)
            return scene.render(camera)

        return write_recording(out, demonstration_rig(spec, robot), n, render, surface_z=spec.surface_z,
                               marker_offset=MARKER_OFFSET, truth=truth, seed=seed,
                               n_calibration=n_calibration, n_stereo=n_stereo, overwrite=overwrite)


def learn_from_sim(seed: int = 0, *, k: int = 3, tags=("reach", "draw", "retract"), contact=("draw",),
                   name: str = "circle", method: str = DEFAULT_METHOD, recording_dir=None, frames: int | None = None,
                   n_calibration: int = 40, n_stereo: int = 16, return_perception: bool = False, robot=None):
    """Record the seeded demonstration in PyBullet, then learn it by perception.

    ``recording_dir`` keeps the recording (default: a temporary folder, deleted afterwards);
    ``frames`` records only the first frames, ``n_calibration`` and ``n_stereo`` set the
    chessboard sessions (see :func:`record_demonstration`).  The ICPs are read by
    :func:`.vision.demonstration_icps`.
    """
    def run(folder: Path):
        record_demonstration(folder, seed, n_calibration=n_calibration, n_stereo=n_stereo, overwrite=True,
                             frames=frames, robot=robot)
        out = template_from_frames(folder, read_icps=demonstration_icps, k=k, tags=tags, contact=contact,
                                   name=name, method=method, seed=0, return_perception=return_perception)
        template = out[0] if return_perception else out
        template.description = (
            f"Learned by perception from a simulated recording: the seeded human-like demonstration "
            f"(hila_lang.worlds.tictactoe.demonstration, seed {seed}) performed by a green hand marker in "
            f"PyBullet, seen by the iCub's two eye cameras (320x240, 20 Hz, barrel lens distortion). "
            + template.description.split(f" in {folder}: ", 1)[-1]
            + f" Made by: hila learn --from-sim --seed {seed} -k {k} --tags {','.join(tags)}"
            + (f" --contact {','.join(contact)}" if contact else ""))
        return out

    if recording_dir is not None:
        return run(Path(recording_dir))
    with tempfile.TemporaryDirectory(prefix="hila_recording_") as tmp:
        return run(Path(tmp) / "recording")
