"""The Demonstrate page's Camera scene: a pen on the printed sheet before the person's webcam.

The page (``static/camera.js``) asks the browser for the camera (``getUserMedia``), grabs its
frames (downscaled to at most :data:`MAX_SIDE` pixels, JPEG, at most :data:`FPS` a second) and
sends them over the websocket ``/ws/camera`` to this server -- and nowhere else.  The server
tracks each with the same :class:`hila_lang.perception.pen.PenTracker` ``hila learn VIDEO
--sheet`` uses and answers with what the frame shows (the markers, the ball, the tip on the
paper: :meth:`~hila_lang.perception.pen.PenFrame.to_dict`), which the page draws over the live
image.  While the person records, the frames go to a tracker of their own; at **stop** the
recording is finished (:meth:`~hila_lang.perception.pen.PenTracker.finish`: gaps bridged or
refused, contact, the tip in 3-D) and turned into a demonstration exactly as ``hila learn
--sheet`` does (:func:`hila_lang.perception.pen.as_demonstration`: 20 Hz, metres in the sheet's
frame, the ICPs the sheet prints).  The page then shows the path on the sheet seen from above
(:func:`sheet_scene`) as a drawn one, and it is cut, tagged and saved by the Demonstrate page's
own ``/api/save`` (:func:`hila_lang.studio.demonstrate.save`, ``hila learn``'s function).  A
recorded video uploaded to ``POST /api/camera/video`` is decoded here by OpenCV and gives the
same answer.

Websocket messages (JSON objects; each answered by one):

- ``{"op": "start", "ball": "green", "ball_mm": 12}`` -> ``{"op": "ready", "limits": {...}}``:
  a new session (the ball's colour and size as ``hila learn --sheet``'s ``--ball``/``--ball-mm``);
- ``{"op": "frame", "t": SECONDS, "jpeg": BASE64, "record": false|true}`` -> ``{"op": "frame",
  "frame": {...}, "recorded": N}``: one camera frame, with the time the page grabbed it;
  ``record`` true adds it to the recording (the first such frame starts a new one);
- ``{"op": "stop", "cell": N|null}`` -> ``{"op": "track", ...}`` (:func:`result`) or a refusal;
- anything wrong -> ``{"op": "refused", "error": REASON}``; the socket goes on.

Bounds (a page cannot make the server hold more): :data:`MAX_FRAME_BYTES` per frame,
:data:`MAX_SIDE` pixels a side, :data:`MAX_FRAMES` frames per recording (a video upload too);
frame times must increase.

Routes: ``WS /ws/camera``, ``POST /api/camera/video?name=FILE&ball=&ball_mm=&cell=``, ``GET
/api/camera/sheet?paper=&grid=`` (the sheet from above, PNG).
"""

from __future__ import annotations

import base64
import binascii
import json
import tempfile
from pathlib import Path

import numpy as np
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.websockets import WebSocket

from ..core.errors import InputError
from ..evaluation.lasa import RATE_HZ
from ..perception.pen import as_demonstration, BALL_MM, drawn_cell, PenTracker
from ..perception.recording import iter_frames
from ..perception.sheet import PAPERS, raster, SheetLayout
from .page import JSONSocket, read_body

#: frames a second the page sends at most: hila resamples every demonstration at 20 Hz, so finer
#: frames add little to the path; tracking one 640x480 frame costs about 8 ms of CPU (ArUco and
#: the ball's outline; process time over 90 synthetic JPEG frames, load 13 on 2 cores), so 20 a
#: second take about a sixth of a core
FPS = 20
#: the longest side of a frame the page sends (it downscales to it): the tracker's tip is within
#: a millimetre at 640x480 (bench/pen.py), more pixels cost time and bytes, not accuracy
MAX_SIDE = 640
#: bytes of one JPEG frame, at most (a synthetic 640x480 frame at quality 0.9 is about 30 kB; a
#: webcam's noisier frames are larger, 1 MB leaves them ten times room and more)
MAX_FRAME_BYTES = 1_000_000
#: frames in one recording, at most: two minutes at 30 frames a second
MAX_FRAMES = 3600
#: pixels per millimetre of the sheet drawn from above (:func:`sheet_scene`): an A4 sheet 525 px wide
SCENE_PX_PER_MM = 2.5
#: the hand is moving where the ball's image moves more than MOVING_PX pixels within MOVING_S
#: seconds.  A recording holds the still time before the person starts and after they stop
#: (pressing Record, then Stop); left in, it is not a demonstration's reach or retract, it breaks
#: the tracker's premise that a fifth of the frames have the pen down, and its jitter makes false
#: speed dips.  A displacement over a fixed time, not a speed between frames, so neither the frame
#: rate nor a frame's jitter (0.1-0.2 px on the synthetic videos, a few tenths on a webcam) moves
#: it; a reach covers 40 px in that time (200 px/s at its peak, measured on the synthetic videos),
#: a slow start 4 px at 20 px/s
MOVING_PX, MOVING_S = 4.0, 0.2
#: the still time kept before the hand first moves and after it last moves, seconds (the
#: tracker looks this far for the speed dips of a landing: :data:`hila_lang.perception.pen.SNAP_S`)
STILL_KEPT_S = 0.25
#: video files an upload may be (what OpenCV's FFmpeg reads)
VIDEO_SUFFIXES = (".mp4", ".webm", ".mkv", ".avi", ".mov", ".y4m")


def decode_jpeg(data: str) -> np.ndarray:
    """A frame the page sent (base64 JPEG) as RGB uint8; a frame too big, not JPEG or broken is
    refused saying which."""
    # lazy: loads cv2, which importing this module does not
    import cv2

    if not isinstance(data, str):
        raise InputError("refused frame: expected 'jpeg' as a base64 string")
    if len(data) > MAX_FRAME_BYTES * 4 // 3 + 4:
        raise InputError(f"refused frame: over {MAX_FRAME_BYTES} bytes; send frames of at most {MAX_SIDE} px a side")
    try:
        raw = base64.b64decode(data, validate=True)
    except (binascii.Error, ValueError):
        raise InputError("refused frame: 'jpeg' is not base64") from None
    if raw[:3] != b"\xff\xd8\xff":
        raise InputError("refused frame: not a JPEG image")
    bgr = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_COLOR)
    if bgr is None:
        raise InputError("refused frame: a broken JPEG image")
    if max(bgr.shape[:2]) > MAX_SIDE:
        raise InputError(f"refused frame: {bgr.shape[1]}x{bgr.shape[0]} px; at most {MAX_SIDE} px a side")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def options(doc) -> dict:
    """The tracker's options from a request: ``ball`` (colour), ``ball_mm``."""
    try:
        ball_mm = float(doc.get("ball_mm") or BALL_MM)
    except (TypeError, ValueError):
        raise InputError(f"expected the ball's diameter in millimetres, got {doc.get('ball_mm')!r}") from None
    return dict(ball=str(doc.get("ball") or "green"), ball_mm=ball_mm)


def cell_of(value) -> int | None:
    if value in (None, "", "auto"):
        return None
    try:
        cell = int(value)
    except (TypeError, ValueError):
        cell = 0
    if not 1 <= cell <= 9:
        raise InputError(f"cell {value!r}: expected a grid cell 1 to 9 (1 top left, 9 bottom right), or none")
    return cell


def sheet_scene(layout) -> dict:
    """The sheet seen from above as a Demonstrate scene (``{name, image, width, height, H, z, lift,
    features}``, as :func:`hila_lang.studio.demonstrate.scene`): H maps the sheet's frame (metres,
    x right, y up the page) to the picture's pixels; the features are the printed points (metres)."""
    w_mm, h_mm = layout.size
    s = SCENE_PX_PER_MM * 1000.0
    width, height = int(round(w_mm * SCENE_PX_PER_MM)), int(round(h_mm * SCENE_PX_PER_MM))
    return dict(name="camera", image=f"/api/camera/sheet?paper={layout.paper}&grid={int(layout.grid)}",
                width=width, height=height, H=[[s, 0.0, 0.0], [0.0, -s, float(height)], [0.0, 0.0, 1.0]],
                z=0.0, lift=None, features=[dict(name=n, point=[p[0] / 1000.0, p[1] / 1000.0, 0.0])
                                            for n, p in layout.features().items()])


def sheet_png(paper: str, grid: bool) -> bytes:
    # lazy: loads cv2, which importing this module does not
    import cv2

    grey = raster(SheetLayout(paper, grid), SCENE_PX_PER_MM)
    _, png = cv2.imencode(".png", np.asarray(grey, np.uint8))
    return png.tobytes()


def trim_still(tracker) -> tuple[int, int]:
    """Keep the recorded frames from :data:`STILL_KEPT_S` before the hand first moves to as long
    after it last does (:data:`MOVING_PX` within :data:`MOVING_S`; a frame without the ball is
    not a move); returns (frames left out before, after).  A recording where it never moves is
    kept whole (finish then says why)."""
    frames = tracker.frames
    if len(frames) < 4:
        return 0, 0
    uv = np.array([f.ball if f.ball is not None else (np.nan, np.nan) for f in frames], float).reshape(-1, 2)
    t = np.array([f.time for f in frames])
    later = np.searchsorted(t, t + MOVING_S)  # the first frame MOVING_S after each
    ok = later < len(t)
    moved = np.zeros(len(t), bool)
    moved[ok] = np.linalg.norm(uv[later[ok]] - uv[ok], axis=1) > MOVING_PX  # NaN: not a move
    if not moved.any():
        return 0, 0
    first, last = np.flatnonzero(moved)[[0, -1]]
    keep = np.flatnonzero((t >= t[first] - STILL_KEPT_S) & (t <= t[later[last]] + STILL_KEPT_S))
    a, b = int(keep[0]), int(keep[-1]) + 1
    tracker.frames = frames[a:b]
    return a, len(frames) - b


def result(tracker, cell=None, source: str = "the recording") -> dict:
    """A finished recording as the page takes it: ``{path, times, pen, icps, cell, summary,
    frames, still, longest_gap_s, frame_times, scene}`` (``frame_times``: the tracked frames' times,
    seconds on the path's clock) (the path in metres at 20 Hz, as ``hila learn --sheet`` writes it), the
    still frames at its ends left out first (:func:`trim_still`; ``still``: how many).  ``cell``: the
    grid cell whose corners are the ICPs; None: the cell the pen drew in
    (:func:`hila_lang.perception.pen.drawn_cell`), or the corner markers off the grid."""
    before, after = trim_still(tracker)
    track = tracker.finish(names=[f"{source}#{i}" for i in range(len(tracker.frames))], source=source)
    path, times, pen, icps = as_demonstration(track, RATE_HZ, cell=cell)
    if cell is None:
        cell = drawn_cell(track.layout, path, pen)
        if cell is not None:
            path, times, pen, icps = as_demonstration(track, RATE_HZ, cell=cell)
    return dict(path=path.tolist(), times=times.tolist(), pen=pen.tolist(),
                icps={k: np.asarray(v, float).tolist() for k, v in icps.items()}, cell=cell,
                summary=track.summary(), frames=len(track.times), still=[before, after],
                longest_gap_s=float(np.diff(track.times).max()), frame_times=track.times.tolist(),
                scene=sheet_scene(track.layout))


class Session:
    """One page's camera: a tracker for the live view and one for the recording."""

    def __init__(self, ball: str = "green", ball_mm: float = 12.0) -> None:
        self.make = lambda: PenTracker(ball, ball_mm)
        self.live = self.make()
        self.recording = None
        self.last_t = None

    def frame(self, doc: dict) -> dict:
        """One frame (``{t, jpeg, record}``): tracked, and recorded when ``record``."""
        try:
            t = float(doc["t"])
        except (KeyError, TypeError, ValueError):
            raise InputError("refused frame: expected 't', the time it was grabbed in seconds") from None
        if not np.isfinite(t) or (self.last_t is not None and t <= self.last_t):
            raise InputError(f"refused frame: its time {doc.get('t')!r} is not after the last frame's ({self.last_t})")
        rgb = decode_jpeg(doc.get("jpeg"))
        record = bool(doc.get("record"))
        if record and self.recording is None:
            self.recording = self.make()
        if record and len(self.recording.frames) >= MAX_FRAMES:
            raise InputError(f"refused frame: a recording holds at most {MAX_FRAMES} frames; stop it")
        tracker = self.recording if record else self.live
        if tracker.size is not None and (rgb.shape[1], rgb.shape[0]) != tracker.size:
            if record:
                raise InputError(f"refused frame: {rgb.shape[1]}x{rgb.shape[0]} px, the recording's frames are "
                                 f"{tracker.size[0]}x{tracker.size[1]}")
            tracker = self.live = self.make()  # the camera changed: the live view starts again
        frame = tracker.feed(rgb, t)
        self.last_t = t
        if not record:
            self.live.frames = self.live.frames[-1:]  # the live view keeps nothing it will not draw
            self.live._rows = self.live._rows[-30:]   # the focal length from the last second or so
        return dict(op="frame", frame=dict(frame.to_dict(), size=list(tracker.size)),
                    recorded=0 if self.recording is None else len(self.recording.frames))

    def stop(self, cell) -> dict:
        if self.recording is None:
            raise InputError("nothing recorded: press Record, draw, then Stop")
        recording, self.recording = self.recording, None
        return dict(result(recording, cell_of(cell)), op="track")


class CameraSocket(JSONSocket):
    """``/ws/camera``: the page's camera frames in, what they show out (module docstring)."""

    session: Session | None = None

    async def on_message(self, websocket: WebSocket, doc: dict) -> None:
        op = doc.get("op")
        if op == "start":
            self.session = await run_in_threadpool(lambda: Session(**options(doc)))
            out = dict(op="ready", limits=dict(fps=FPS, max_side=MAX_SIDE, max_frame_bytes=MAX_FRAME_BYTES,
                                               max_frames=MAX_FRAMES))
        elif self.session is None:
            raise InputError("start the camera first ({'op': 'start'})")
        elif op == "frame":
            out = await run_in_threadpool(self.session.frame, doc)
        elif op == "stop":
            out = await run_in_threadpool(self.session.stop, doc.get("cell"))
        else:
            raise InputError(f"unknown op {op!r}; expected start, frame or stop")
        await websocket.send_text(json.dumps(out))

    async def on_error(self, websocket: WebSocket, doc: dict, text: str) -> None:
        await websocket.send_text(json.dumps({"op": "refused", "error": text, "was": doc.get("op")}))


def track_upload(data: bytes, name: str, query) -> dict:
    """A recorded video (its bytes, its file name) tracked as a recording (:func:`result`); it is
    written to a temporary file for OpenCV to decode and removed, never kept in the folder."""
    suffix = Path(name).suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise InputError(f"{name}: expected a video file ({', '.join(VIDEO_SUFFIXES)})")
    if not data:
        raise InputError(f"{name}: the upload is empty")
    tracker = PenTracker(**options(query))
    cell = cell_of(query.get("cell"))
    with tempfile.TemporaryDirectory(prefix="hila-camera-") as tmp:
        file = Path(tmp) / f"upload{suffix}"
        file.write_bytes(data)
        for i, (rgb, _, t) in enumerate(iter_frames(file, "frames")):
            if i >= MAX_FRAMES:
                raise InputError(f"{name}: over {MAX_FRAMES} frames; the studio tracks at most {MAX_FRAMES} "
                                 "(use 'hila learn VIDEO --sheet' for longer videos)")
            tracker.feed(rgb, t)
        if not tracker.frames:
            raise InputError(f"{name}: no frames OpenCV can read")
    return dict(result(tracker, cell, source=Path(name).name), op="track")


# ----------------------------------------------------------------------------- routes


async def _video(request: Request) -> Response:
    q = request.query_params
    data = await read_body(request)
    return JSONResponse(await run_in_threadpool(track_upload, data, q.get("name", "video"), q))


async def _sheet(request: Request) -> Response:
    q = request.query_params
    paper = q.get("paper", "a4")

    if paper not in PAPERS:
        raise InputError(f"unknown paper {paper!r}; expected {' or '.join(PAPERS)}")
    return Response(await run_in_threadpool(sheet_png, paper, q.get("grid") == "1"), media_type="image/png")


ROUTES = [
    WebSocketRoute("/ws/camera", CameraSocket),
    Route("/api/camera/video", _video, methods=["POST"]),
    Route("/api/camera/sheet", _sheet),
]
