"""The dashboard's JavaScript modules, checked inside the real browser (page.evaluate).

Oracles are independent of the JS: map frames are built here with ``struct`` + ``zlib`` straight
from PROTOCOL.md, ellipses are checked against numpy's eigen-decomposition, transforms against the
REP-103 convention (x right, y up on screen, yaw counter-clockwise).
"""

from __future__ import annotations

import base64
import math
import re
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

STATIC = Path(__file__).resolve().parents[2] / "static"

HEADER = struct.Struct("<BBHIdddIII")


def frame_bytes(cells: np.ndarray, tile: int, res: float, origin, seq: int, full: bool, compress: bool,
                only: list[int] | None = None) -> bytes:
    """A binary map frame per PROTOCOL.md, written independently of the server's encoder."""
    h, w = cells.shape
    tiles_x, tiles_y = -(-w // tile), -(-h // tile)
    indices = range(tiles_x * tiles_y) if only is None else only
    payload = b""
    for index in indices:
        tx, ty = index % tiles_x, index // tiles_x
        block = np.full((tile, tile), 255, np.uint8)
        part = cells[ty * tile:(ty + 1) * tile, tx * tile:(tx + 1) * tile]
        block[: part.shape[0], : part.shape[1]] = part
        payload += struct.pack("<I", index) + block.tobytes()
    flags = (1 if full else 0) | (2 if compress else 0)
    if compress:
        payload = zlib.compress(payload)
    return HEADER.pack(1, flags, tile, seq, res, origin[0], origin[1], w, h, len(indices)) + payload


@pytest.fixture(scope="module")
def modules(browser, static_url):
    """A page on the static server from which the dashboard's modules can be imported."""
    context = browser.new_context()
    page = context.new_page()
    page.goto(static_url + "js/view.js")
    yield page
    context.close()


def run(page, body: str, arg=None):
    """Evaluate an async function body in the page with ``arg``; its modules are importable by name."""
    return page.evaluate(f"async (arg) => {{ {body} }}", arg)


def test_world_screen_transforms_follow_rep103(modules):
    out = run(modules, """
        const { View } = await import('./view.js');
        const v = new View(800, 600);
        v.centerOn(2, 3); v.scale = 50;
        const centre = v.worldToScreen(2, 3);
        const up = v.worldToScreen(2, 4);       // +y is up on screen
        const right = v.worldToScreen(3, 3);    // +x is right
        const back = v.screenToWorld(...v.worldToScreen(-1.25, 7.5));
        const [a, b, c, d, e, f] = v.matrix(2);  // the canvas matrix for devicePixelRatio 2
        const m = [a * -1.25 + c * 7.5 + e, b * -1.25 + d * 7.5 + f];
        const s = v.worldToScreen(-1.25, 7.5);
        // zooming keeps the world point under the cursor fixed
        const before = v.screenToWorld(100, 500);
        v.zoomAt(100, 500, 3.0);
        const after = v.screenToWorld(100, 500);
        // a 90-degree yaw points up the screen; a drag up the screen is yaw +pi/2
        const ang = View.yawToScreenAngle(Math.PI / 2);
        return { centre, up, right, back, m, s: [s[0] * 2, s[1] * 2], before, after, scale: v.scale,
                 dirUp: [Math.cos(ang), Math.sin(ang)],
                 dragUp: View.screenDirectionToYaw(10, 10, 10, 0),
                 dragLeft: View.screenDirectionToYaw(10, 10, 0, 10) };
    """)
    assert out["centre"] == [400, 300]
    assert out["up"] == [400, 250]
    assert out["right"] == [450, 300]
    assert out["back"] == pytest.approx([-1.25, 7.5])
    assert out["m"] == pytest.approx(out["s"])
    assert out["after"] == pytest.approx(out["before"])
    assert out["scale"] == pytest.approx(150)
    assert out["dirUp"] == pytest.approx([0, -1], abs=1e-12)
    assert out["dragUp"] == pytest.approx(math.pi / 2)
    assert out["dragLeft"] == pytest.approx(math.pi)


def test_zoom_is_clamped_and_fit_shows_the_rectangle(modules):
    out = run(modules, """
        const { View, MIN_SCALE, MAX_SCALE } = await import('./view.js');
        const v = new View(400, 300);
        v.zoomAt(0, 0, 1e9); const hi = v.scale;
        v.zoomAt(0, 0, 1e-9); const lo = v.scale;
        v.fit(-5, -2, 15, 8, 20);
        const vis = v.visibleWorld();
        v.fit(-5, -2, 15, 8, 20, 100);   // 100 px kept free at the top
        const [, top] = v.worldToScreen(0, 8);
        const [, bottom] = v.worldToScreen(0, -2);
        return { hi, lo, MIN_SCALE, MAX_SCALE, vis, top, bottom, scale: v.scale };
    """)
    assert out["hi"] == out["MAX_SCALE"] and out["lo"] == out["MIN_SCALE"]
    x0, y0, x1, y1 = out["vis"]
    assert x0 <= -5 and x1 >= 15 and y0 <= -2 and y1 >= 8
    assert (x1 - x0) == pytest.approx(20 * 400 / 360)  # the width limits: (400 - 2*20) px for 20 m
    assert out["scale"] == pytest.approx((300 - 40 - 100) / 10)  # now the height limits
    assert out["top"] == pytest.approx(120) and out["bottom"] == pytest.approx(280)


@pytest.mark.parametrize("compress", [False, True])
def test_map_frame_decoder_reads_what_protocol_md_describes(modules, compress):
    rng = np.random.default_rng(7)
    cells = rng.choice(np.array([0, 37, 100, 255], np.uint8), size=(70, 150))
    frame = frame_bytes(cells, 64, 0.05, (-3.5, 1.25), 42, True, compress)
    out = run(modules, """
        const { decodeMapFrame } = await import('./mapframe.js');
        const bytes = Uint8Array.from(atob(arg), (c) => c.charCodeAt(0));
        const f = await decodeMapFrame(bytes.buffer);
        const tiles = f.tiles.map((t) => ({ ...t, cells: Array.from(t.cells) }));
        return { ...f, tiles };
    """, base64.b64encode(frame).decode())
    assert out["full"] is True and out["zlib"] is compress
    assert (out["tileSize"], out["seq"], out["width"], out["height"]) == (64, 42, 150, 70)
    assert (out["resolution"], out["originX"], out["originY"]) == (0.05, -3.5, 1.25)
    assert (out["tilesX"], out["tilesY"]) == (3, 2)
    rebuilt = np.full((128, 192), 255, np.uint8)
    for t in out["tiles"]:
        assert t["index"] == t["ty"] * 3 + t["tx"]
        y0, x0 = t["ty"] * 64, t["tx"] * 64
        rebuilt[y0:y0 + 64, x0:x0 + 64] = np.reshape(t["cells"], (64, 64))
    np.testing.assert_array_equal(rebuilt[:70, :150], cells)
    assert (rebuilt[70:, :] == 255).all() and (rebuilt[:, 150:] == 255).all()


def test_map_frame_decoder_rejects_malformed_frames(modules):
    good = frame_bytes(np.zeros((10, 10), np.uint8), 16, 0.1, (0, 0), 1, True, False)
    cases = {
        "short": good[:20],
        "truncated": good[:-5],
        "type": bytes([2]) + good[1:],
        "index": good[:44] + struct.pack("<I", 99) + good[48:],
    }
    out = run(modules, """
        const { decodeMapFrame } = await import('./mapframe.js');
        const result = {};
        for (const [name, b64] of Object.entries(arg)) {
            const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
            try { await decodeMapFrame(bytes.buffer); result[name] = 'accepted'; }
            catch (e) { result[name] = e.constructor.name + ': ' + e.message; }
        }
        return result;
    """, {k: base64.b64encode(v).decode() for k, v in cases.items()})
    assert out["short"].startswith("MapFrameError") and "header" in out["short"]
    assert out["truncated"].startswith("MapFrameError") and "payload" in out["truncated"]
    assert "unknown type 2" in out["type"]
    assert "tile index 99" in out["index"]


def test_map_tiles_draw_cells_where_they_are_in_the_world(modules):
    """A full frame then a delta, drawn through the view: the pixels under each world point show its
    cell (row 0 = smallest y at the bottom of the screen), and a delta repaints only its tile."""
    cells = np.full((100, 100), 255, np.uint8)  # 2 x 2 tiles of 64, 5 m x 5 m at 5 cm
    cells[90:95, 5:10] = 100  # occupied block near the TOP-left (large y, small x)
    cells[5:10, 90:95] = 0  # free block near the BOTTOM-right
    full = frame_bytes(cells, 64, 0.05, (-1.0, -2.0), 1, True, True)
    cells2 = cells.copy()
    cells2[90:95, 90:95] = 100  # top-right, in tile 3
    delta = frame_bytes(cells2, 64, 0.05, (-1.0, -2.0), 2, False, False, only=[3])
    out = run(modules, """
        const { decodeMapFrame } = await import('./mapframe.js');
        const { MapTiles, PALETTE } = await import('./maptiles.js');
        const { View } = await import('./view.js');
        const b = (s) => Uint8Array.from(atob(s), (c) => c.charCodeAt(0)).buffer;
        const canvas = document.createElement('canvas'); canvas.width = 500; canvas.height = 500;
        const ctx = canvas.getContext('2d');
        const view = new View(500, 500); view.fit(-1, -2, 4, 3, 0);   // 100 px per metre
        const tiles = new MapTiles();
        const px = ([x, y]) => {
            const [sx, sy] = view.worldToScreen(x, y);
            return Array.from(ctx.getImageData(Math.floor(sx), Math.floor(sy), 1, 1).data);
        };
        const draw = () => {
            ctx.setTransform(...view.matrix(1));
            ctx.clearRect(-100, -100, 200, 200);
            tiles.draw(ctx);
        };
        const cell = (ix, iy) => [-1 + (ix + .5) * .05, -2 + (iy + .5) * .05];  // cell centre in metres
        const [topLeft, bottomRight, topRight] = [cell(7, 92), cell(92, 7), cell(92, 92)];
        tiles.apply(await decodeMapFrame(b(arg.full)));
        draw();
        const first = { occTopLeft: px(topLeft), freeBottomRight: px(bottomRight),
                        unknown: px([1.5, 0.5]), topRight: px(topRight),
                        cellAt: [topLeft, bottomRight, [50, 50]].map((p) => tiles.cellAt(...p)),
                        known: tiles.knownBounds() };
        const applied = tiles.apply(await decodeMapFrame(b(arg.delta)));
        draw();
        const unpack = (p) => [p & 255, (p >> 8) & 255, (p >> 16) & 255, p >>> 24];
        return { first, applied, topRight: px(topRight), stillOcc: px(topLeft), version: tiles.version,
                 occ: unpack(PALETTE[100]), free: unpack(PALETTE[0]), unk: unpack(PALETTE[255]) };
    """, {"full": base64.b64encode(full).decode(), "delta": base64.b64encode(delta).decode()})
    first = out["first"]
    assert first["occTopLeft"] == out["occ"]
    assert first["freeBottomRight"] == out["free"]
    assert first["unknown"] == out["unk"] and first["topRight"] == out["unk"]
    assert first["cellAt"] == [100, 0, 255]
    assert out["applied"] is True and out["version"] == 2
    assert out["topRight"] == out["occ"] and out["stillOcc"] == out["occ"]
    # the known cells span ix, iy in [5, 95): "fit" frames exactly them
    lo, hi = 5 * 0.05, 95 * 0.05
    assert first["known"] == pytest.approx([-1.0 + lo, -2.0 + lo, -1.0 + hi, -2.0 + hi])


def test_delta_that_does_not_fit_the_map_is_dropped(modules):
    a = frame_bytes(np.zeros((20, 20), np.uint8), 16, 0.05, (0, 0), 1, True, False)
    b = frame_bytes(np.zeros((40, 20), np.uint8), 16, 0.05, (0, 0), 2, False, False, only=[0])
    out = run(modules, """
        const { decodeMapFrame } = await import('./mapframe.js');
        const { MapTiles } = await import('./maptiles.js');
        const buf = (s) => Uint8Array.from(atob(s), (c) => c.charCodeAt(0)).buffer;
        const tiles = new MapTiles();
        const early = tiles.apply(await decodeMapFrame(buf(arg[1])));   // delta before any full frame
        const full = tiles.apply(await decodeMapFrame(buf(arg[0])));
        const wrong = tiles.apply(await decodeMapFrame(buf(arg[1])));   // different height
        return [early, full, wrong];
    """, [base64.b64encode(a).decode(), base64.b64encode(b).decode()])
    assert out == [False, True, False]


def test_uncertainty_ellipse_matches_numpy_eigen(modules):
    rng = np.random.default_rng(3)
    covs = []
    for _ in range(20):
        a = rng.normal(size=(2, 2))
        covs.append((a @ a.T).tolist())
    covs.append([[0.04, 0.0], [0.0, 0.01]])
    out = run(modules, """
        const { covarianceEllipse, CHI2_2DOF_95 } = await import('./geometry.js');
        return { chi2: CHI2_2DOF_95, e: arg.map((c) => covarianceEllipse(c)) };
    """, covs)
    for cov, e in zip(covs, out["e"], strict=True):
        values, vectors = np.linalg.eigh(np.array(cov))
        assert e["a"] == pytest.approx(math.sqrt(out["chi2"] * values[1]), rel=1e-9)
        assert e["b"] == pytest.approx(math.sqrt(out["chi2"] * max(values[0], 0)), rel=1e-6, abs=1e-9)
        major = vectors[:, 1]
        along = math.cos(e["angle"]) * major[0] + math.sin(e["angle"]) * major[1]
        assert abs(along) == pytest.approx(1, abs=1e-9)
    assert out["chi2"] == pytest.approx(5.991, abs=1e-3)  # chi-square 95 %, 2 dof


def test_teleop_command_and_relative_urls(modules):
    out = run(modules, """
        const { command, LINEAR_SPEED, ANGULAR_SPEED } = await import('./teleop.js');
        const { httpUrl, wsUrl } = await import('./urls.js');
        let leading = null;
        try { httpUrl('/api/status', 'http://h/'); } catch (e) { leading = e.message; }
        return {
            fl: command(new Set(['forward', 'left'])), br: command(new Set(['back', 'right'])),
            none: command(new Set()), both: command(new Set(['forward', 'back'])),
            v: LINEAR_SPEED, w: ANGULAR_SPEED,
            api: httpUrl('api/status', 'https://example.org/robot/'),
            ws: wsUrl('ws', { token: 'a b' }, 'https://example.org/robot/index.html'),
            wsPlain: wsUrl('ws', {}, 'http://10.0.0.2:8000/'), leading,
        };
    """)
    assert out["fl"] == [out["v"], out["w"]] and out["br"] == [-out["v"], -out["w"]]
    assert out["none"] == [0, 0] and out["both"] == [0, 0]
    assert 0 < out["v"] <= 0.5 and 0 < out["w"] <= 2.0  # within the server's teleop limits
    assert out["api"] == "https://example.org/robot/api/status"
    assert out["ws"] == "wss://example.org/robot/ws?token=a+b"
    assert out["wsPlain"] == "ws://10.0.0.2:8000/ws"
    assert "relative" in out["leading"]


ABSOLUTE = re.compile(
    r"""(?:href|src|action)\s*=\s*["']/|(?:fetch|import|WebSocket|httpUrl|wsUrl|url)\(\s*["'`]/"""
    r"""|["'`]/(?:api|ws|static|js|css)\b|\bhttps?://(?!example\.org)""",
)


def test_no_absolute_or_external_urls_in_static():
    """Relative URLs only (reverse proxy under a sub-path) and nothing fetched from the internet."""
    offenders = []
    for path in sorted(STATIC.rglob("*")):
        if path.suffix not in {".html", ".js", ".css"}:
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if ABSOLUTE.search(line) and "goo.gl" not in line:
                offenders.append(f"{path.relative_to(STATIC)}:{number}: {line.strip()}")
    assert not offenders, "absolute or external URLs:\n" + "\n".join(offenders)
    assert (STATIC / "index.html").read_text().count('type="module"') == 1


def test_index_loads_without_script_errors(page, static_url):
    """With no homebot behind the static files the page still loads and says it is offline."""
    page.goto(static_url)
    page.wait_for_selector("#offline-banner", state="visible", timeout=10_000)
    assert page.locator("#st-conn").inner_text().strip() == "offline"
    assert page.js_errors == []


def test_renderer_draws_landmark_ellipses_robot_heading_and_scan_where_they_are(modules):
    """Landmark ellipses (EKF mode) along their covariance's axes, the robot's arrow along its yaw
    (REP-103: yaw pi/2 points up the screen), scan points at their world positions."""
    out = run(modules, """
        const { State } = await import('./state.js');
        const { Renderer } = await import('./renderer.js');
        const canvas = document.createElement('canvas');
        canvas.width = 400; canvas.height = 400;
        const state = new State();
        state.robot = { footprint_radius: 0.17 };
        const r = new Renderer(canvas, state);
        r.view.resize(400, 400); r.view.centerOn(1, 2); r.view.scale = 100;
        state.handle({ type: 'landmarks', landmarks: [[1, 2]], covariances: [[[0.09, 0], [0, 0.01]]] });
        state.handle({ type: 'pose', x: 0, y: 2, yaw: Math.PI / 2, localized: true });
        state.handle({ type: 'scan', pose: [0, 2, Math.PI / 2], points: [[2.5, 3.5]] });
        r.layers.places = false;
        r.draw();
        const ctx = canvas.getContext('2d');
        const rgb = (x, y) => [...ctx.getImageData(Math.round(x), Math.round(y), 1, 1).data].slice(0, 3);
        // does any pixel within 2 px of (x, y) have colour c (+-40 per channel, for anti-aliasing)?
        const near = (x, y, c) => {
            for (let dx = -2; dx <= 2; dx++) for (let dy = -2; dy <= 2; dy++) {
                const p = rgb(x + dx, y + dy);
                if (p.every((v, k) => Math.abs(v - c[k]) <= 40)) return true;
            }
            return false;
        };
        const [cx, cy] = r.view.worldToScreen(1, 2);
        const a = Math.sqrt(5.991 * 0.09) * 100, b = Math.sqrt(5.991 * 0.01) * 100;
        const [violet, white] = [[124, 58, 237], [255, 255, 255]];
        const [teal, red] = [[15, 118, 110], [220, 38, 38]];
        const [rx, ry] = r.view.worldToScreen(0, 2);
        const rr = state.robot.footprint_radius * 100;
        const [px, py] = r.view.worldToScreen(2.5, 3.5);
        return {
            majorEnd: near(cx + a, cy, violet), minorEnd: near(cx, cy - b, violet),
            notTall: near(cx, cy - a, violet),
            tipUp: near(rx, ry - 0.7 * rr, white), notTipDown: rgb(rx, ry + 0.7 * rr),
            tealDown: near(rx, ry + 0.7 * rr, teal), scanPoint: near(px, py, red),
        };
    """)
    assert out["majorEnd"] and out["minorEnd"] and not out["notTall"]
    assert out["tipUp"] and out["tealDown"]
    assert out["notTipDown"] != [255, 255, 255]
    assert out["scanPoint"]


def test_pointer_gestures_click_drag_pinch_and_wheel(modules):
    """Pointer events as a finger or mouse sends them: a tap picks a point (no heading), a drag picks
    a point and a heading, two fingers pinch-zoom about their midpoint, the wheel zooms about the cursor."""
    out = run(modules, """
        const { View } = await import('./view.js');
        const { PointerControl } = await import('./pointer.js');
        const canvas = document.createElement('canvas');
        canvas.style.cssText = 'position:fixed;left:0;top:0;width:400px;height:300px';
        document.body.appendChild(canvas);
        const view = new View(400, 300); view.scale = 50;
        const picks = [];
        let tool = 'goal';
        new PointerControl(canvas, view, { getTool: () => tool, onPick: (...a) => picks.push(a),
                                           onPreview: () => {}, onViewChange: () => {} });
        const ev = (type, id, x, y) => canvas.dispatchEvent(new PointerEvent(type, {
            pointerId: id, clientX: x, clientY: y, pointerType: 'touch', isPrimary: id === 1, bubbles: true,
        }));
        ev('pointerdown', 1, 250, 150); ev('pointerup', 1, 252, 151);  // tap
        ev('pointerdown', 1, 200, 150); ev('pointermove', 1, 200, 120); ev('pointerup', 1, 200, 100);  // up
        tool = 'pose';
        ev('pointerdown', 1, 200, 150); ev('pointermove', 1, 150, 150); ev('pointerup', 1, 140, 150);  // left
        // pinch: fingers 100 px apart around (300, 100) move to 200 px apart
        const before = view.screenToWorld(300, 100);
        ev('pointerdown', 1, 250, 100); ev('pointerdown', 2, 350, 100);
        ev('pointermove', 1, 200, 100); ev('pointermove', 2, 400, 100);
        ev('pointerup', 1, 200, 100); ev('pointerup', 2, 400, 100);
        const pinched = { scale: view.scale, after: view.screenToWorld(300, 100) };
        const underCursor = view.screenToWorld(50, 250);
        canvas.dispatchEvent(new WheelEvent('wheel',
            { clientX: 50, clientY: 250, deltaY: -200, bubbles: true, cancelable: true }));
        const wheeled = { scale: view.scale, at: view.screenToWorld(50, 250) };
        return { picks, before, pinched, underCursor, wheeled, nPicksAfterPinch: picks.length };
    """)
    tap, drag, pose = out["picks"]
    assert tap[0] == "goal" and tap[1:3] == pytest.approx([1.0, 0.0]) and tap[3] is None
    assert drag[0] == "goal" and drag[1:3] == pytest.approx([0, 0]) and drag[3] == pytest.approx(math.pi / 2)
    assert pose[0] == "pose" and pose[3] == pytest.approx(math.pi)
    assert out["nPicksAfterPinch"] == 3, "a pinch picks nothing"
    assert out["pinched"]["scale"] == pytest.approx(100)
    assert out["pinched"]["after"] == pytest.approx(out["before"])
    assert out["wheeled"]["scale"] > 100
    assert out["wheeled"]["at"] == pytest.approx(out["underCursor"])


def test_the_scale_bar_reads_over_a_wall(modules):
    """The scale bar's label sits on a light backing, so it can be read where the map under it
    is a wall (dark cells) as well as where it is free space."""
    out = run(modules, """
        const { State } = await import('./state.js');
        const { Renderer } = await import('./renderer.js');
        const canvas = document.createElement('canvas');
        canvas.width = 300; canvas.height = 100;
        const r = new Renderer(canvas, new State());
        r.view.resize(300, 100); r.view.scale = 100;
        const ctx = canvas.getContext('2d');
        ctx.fillStyle = '#111827'; ctx.fillRect(0, 0, 300, 100);  // a wall under the whole bar
        r.drawScaleBar();
        const y = 100 - 14;
        const box = ctx.getImageData(12, y - 16, 60, 12).data;  // the label's row above the bar
        let light = 0, dark = 0;
        for (let k = 0; k < box.length; k += 4) {
            const v = (box[k] + box[k + 1] + box[k + 2]) / 3;
            if (v > 200) light++; else if (v < 100) dark++;
        }
        return { light, dark, pixels: box.length / 4 };
    """)
    assert out["light"] > 0.5 * out["pixels"], out  # a backing, not the wall
    assert out["dark"] > 5, out  # the label's strokes on it
