"""hila studio's live imitation, measured in the real browser: pointer move -> redrawn OSILA path.

A seeded synthetic 2-D template of T = 1000 waypoints (a smooth random curve, metres, with 0.5 mm
of white noise, so OSILA's candidate ball -- 2 sigma of the path's noise -- is not empty) with K = 8
ICPs -- its two ends, three points on the path and three off it -- is opened in the studio's
Imitate view in Debian's chromium (Playwright, headless).  Each drag step moves the ICP handle
``icp-p3`` by a few pixels with a real pointer move (the browser's own input pipeline), and the
time is taken in the page from just before the move to the end of the redraw whose answer
matches that move (the websocket round trip, OSILA in the server, the canvas redraw).  The
server's share (``server_ms``: parsing the scene, THE HILA step, the reason) is reported by the
server with each answer.  Moves are sent one at a time, each after the previous redraw (what a
person dragging at screen rate sees when the page keeps up).

Not a test.  Seeded.  Prints one line per 10 moves, then exactly
``studio drag_to_redraw_ms median=M p95=P server_ms median=S``.

    python bench/studio.py [--moves 60] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

T, K = 1000, 8

def template(seed: int):
    """A smooth random 2-D curve (T points over 4 s) with K ICPs: its ends, 3 on it, 3 off it."""
    from hila_lang.osila.template import Template

    rng = np.random.default_rng(seed)
    s = np.linspace(0, 1, T)
    coef = rng.normal(scale=0.05, size=(2, 4))
    path = np.column_stack([0.2 * s + sum(coef[0, k] * np.sin((k + 1) * np.pi * s) for k in range(4)),
                            sum(coef[1, k] * np.sin((k + 1) * np.pi * s) for k in range(4))])
    path += rng.normal(scale=0.0005, size=path.shape)  # 0.5 mm of hand/camera noise: OSILA's ball is not empty
    on = path[[0, 250, 500, 750, T - 1]]
    off = path[[120, 380, 630]] + rng.normal(scale=0.03, size=(3, 2))
    icps = {f"p{i + 1}": p for i, p in enumerate(np.vstack([on, off]))}
    return Template("bench", path, icps, times=np.arange(T) / (T / 4.0), description="bench/studio.py synthetic")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--moves", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    from hila_lang.osila.template import save_template
    from studio_support import BROWSER_ARGS, Studio

    exe = shutil.which("chromium")
    if exe is None:
        print("bench/studio.py needs Debian's chromium (apt-get install chromium)", file=sys.stderr)
        return 2
    folder = Path(tempfile.mkdtemp(prefix="hila-bench-studio-"))
    save_template(template(args.seed), folder / "bench.yaml")
    studio = Studio(folder)
    totals, servers = [], []
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=exe, headless=True, args=BROWSER_ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.goto(studio.url)
            page.wait_for_function("window.hilaStudio && window.hilaStudio.demo && window.hilaStudio.demo.scene !== undefined")
            page.get_by_test_id("tab-imitate").click()
            page.get_by_test_id("imitate-template").select_option("bench.yaml")
            page.wait_for_function("window.hilaStudio.imitate.path && window.hilaStudio.imitate.shown >= 1", timeout=120000)
            box = page.get_by_test_id("icp-p3").bounding_box()
            x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            page.mouse.move(x, y)
            page.mouse.down()
            rng = np.random.default_rng(args.seed)
            for i in range(args.moves):
                dx, dy = rng.uniform(-3, 3, size=2)
                x, y = x + dx, y + dy
                ms = _one_move(page, x, y)
                totals.append(ms[0])
                servers.append(ms[1])
                if (i + 1) % 10 == 0:
                    print(f"  moves {i + 1:3d}: drag_to_redraw median {np.median(totals):.1f} ms, "
                          f"server median {np.median(servers):.1f} ms", flush=True)
            page.mouse.up()
            browser.close()
    finally:
        studio.stop()
        shutil.rmtree(folder, ignore_errors=True)
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}; T = {T}, K = {K}, {args.moves} moves")
    print(f"studio drag_to_redraw_ms median={np.median(totals):.1f} p95={np.percentile(totals, 95):.1f} "
          f"server_ms median={np.median(servers):.1f}")
    return 0


def _one_move(page, x: float, y: float) -> tuple[float, float]:
    """One real pointer move (Playwright's mouse, dispatched by the browser's input pipeline) and
    the page's time from that event's time stamp to the end of the matching redraw."""
    page.evaluate("""() => { const I = window.hilaStudio.imitate; window.__want = I.seq + 1;
      window.__result = new Promise(res => { I.onPath = (r) => { if (r.seq >= window.__want)
        requestAnimationFrame(() => res([performance.now(), r.server_ms])); }; });
      window.__t0 = null;
      document.querySelector('[data-testid=icp-p3]').addEventListener('pointermove',
        (e) => { if (window.__t0 === null) window.__t0 = e.timeStamp; }, { once: true }); }""")
    page.mouse.move(x, y)
    t1, server = page.evaluate("window.__result")
    t0 = page.evaluate("window.__t0")
    return t1 - t0, server


if __name__ == "__main__":
    sys.exit(main())
