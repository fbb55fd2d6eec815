"""The ``picture`` world: the iCub retraces a demonstrated route on a map sheet it finds by sight.

When it starts (:meth:`PictureWorld.attach`, PyBullet back end) the robot sees the
demonstration scene again -- the map flat at the demonstration pose, as when the route was
traced (:mod:`.demonstration`) -- and remembers its triangulated features (a robot with other
eyes than the iCub's, which recorded the demonstration -- a stereo rig on a stand -- takes the
demonstration as it was recorded, :func:`.demonstration.recorded_demonstration`, and sees only
the task with its own eyes); the world refuses a
template whose ICPs are not those features (named ``f000``, ...).  Then the task scene is laid
out from ``--seed``: the sheet moved, turned, scaled and (``--set bent=yes``, the default) bent,
three distractor boxes beside it, the light changed (:mod:`.scenes`).  With ``--set map.slide=D``
(``map.turn``, ``map.jump``) the sheet moves while the robot draws, and a program that tracks its
match (``track m``) follows it (:mod:`.tracking`).  ``--set picture.image=FILE`` prints the
person's own picture on the sheet instead of the generated map (:func:`.texture.person_page`); the
route is then theirs, learned on that picture (:func:`.demonstration.learn`), and scored against
where they drew it.

The world is told the program's pen-down templates before it runs (``notify("program")``) and
refuses, then, one not learned from its demonstration: an :class:`InputError` (exit 2) naming
the template and how to learn one, before the robot moves.

Question ``matched``: the robot looks with both eyes, matches its images against the
demonstration's (:func:`hila_lang.perception.matching.match_scenes`, verification
``--set verify=local|homography|none``) and answers the point group ``"match"``.  Scene points
``match.f000`` ... are then the triangulated task points of the pairs it kept, and None for the
demonstration features it did not match or rejected, so ``run picture(m.*)`` binds every matched
ICP and leaves the others out (a point the world does not see binds to none).

At the end the referee (truth: the sheets' geometry, the rendering camera) scores the drawn
route -- the pen-tip trace of the ``draw`` segment (:meth:`PictureWorld.drawn_route`) -- against the true route on the task sheet
(median and 95th percentile, mm), gives the controls in the same table (OSILA's planned route
with the matched pairs, without rejection, with the pairs' true points, with the four corners),
and the matching precision before and after rejection.  ``--out`` (default
``runs/picture-<UTC time>``) gets ``report.json``, ``route.png`` (the map with the true route in
green and the drawn one in blue) and ``eyes.png`` (the task's left eye image, kept pairs green,
rejected red).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ...core.errors import HilaRuntimeError, InputError, UnknownNameError
from ...core.fileio import OutputFolder
from ...perception.distortion import undistorted
from ...perception.matching import match_scenes, scene_features
from ...plugins.snapshots import AttributeSnapshots
from ...sim.surface import Scene
from . import scenes as S, WORLD
from .demonstration import (demonstrated_path, demonstration_features, DRAW, feature_name, LIFT, page_of, REACH,
    recorded_demonstration, ROUTE_SEED)
from .tracking import PictureTracking

FILES = ("report.json", "route.png", "eyes.png")
#: the template's ICPs must be the demonstration's features within this distance, metres
SAME_POINT = 1e-4


class PictureWorld:
    """See the module docstring."""

    def __init__(self, options, settings: dict[str, Any]) -> None:
        self.options = options
        self.seed = int(options.seed)
        self.bent = settings["bent"]
        self.model = settings["verify"]
        self.image = settings.get("picture.image")
        if self.image is not None:  # read now: a bad file is refused before anything is built
            # lazy: only this branch needs it
            from .demonstration import page_of

            self.page, self.to_uv = page_of(self.image)
        self.outputs = OutputFolder(options.out, "picture-{time}", owned=FILES) if settings["report"] else None
        self.mat = S.mat()
        self.scene = Scene(surface=self.mat, home=S.HOME)
        self.backend = None
        self.pairs = None
        self.drawn: list[dict] = []
        self.points_now: dict[str, np.ndarray | None] = {}
        self.light = 1.0
        self.task = None  # the task sheet (the truth), where it is now
        self.matched_task = None  # ... and where it was at the robot's last match (the pairs' referee)

        #: the map moving while the robot draws (``map.slide`` ...), and the robot following it (``track``)
        self.tracking = PictureTracking(self, settings)
        self.snapshots = AttributeSnapshots(self, ("pairs", "points_now", "task", "matched_task"),
                                            append_only=("drawn",))

    # -- plug-in hooks -----------------------------------------------------------------------
    def attach(self, backend) -> None:
        self.backend = backend
        backend.reset_hand(S.HOME)
        if backend.eyes is None or getattr(backend, "sim", None) is None:
            return  # nothing to see: 'ask matched' says so

        self.texture = page_of()[0] if self.image is None else self.page
        robot = getattr(backend, "robot", None)
        if robot is None or robot.eyes == "head":  # the eyes that watched the demonstration: see it again
            self.seen, self.demo, self.demo_images, self.demo_camera = demonstration_features(backend, self.texture)
        else:  # another robot's eyes: the demonstration as it was recorded (the template's ICPs)
            self.seen, self.demo, self.demo_images, self.demo_camera = recorded_demonstration(self.texture)
        self.names = [feature_name(i) for i in range(len(self.seen))]
        self.task = S.task_sheet(self.seed, self.mat.z, self.bent)
        boxes = [(h, [p[0], p[1], self.mat.z + p[2]], c) for h, p, c in S.distractors(self.seed)]
        self.sheet_body = S.show(backend, self.task, self.texture, boxes)[0]
        self.tracking.lay(self.task)
        light = float(np.random.default_rng([self.seed, 2404]).uniform(0.6, 1.0))
        backend.lighting.set_light(light)
        self.light = light
        self.points_now = dict.fromkeys(f"match.{n}" for n in self.names)

    def points(self) -> dict[str, np.ndarray | None]:
        return dict(self.points_now)

    def query(self, name: str, *args: Any) -> Any:
        return WORLD.questions.answer(self, name, args, "the picture world")

    # the questions, as declared in :data:`hila_lang.worlds.picture.WORLD` (name, arguments, doc)
    def ask_matched(self) -> str:
        self._match()
        return "match"

    def ask_pairs(self) -> int:
        return 0 if self.pairs is None else int(self.pairs.kept.sum())

    def _match(self, move_arm: bool = True) -> None:
        """The robot looks with both eyes and matches; ``move_arm``: first take the hand out of the
        way (not while it draws: its own arm is masked anyway)."""
        if self.backend is None or self.backend.eyes is None or getattr(self.backend, "sim", None) is None:
            raise InputError("the picture world's robot matches what its eyes see: run it with --backend pybullet "
                             f"(this back end, {getattr(self.backend, 'name', None)!r}, has no eyes)")
        if move_arm:
            self.backend.reset_hand(S.HOME)
        (left, right), self.task_camera = S.look(self.backend)
        self.task_left = left
        task = scene_features(left, right, hidden=S.own_body(self.backend))
        self.pairs = match_scenes(self.seen, task, self.model)
        self.matched_task = self.task
        points = dict.fromkeys(f"match.{n}" for n in self.names)
        for i, p, keep in zip(self.pairs.template_index, self.pairs.task_points, self.pairs.kept):
            if keep:
                points[f"match.{self.names[i]}"] = p
        self.points_now = points

    def wait(self, event: str, *args: Any) -> Any:
        raise UnknownNameError("event", event, (), owner="the picture world",
                               hint="the picture world has no events; ask it instead")

    def notify(self, event: str, **data: Any) -> None:
        if event == "program":  # what the program draws with: refused now, before the robot moves
            if hasattr(self, "seen"):
                for ref, template in (data.get("marks") or {}).items():
                    self._check_template(template, ref, InputError)
            return
        if event != "state_done":
            return
        template = data.get("template")
        if template is not None and hasattr(self, "seen"):
            self._check_template(template, template.name, HilaRuntimeError)
        if data.get("pen_down"):
            executed = data.get("executed")
            self.drawn.append({"state": data.get("state"), "path": np.asarray(data["path"], float),
                               "executed": None if executed is None else
                               self.tracking.carried(np.asarray(executed, float)),
                               "replans": len(data.get("replans") or ()), "template": template})

    def _check_template(self, template, ref: str, error=HilaRuntimeError) -> None:
        mine = {n: p for n, p in zip(self.names, self.seen.points)}
        theirs = {k: v for k, v in template.icps.items() if k not in ("start", "end")}
        if set(theirs) != set(mine) or any(np.linalg.norm(np.asarray(theirs[k]) - mine[k]) > SAME_POINT for k in mine):
            on = "the generated map" if self.image is None else f"the picture {self.image}"
            how = (f"python -m hila_lang.worlds.picture.demonstration OUT.yaml --image {self.image} --route ROUTE.yaml"
                   if self.image is not None else "python -m hila_lang.worlds.picture.demonstration primitives/picture.yaml")
            raise error(f"the template '{ref}' was not learned from this world's demonstration on {on} (its ICPs "
                        f"are not the {len(mine)} features the robot sees there): it does not fit the picture world",
                        hint=f"learn it on the sheet the robot sees: {how}" + (
                            "; a route drawn on your own picture (hila studio) runs with --set picture.image=FILE, "
                            "the picture it was drawn on" if self.image is None else ""))

    # -- the end -----------------------------------------------------------------------------
    def _route_uv(self) -> np.ndarray:
        """The true route in the sheet's texture coordinates (the referee's): the seeded one on
        the generated map; on a person's picture, the draw part of the template that ran, where
        it lay on the (flat) demonstration sheet."""
        if self.image is None or not self.drawn or self.drawn[-1]["template"] is None:
            return S.route_uv(ROUTE_SEED, DRAW)
        template = self.drawn[-1]["template"]
        down = [np.arange(s.start, s.stop) for s in template.segments if s.contact]
        path = np.asarray(template.path, float)
        return S.sheet_uv(self.demo, path[np.concatenate(down)] if down else path)

    def _score(self) -> dict[str, Any]:
        route = self._route_uv()
        goal = self.task.to_world(route)
        out: dict[str, Any] = {}
        drawn = self.drawn_route()
        if drawn is not None:
            err = S.route_error(drawn, goal) * 1000
            out["route_error_mm"] = {"median": round(float(np.median(err)), 2),
                                     "p95": round(float(np.percentile(err, 95)), 2), "points": int(len(drawn))}
        if self.pairs is not None:
            true_demo, true_task, true = S.referee_pairs(self.pairs, self.demo, self.matched_task, self.demo_camera,
                                                         self.task_camera)
            k = self.pairs.kept
            out["matching"] = {**self.pairs.counts, "verification": self.model,
                               "precision_before": round(float(true.mean()), 3) if len(true) else None,
                               "precision_after": round(float(true[k].mean()), 3) if k.any() else None,
                               "median_confidence": round(float(np.median(self.pairs.confidence[k])), 3) if k.any() else None}
            sets = S.control_sets(self.pairs, self.demo, self.matched_task, true_demo, true_task)
            path = demonstrated_path(self.demo, None if self.image is None else route)
            errors = S.control_errors(path, slice(REACH, REACH + DRAW), sets, goal, S.HOME)
            out["controls_planned_mm"] = {n: {"median": round(m, 2), "p95": round(p, 2)} for n, (m, p) in errors.items()}
        return out

    def drawn_route(self) -> np.ndarray | None:
        """The pen-tip trace (N, 3) of the route's part of the last pen-down run: the executed
        points whose nearest planned point is in the template's ``draw`` segment."""
        if not self.drawn:
            return None
        d = self.drawn[-1]
        planned = d["path"]
        executed = planned if d["executed"] is None else d["executed"]
        if len(planned) != REACH + DRAW + LIFT:  # a run of the draw segment alone
            return executed
        nearest = np.argmin(np.linalg.norm(executed[:, None, :] - planned[None, :, :], axis=2), axis=1)
        keep = (nearest >= REACH) & (nearest < REACH + DRAW)
        return executed[keep] if keep.any() else None

    def _route_image(self) -> np.ndarray:
        # lazy: loads cv2, which importing this module does not
        import cv2

        img = np.ascontiguousarray(self.texture.copy())
        h, w = img.shape[:2]

        def px(uv):
            return (np.asarray(uv) * [w, h] * 16).astype(np.int32).reshape(-1, 1, 2)

        cv2.polylines(img, [px(self._route_uv())], False, (0, 170, 0), 4, cv2.LINE_AA, 4)
        drawn = self.drawn_route()
        if drawn is not None:
            cv2.polylines(img, [px(self.task.to_uv(drawn))], False, (20, 40, 220), 2, cv2.LINE_AA, 4)
        cv2.rectangle(img, (4, h - 22), (w - 4, h - 4), (255, 255, 255), -1)
        cv2.putText(img, "green: true route   blue: drawn (on the sheet)", (8, h - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (0, 0, 0), 1, cv2.LINE_AA)
        return img

    def _eyes_image(self) -> np.ndarray:
        # lazy: loads cv2, which importing this module does not
        import cv2

        img = np.ascontiguousarray(undistorted(self.task_left).rgb.copy())
        for (u, v), keep in zip(self.pairs.task_uv, self.pairs.kept):
            cv2.circle(img, (int(round(u)), int(round(v))), 3, (0, 200, 0) if keep else (230, 0, 0), 1, cv2.LINE_AA)
        return cv2.resize(img, None, fx=2, fy=2, interpolation=cv2.INTER_NEAREST)

    def finish(self, trace=None, *, fsm=None) -> dict[str, Any]:
        task = getattr(self, "task", None) or S.task_sheet(self.seed, self.mat.z, self.bent)
        report = {"world": "picture", "seed": self.seed, "picture": self.image or "generated map",
                  "bent_m": round(task.bend, 4), "light": round(self.light, 3),
                  "task_sheet": {"center": list(task.center), "rotation_deg": round(float(np.degrees(task.rotation)), 2),
                                 "size": list(task.size)},
                  "backend": None if self.backend is None else self.backend.name}
        motion = self.tracking.motion
        if motion is not None and motion.active:
            report["map_moves"] = motion.moves
            report["replans"] = [d["replans"] for d in self.drawn]
        seen = hasattr(self, "seen")
        if seen:
            report.update(self._score())
        r = report.get("route_error_mm")
        m = report.get("matching")
        print(("route error " + (f"median {r['median']} mm, p95 {r['p95']} mm" if r else "not measured (nothing drawn)"))
              + (f"; pairs matched {m['matched']}, kept {m['kept']}, rejected {m['rejected']}" if m else ""),
              file=self.options.stdout)
        if m and m.get("precision_before") is not None:
            print(f"precision of the pairs (referee): {m['precision_before']} before rejection, "
                  f"{m['precision_after']} after", file=self.options.stdout)
        for name, e in report.get("controls_planned_mm", {}).items():
            print(f"  planned with {name + ':':24s} median {e['median']:6.2f} mm, p95 {e['p95']:6.2f} mm",
                  file=self.options.stdout)
        if self.outputs is not None:
            self.outputs.write_text("report.json", json.dumps(report, indent=2) + "\n")
            if seen:
                self.outputs.write_png("route.png", self._route_image())
                if self.pairs is not None:
                    self.outputs.write_png("eyes.png", self._eyes_image())
            self.outputs.close()
            report["out"] = str(self.outputs.path)
            print(f"outputs written to {self.outputs.path}", file=self.options.stdout)
        return report


def make_world(options, settings) -> PictureWorld:
    """Plug-in factory (:data:`hila_lang.worlds.picture.WORLD`)."""
    return PictureWorld(options, settings)
