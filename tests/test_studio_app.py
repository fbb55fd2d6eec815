"""hila studio's app: the URL line, the refusals of its security rules (token, Host, Origin, paths,
uploads), atomic writes, a taken port and Ctrl-C.  Plain HTTP and websocket clients, so each
header can be forged as an attacker's page or a rebinding DNS name would send it."""

from __future__ import annotations

import http.client
import json
import re
import subprocess
import sys

import pytest

from studio_support import Studio

pytest.importorskip("starlette")


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    folder = tmp_path_factory.mktemp("studio")
    (folder / "prog.hila").write_text("main {\n}\n")
    outside = tmp_path_factory.mktemp("outside")
    (outside / "secret.hila").write_text("secret\n")
    (folder / "link.hila").symlink_to(outside / "secret.hila")
    (folder / "linkdir").symlink_to(outside, target_is_directory=True)
    s = Studio(folder)
    yield s
    s.stop()


def request(s, method, path, *, host=None, headers=None, body=None, token=True):
    conn = http.client.HTTPConnection("127.0.0.1", s.port, timeout=20)
    sep = "&" if "?" in path else "?"
    url = path + (f"{sep}token={s.token}" if token is True else (f"{sep}token={token}" if token else ""))
    hdrs = {"Host": host or f"127.0.0.1:{s.port}", **(headers or {})}
    conn.request(method, url, body=body, headers=hdrs)
    r = conn.getresponse()
    return r.status, r.read().decode("utf-8", "replace"), r


def test_first_line_is_the_url_with_a_fresh_token(studio):
    assert re.fullmatch(r"hila studio: http://127\.0\.0\.1:\d+/\?token=[A-Za-z0-9_-]{40,}\n", studio.first_line)
    status, text, r = request(studio, "GET", "/")
    assert status == 200 and "/static/common.js" in text
    assert f"hila_studio_{studio.port}=" in r.getheader("set-cookie") and "HttpOnly" in r.getheader("set-cookie")


def test_cookie_from_the_token_url_is_enough_for_the_page_and_its_own_requests(studio):
    """The cookie alone opens the page; for data it needs the page's own request
    (Sec-Fetch-Site: same-origin) or the X-Hila-Token header (issue 32: another port's page
    sends the cookie too, as Sec-Fetch-Site: same-site)."""
    status, _, r = request(studio, "GET", "/")
    cookie = r.getheader("set-cookie").split(";")[0]
    status, text, _ = request(studio, "GET", "/", token=None, headers={"Cookie": cookie})
    assert status == 200 and "/static/common.js" in text
    for site in ("same-origin", "none"):
        status, text, _ = request(studio, "GET", "/api/files", token=None,
                                  headers={"Cookie": cookie, "Sec-Fetch-Site": site})
        assert status == 200 and "prog.hila" in json.loads(text)["files"]
    status, text, _ = request(studio, "GET", "/api/files", token=None,
                              headers={"Cookie": "x=1", "X-Hila-Token": studio.token})
    assert status == 200 and "prog.hila" in json.loads(text)["files"]
    for headers in ({"Cookie": cookie}, {"Cookie": cookie, "Sec-Fetch-Site": "same-site"},
                    {"Cookie": cookie, "Sec-Fetch-Site": "cross-site"}):
        status, text, _ = request(studio, "GET", "/api/raw?path=prog.hila", token=None, headers=headers)
        assert status == 403 and "another page" in text and "main" not in text


@pytest.mark.parametrize("token, why", [(None, "no token"), ("wrong", "wrong token")])
def test_refused_without_the_right_token(studio, token, why):
    status, text, _ = request(studio, "GET", "/api/files", token=token)
    assert status == 403 and why in text
    status, text, _ = request(studio, "GET", "/static/common.js", token=token)
    assert status == 403


def test_refused_foreign_host_dns_rebinding(studio):
    status, text, _ = request(studio, "GET", "/api/files", host=f"evil.example:{studio.port}")
    assert status == 403 and "Host 'evil.example" in text
    status, text, _ = request(studio, "GET", "/api/files", host="127.0.0.1:1")
    assert status == 403


def test_refused_foreign_origin_on_http(studio):
    status, text, _ = request(studio, "POST", "/api/check", headers={"Origin": "http://evil.example"},
                              body=json.dumps({"text": ""}))
    assert status == 403 and "evil.example" in text


def _ws(studio, origin, token=True):
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    url = f"ws://127.0.0.1:{studio.port}/ws/imitate" + (f"?token={studio.token}" if token else "")
    try:
        with connect(url, origin=origin, open_timeout=10) as ws:
            ws.send(json.dumps({"template": "../none.yaml", "icps": {}, "seq": 1}))
            return "open", json.loads(ws.recv(timeout=10))
    except InvalidStatus as exc:
        return "refused", exc.response.status_code


def test_websocket_needs_own_origin_and_token(studio):
    state, reply = _ws(studio, f"http://127.0.0.1:{studio.port}")
    assert state == "open" and "refused" in reply["error"]  # reached the app: the file name is refused there
    assert _ws(studio, "http://evil.example") == ("refused", 403)
    assert _ws(studio, f"http://127.0.0.1:{studio.port}", token=False) == ("refused", 403)


@pytest.mark.parametrize("name, why", [
    ("../outside.hila", "goes up a folder"),
    ("sub/../../x.hila", "goes up a folder"),
    ("/etc/passwd", "absolute path"),
    ("link.hila", "symbolic link"),
    ("linkdir/secret.hila", "symbolic link"),
])
def test_paths_outside_the_folder_are_refused(studio, name, why):
    status, text, _ = request(studio, "GET", f"/api/file?path={name}")
    assert status == 403 and why in json.loads(text)["error"]
    status, text, _ = request(studio, "PUT", f"/api/file?path={name}", body=b"main {\n}\n")
    assert status == 403 and why in json.loads(text)["error"]
    assert (studio.folder.parent / "outside.hila").exists() is False


def test_writes_are_atomic_and_inside(studio):
    status, text, _ = request(studio, "PUT", "/api/file?path=new/p.hila", body="main {\n}\n".encode())
    assert status == 200, text
    assert (studio.folder / "new" / "p.hila").read_text() == "main {\n}\n"
    assert not [p for p in (studio.folder / "new").iterdir() if p.name.endswith(".tmp")]


def test_oversized_upload_is_refused_and_nothing_written(studio):
    from hila_lang.studio.security import MAX_UPLOAD

    status, text, _ = request(studio, "POST", "/api/upload?path=big.png", body=b"\0" * (MAX_UPLOAD + 1))
    assert status == 403 and "limit" in json.loads(text)["error"]
    assert not (studio.folder / "big.png").exists()
    status, text, _ = request(studio, "POST", "/api/upload?path=small.png", body=b"\x89PNG")
    assert status == 200 and (studio.folder / "small.png").read_bytes() == b"\x89PNG"


def test_check_gives_lsp_located_problems(studio):
    status, text, _ = request(studio, "POST", "/api/check", body=json.dumps({"path": "x.hila", "text": "main {\n  run nothing.x()\n}\n"}))
    problems = json.loads(text)["problems"]
    assert status == 200 and problems and problems[0]["line"] == 1 and problems[0]["severity"] == "error"


def test_taken_port_is_one_line_exit_2_and_ctrl_c_is_130(tmp_path):
    s = Studio(tmp_path)
    try:
        r = subprocess.run([sys.executable, "-m", "hila_lang", "studio", str(tmp_path), "--port", str(s.port)],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and r.stdout == ""
        assert r.stderr.count("\n") == 1 and f"port {s.port}" in r.stderr and "taken" in r.stderr
    finally:
        assert s.stop() == 130


def test_bad_websocket_messages_are_answered_and_the_socket_lives(studio):
    from websockets.sync.client import connect

    url = f"ws://127.0.0.1:{studio.port}/ws/imitate?token={studio.token}"
    with connect(url, origin=f"http://127.0.0.1:{studio.port}", open_timeout=10) as ws:
        ws.send("not json")
        assert "error" in json.loads(ws.recv(timeout=10))
        ws.send("[1, 2]")
        assert "JSON object" in json.loads(ws.recv(timeout=10))["error"]
        ws.send(json.dumps({"template": "prog.hila", "seq": 3}))
        reply = json.loads(ws.recv(timeout=10))
        assert reply["seq"] == 3 and "error" in reply


def test_ctrl_c_with_a_game_waiting_for_a_move_exits_130(tmp_path):
    import shutil

    from websockets.sync.client import connect

    from studio_support import ROOT

    shutil.copy(ROOT / "programs" / "game.hila", tmp_path)
    s = Studio(tmp_path)
    try:
        with connect(f"ws://127.0.0.1:{s.port}/ws/run?token={s.token}", origin=f"http://127.0.0.1:{s.port}",
                     open_timeout=10) as ws:
            ws.send(json.dumps({"cmd": "start", "path": "game.hila", "backend": "dry", "settings": {"opponent": "human"}}))
            ws.send(json.dumps({"cmd": "run"}))
            while not json.loads(ws.recv(timeout=30)).get("waiting"):
                pass  # the run waits in a worker thread for the person's cell
            assert s.stop() == 130
    finally:
        s.stop()


def test_a_page_is_its_module_its_script_and_its_test():
    """Each page is three files: ``studio/NAME.py`` (its routes, under 350 lines), ``static/SCRIPT``
    (an ES module exporting its markup, state, mount and files) and ``tests/test_studio_NAME.py``;
    the package data ships every static file."""
    import tomllib
    from fnmatch import fnmatch
    from pathlib import Path

    from hila_lang.studio import app

    root = Path(__file__).resolve().parents[1]
    studio = root / "hila_lang" / "studio"
    for page in app.PAGES:
        module = next(m for m in ("demonstrate", "imitate", "run") if getattr(__import__(
            f"hila_lang.studio.{m}", fromlist=["PAGE"]), "PAGE") is page)
        assert len((studio / f"{module}.py").read_text().splitlines()) <= 350, module
        script = (studio / "static" / page.script).read_text()
        for name in ("html", "state", "mount", "files"):
            assert re.search(rf"^export (const|async function|function) {name}\b", script, re.M), (page.script, name)
        assert (root / "tests" / f"test_studio_{module}.py").is_file()
    globs = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["hila_lang.studio"]
    shipped = [p.relative_to(studio).as_posix() for p in (studio / "static").rglob("*") if p.is_file()]
    assert shipped and all(any(fnmatch(f, g) for g in globs) for f in shipped)


def test_the_studio_names_no_world():
    """What a world shows in the studio comes from its plug-in: the studio's code, scripts and page
    hold no world's name as a string (nor the shipped game's anywhere) and import no world."""
    from pathlib import Path

    from hila_lang.plugins import registry

    studio = Path(__file__).resolve().parents[1] / "hila_lang" / "studio"
    worlds = registry.names("world")
    assert {"tictactoe", "letters"} <= set(worlds)
    for path in studio.rglob("*"):
        if path.suffix not in (".py", ".js", ".html", ".css"):
            continue
        text = path.read_text()
        quoted = [w for w in worlds if re.search(rf"[\"'`]{w}[\"'`.:]", text)]
        assert quoted == [], f"{path.name} names {quoted}"
        assert not re.search(r"tic-?tac-?toe|hila_lang\.worlds|from \.\.worlds", text, re.I), path.name
