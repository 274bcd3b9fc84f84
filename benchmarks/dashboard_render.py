"""Dashboard speed in Debian's chromium (headless, via Playwright): decoding + painting binary map
frames (zlib, 64x64 tiles) and drawing one frame of the live view.

    python benchmarks/dashboard_render.py

Prints, per map size: the full frame's bytes, decode + tile painting time; a 16-tile delta's time;
and the time of one complete redraw (map + 300 particles + 360 scan points + a 200-point path) on a
1280x800 canvas. Times are medians over repeats, in milliseconds.
"""

from __future__ import annotations

import base64
import functools
import shutil
import struct
import threading
import zlib
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

STATIC = Path(__file__).resolve().parents[1] / "static"
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
TILE = 64
SIZES = (512, 1024, 2048)  # cells per side at 5 cm: 25.6 m, 51.2 m, 102.4 m
DELTA_TILES = 16
REPEATS = 15


def frame(cells: np.ndarray, indices: np.ndarray, full: bool) -> bytes:
    """A zlib map frame (PROTOCOL.md) with the given tiles."""
    h, w = cells.shape
    tx, ty = -(-w // TILE), -(-h // TILE)
    padded = np.full((ty * TILE, tx * TILE), 255, np.uint8)
    padded[:h, :w] = cells
    blocks = padded.reshape(ty, TILE, tx, TILE).transpose(0, 2, 1, 3).reshape(tx * ty, TILE * TILE)
    records = np.empty(len(indices), dtype=[("i", "<u4"), ("c", np.uint8, TILE * TILE)])
    records["i"], records["c"] = indices, blocks[indices]
    payload = zlib.compress(records.tobytes(), 1)
    return struct.pack("<BBHIdddIII", 1, (1 if full else 0) | 2, TILE, 1, 0.05, 0.0, 0.0, w, h,
                       len(indices)) + payload


def house_like(n: int, rng: np.random.Generator) -> np.ndarray:
    """Free rooms with walls, unknown outside: compresses like a real map."""
    cells = np.full((n, n), 255, np.uint8)
    inner = slice(n // 8, n - n // 8)
    cells[inner, inner] = 0
    for k in range(n // 8, n - n // 8, max(n // 10, 8)):
        cells[k, inner] = 100
        cells[inner, k] = 100
    noise = rng.random((n, n)) < 0.02
    cells[noise & (cells == 0)] = rng.integers(1, 60, noise.sum())[: (noise & (cells == 0)).sum()]
    return cells


class QuietHandler(SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


BENCH_JS = """async ([full, delta, repeats]) => {
    const { decodeMapFrame } = await import('./mapframe.js');
    const { State } = await import('./state.js');
    const { Renderer } = await import('./renderer.js');
    const b = (s) => Uint8Array.from(atob(s), (c) => c.charCodeAt(0)).buffer;
    const fullBuf = b(full), deltaBuf = b(delta);
    const median = (xs) => xs.sort((p, q) => p - q)[Math.floor(xs.length / 2)];
    const canvas = document.createElement('canvas'); canvas.width = 1280; canvas.height = 800;
    const state = new State();
    const r = new Renderer(canvas, state); r.view.resize(1280, 800);
    const fullMs = [], deltaMs = [], drawMs = [];
    for (let i = 0; i < repeats; i++) {
        let t = performance.now();
        state.map.apply(await decodeMapFrame(fullBuf.slice(0)));
        fullMs.push(performance.now() - t);
        t = performance.now();
        state.map.apply(await decodeMapFrame(deltaBuf.slice(0)));
        deltaMs.push(performance.now() - t);
    }
    r.view.fit(...state.map.bounds());
    const c = state.map.bounds().map((v) => v / 2);
    const cx = (c[0] + c[2]), cy = (c[1] + c[3]);
    state.handle({ type: 'pose', x: cx, y: cy, yaw: 0.3, localized: true });
    const many = (n, f) => Array.from({ length: n }, (_, k) => f(k));
    state.handle({ type: 'particles', particles: many(300, (k) => [cx + Math.sin(k), cy + Math.cos(k), k]) });
    state.handle({ type: 'scan', pose: [cx, cy, 0.3],
                   points: many(360, (k) => [cx + 4 * Math.cos(k / 57.3), cy + 4 * Math.sin(k / 57.3)]) });
    state.handle({ type: 'path', goal: { x: cx + 5, y: cy }, state: 'driving', reason: null,
                   path: many(200, (k) => [cx + k / 40, cy + Math.sin(k / 20)]) });
    for (let i = 0; i < repeats * 4; i++) {
        const t = performance.now();
        r.draw();
        canvas.getContext('2d').getImageData(0, 0, 1, 1);  // wait for the drawing to finish
        drawMs.push(performance.now() - t);
    }
    return { full: median(fullMs), delta: median(deltaMs), draw: median(drawMs) };
}"""


def main() -> None:
    handler = functools.partial(QuietHandler, directory=str(STATIC))
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    rng = np.random.default_rng(0)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=shutil.which("chromium"), args=ARGS)
        page = browser.new_page()
        page.goto(f"http://127.0.0.1:{server.server_address[1]}/js/view.js")
        print(f"{'map (cells)':>12} {'tiles':>6} {'full frame':>11} {'full ms':>8} {'delta ms':>9} "
              f"{'redraw ms':>10}")
        for n in SIZES:
            cells = house_like(n, rng)
            tiles = (-(-n // TILE)) ** 2
            full = frame(cells, np.arange(tiles), True)
            delta = frame(cells, rng.choice(tiles, DELTA_TILES, replace=False), False)
            frames = [base64.b64encode(full).decode(), base64.b64encode(delta).decode()]
            out = page.evaluate(BENCH_JS, [*frames, REPEATS])
            print(f"{n:>5} x {n:<5} {tiles:>6} {len(full) / 1024:>8.0f} KiB {out['full']:>8.1f} "
                  f"{out['delta']:>9.2f} {out['draw']:>10.2f}")
        browser.close()
    server.shutdown()


if __name__ == "__main__":
    main()
