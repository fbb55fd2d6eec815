"""A hostile round against ``hila studio`` (issue 32): every route and websocket gets malformed
bodies, wrong types in every field, huge counts, deep JSON, 1e308 / Infinity / NaN, hostile
paths and binary frames; then the studio must still answer normally.

It starts ``hila studio`` on a fresh folder (a template, a program, a picture), sends each input
with the right token (an attacker with the token is the worst case: the door must hold by
itself), and counts the answers by status.  The promise: 0 answers of 500, 0 "bug in hila" (in
an HTTP body or a websocket message), every socket still open after its bad messages, and the
studio answering a good request afterwards.  Exit 0 when kept, 1 when not (each failure
printed).

    python bench/hostile_studio.py [--quick]

``--quick`` sends one mutation per field instead of all of them (the test suite runs it).
"""

from __future__ import annotations

import argparse
import http.client
import json
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: values that must never reach a handler, put in every field
BAD_VALUES = [None, True, "text", "", 1e308, -1e308, float("inf"), float("nan"), 10**400, -1, 0, 1.5, [], {},
              [1e308], [None], [[1, 2]] * 3, {"a": 1}, "x" * 100_000, [0] * 200_000]
QUICK_VALUES = [True, "text", 1e308, float("nan"), 10**400, [None], {"a": 1}, [0] * 200_000]
HOSTILE_PATHS = ["", "../x.hila", "/etc/passwd", "a/../../b", "x\x00y", "C:\\x", "%2e%2e/x", "." * 300,
                 "a/" * 2000 + "b", "link.hila", "pipe.hila", "missing.yaml", "prog.hila/x"]


def studio_args(folder: Path) -> list[str]:
    return [sys.executable, "-m", "hila_lang", "studio", str(folder)]


class Target:
    def __init__(self, folder: Path) -> None:
        self.proc = subprocess.Popen(studio_args(folder), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        if not line.startswith("hila studio: http://127.0.0.1:"):
            raise SystemExit(f"hila studio did not start: {line!r} {self.proc.stderr.read()}")
        url = line.split(": ", 1)[1].strip()
        base, self.token = url.split("/?token=")
        self.port = int(base.rsplit(":", 1)[1])
        self.statuses: Counter = Counter()
        self.failures: list[str] = []

    def http(self, method: str, path: str, body: bytes | None = None) -> tuple[int, str]:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=120)
        sep = "&" if "?" in path else "?"
        try:
            conn.request(method, f"{path}{sep}token={self.token}", body=body,
                         headers={"Host": f"127.0.0.1:{self.port}", "Content-Type": "application/json"})
            r = conn.getresponse()
            status, text = r.status, r.read().decode("utf-8", "replace")
        except (OSError, http.client.HTTPException) as exc:
            status, text = 0, f"no answer: {exc}"
        finally:
            conn.close()
        self.statuses[status] += 1
        if status >= 500 or status == 0 or "bug in hila" in text:
            self.failures.append(f"{method} {path[:80]} {(body or b'')[:120]!r} -> {status} {text[:300]}")
        return status, text

    def socket(self, path: str, messages: list) -> None:
        from websockets.sync.client import connect

        with connect(f"ws://127.0.0.1:{self.port}{path}?token={self.token}", origin=f"http://127.0.0.1:{self.port}",
                     open_timeout=10, max_size=None) as ws:
            for message in messages + [b"\x00probe"]:  # the last: the socket still answers
                ws.send(message)
                try:
                    reply = ws.recv(timeout=120 if path != "/ws/run" else 10)
                except TimeoutError:
                    self.statuses["ws-no-reply"] += 1  # a run's answer (a line for a world that reads none)
                    continue
                except Exception as exc:  # noqa: BLE001 - a closed socket is a failure of the promise
                    self.failures.append(f"{path} {str(message)[:120]!r}: the socket ended ({exc})")
                    return
                kind = "ws-error" if '"error"' in reply else "ws-answer"
                self.statuses[kind] += 1
                if "bug in hila" in reply:
                    self.failures.append(f"{path} {str(message)[:120]!r} -> {reply[:300]}")
                while path == "/ws/run" and '"type": "error"' not in reply and '"type": "state"' not in reply:
                    reply = ws.recv(timeout=120)  # a run's messages until its state

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def dumps(doc) -> bytes:
    return json.dumps(doc, allow_nan=True).encode()  # NaN and Infinity as Python's json writes them


def mutations(base: dict, values: list):
    """``base`` with each field replaced by each bad value, each field dropped, and junk added."""
    for field in base:
        yield {k: v for k, v in base.items() if k != field}
        for value in values:
            yield dict(base, **{field: value})
    yield dict(base, unknown=[1e308])


def prepare(folder: Path) -> None:
    import os

    import numpy as np

    from hila_lang.core.fileio import write_png

    shutil.copy(ROOT / "primitives" / "reach.yaml", folder / "reach.yaml")
    (folder / "prog.hila").write_text("main {\n}\n")
    write_png(folder / "pic.png", np.full((20, 30, 3), 200, np.uint8))
    (folder / "demo.csv").write_text("x,y\n0,0\n1,1\n2,1\n")
    os.symlink("/etc/passwd", folder / "link.hila")
    os.mkfifo(folder / "pipe.hila")


def deep(n: int) -> bytes:
    return b"[" * n + b"]" * n


def round_(t: Target, quick: bool) -> None:
    values = QUICK_VALUES if quick else BAD_VALUES
    t_ = [i / 20 for i in range(40)]
    path = [[i / 40, (i % 7) / 70] for i in range(40)]
    samples = [dict(x=i / 40, y=0.01 * i, t=i * 16.0, down=i > 5) for i in range(40)]
    bodies = {
        "/api/save": dict(name="hostile", path=path, times=t_, icps={"a": [0, 0], "b": [1, 0]}, tags=["r", "d"],
                          contact=["d"], method="speed", seed=0, cuts=[20], overwrite=True),
        "/api/demonstration": dict(samples=samples, z=0.1, lift=0.02, k=3, method="speed", seed=0),
        "/api/imitate/export": dict(template="reach.yaml", icps={"home": [0.18, -0.25, 0.75], "object": [0.36, -0.1, 0.6]}, via=[[0.3, -0.2, 0.7]],
                                    avoid=[{"centre": [0.3, -0.1, 0.7], "radius": 0.01}], names={"object": "s", "home": "h"}),
        "/api/imitate/explain": dict(template="reach.yaml", icps={"home": [0.18, -0.25, 0.75], "object": [0.36, -0.1, 0.6]}, via=[[0.3, -0.2, 0.7]]),
        "/api/check": dict(path="x.hila", text="main {\n}\n"),
    }
    bodies["/api/demonstration#path"] = dict(path=path, times=t_, k=2, method="changepoint")
    for route, base in bodies.items():
        route = route.split("#")[0]
        t.http("POST", route, dumps(base))
        for doc in mutations(base, values):
            t.http("POST", route, dumps(doc))
        for junk in (b"", b"not json", b"[1, 2]", b"null", b"\xff\xfe", deep(100_000), b'{"a": ' * 5000,
                     dumps({"icps": {str(i): [1e308, 1e308] for i in range(5000)}})):
            t.http("POST", route, junk)
    gets = ["/api/files", "/api/pages", "/api/scenes", "/api/lasa", "/api/plugins"]
    for route in gets:
        t.http("GET", route)
    for p in HOSTILE_PATHS:
        from urllib.parse import quote

        q = quote(p, safe="")
        for method, route in (("GET", f"/api/file?path={q}"), ("PUT", f"/api/file?path={q}&overwrite=1"),
                              ("GET", f"/api/raw?path={q}"), ("POST", f"/api/upload?path={q}"),
                              ("GET", f"/api/template?path={q}"), ("GET", f"/api/open?kind=csv&name={q}"),
                              ("GET", f"/api/open?kind=template&name={q}"), ("GET", f"/api/scene?name=upload:{q}"),
                              ("GET", f"/api/scene-image?name={q}")):
            t.http(method, route, b"main {\n}\n" if method != "GET" else None)
    for odd in ("/api/open?kind=bogus&name=x", "/api/open", "/api/file", "/api/file?path=prog.hila&overwrite=maybe",
                "/api/scene?name=world:nothing", "/api/template", "/api/raw?path=pic.png&path=x"):
        t.http("GET", odd)
    scene = dict(template="reach.yaml", icps={"home": [0.18, -0.25, 0.75], "object": [0.36, -0.1, 0.6]}, seq=1)
    messages = [b"\x00\x01binary", deep(100_000).decode(), "not json", "[1]", json.dumps(scene)]
    messages += [dumps(d).decode() for d in mutations(scene, values)]
    t.socket("/ws/imitate", messages)
    run_msgs = [b"\x00binary", deep(100_000).decode(), json.dumps({"cmd": "scrub", "n": 3}),
                json.dumps({"cmd": "move"}), json.dumps({"cmd": "answer", "text": "5"})]
    for base in (dict(cmd="start", path="prog.hila", backend="dry", seed=0, settings={}),
                 dict(cmd="step", n=1), dict(cmd="view", azimuth=30), dict(cmd="scrub", n=1),
                 dict(cmd="answer", text="5"), dict(cmd="break", state="x")):
        run_msgs += [dumps(d).decode() for d in mutations(base, values)]
    t.socket("/ws/run", run_msgs)
    cam_msgs = [b"\x00binary", deep(100_000).decode(), json.dumps({"op": "frame", "t": 1, "jpeg": "AAAA"})]
    for base in (dict(op="start", ball="green", ball_mm=12), dict(op="frame", t=0.5, jpeg="/9j/AAAA", record=True),
                 dict(op="stop", cell=5)):
        cam_msgs += [dumps(d).decode() for d in mutations(base, values)]
    t.socket("/ws/camera", cam_msgs)
    for route in ("/api/camera/sheet?paper=a4", "/api/camera/sheet?paper=" + "x" * 5000, "/api/camera/sheet?grid=2"):
        t.http("GET", route)
    for q in ("name=v.mp4", "name=v.mp4&ball_mm=1e308", "name=v.mp4&cell=-1", "name=../v.mp4&ball=" + "x" * 500):
        t.http("POST", f"/api/camera/video?{q}", b"\x00\x00\x00\x18ftypmp42" + b"\x00" * 1000)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="one set of bad values per field (a few hundred inputs)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="hila-hostile-") as tmp:
        folder = Path(tmp)
        prepare(folder)
        t = Target(folder)
        start = time.monotonic()
        try:
            round_(t, args.quick)
            status, text = t.http("GET", "/api/files")  # and the studio answers normally afterwards
            alive = status == 200 and "prog.hila" in text
            status, text = t.http("POST", "/api/imitate/explain",
                                  dumps(dict(template="reach.yaml", icps={"home": [0.18, -0.25, 0.75], "object": [0.36, -0.1, 0.6]})))
            alive = alive and status == 200 and '"lines"' in text
            if not alive:
                print("afterwards:", status, text[:300])
        finally:
            t.stop()
        total = sum(t.statuses.values())
        print(f"{total} inputs in {time.monotonic() - start:.0f} s; answers: "
              + ", ".join(f"{k}: {v}" for k, v in sorted(t.statuses.items(), key=lambda kv: str(kv[0]))))
        print(f"500s: {t.statuses.get(500, 0)}; 'bug in hila' or no answer: {len(t.failures)}; "
              f"answers normally afterwards: {'yes' if alive else 'NO'}")
        for f in t.failures[:50]:
            print("  FAILED", f)
        return 0 if not t.failures and alive else 1


if __name__ == "__main__":
    sys.exit(main())
