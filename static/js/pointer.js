// Mouse and touch on the map. Pointer events cover both:
// - wheel zooms about the cursor; two fingers pinch-zoom and pan; middle/right drag pans;
// - the "pan" tool pans with one finger / left drag;
// - the "goal", "pose" and "place" tools: a click picks a point, a drag from it gives a heading.

import { View } from "./view.js";

export const DRAG_THRESHOLD_PX = 8; // a press that moves less than this is a click
export const WHEEL_ZOOM_PER_PIXEL = 0.0015;

export class PointerControl {
  constructor(canvas, view, { getTool, onPick, onPreview, onViewChange }) {
    this.canvas = canvas;
    this.view = view;
    this.getTool = getTool;
    this.onPick = onPick; // (tool, x, y, yaw | null)
    this.onPreview = onPreview; // (preview | null)
    this.onViewChange = onViewChange;
    this.pointers = new Map(); // pointerId -> {x, y}
    this.gesture = null;

    canvas.addEventListener("pointerdown", (e) => this.down(e));
    canvas.addEventListener("pointermove", (e) => this.move(e));
    canvas.addEventListener("pointerup", (e) => this.up(e, false));
    canvas.addEventListener("pointercancel", (e) => this.up(e, true));
    canvas.addEventListener("wheel", (e) => this.wheel(e), { passive: false });
    canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  }

  local(e) {
    const rect = this.canvas.getBoundingClientRect();
    return [e.clientX - rect.left, e.clientY - rect.top];
  }

  down(e) {
    try {
      this.canvas.setPointerCapture(e.pointerId); // keep getting moves when the finger leaves the canvas
    } catch {
      // a pointer the browser no longer tracks: nothing to capture
    }
    const [x, y] = this.local(e);
    this.pointers.set(e.pointerId, { x, y });
    if (this.pointers.size === 2) {
      this.cancelPick();
      this.gesture = { kind: "pinch", ...this.pinchState() };
      return;
    }
    if (this.pointers.size > 2) return;
    const tool = this.getTool();
    const panButton = e.pointerType === "mouse" && (e.button === 1 || e.button === 2);
    if (tool === "pan" || panButton || (e.pointerType === "mouse" && e.shiftKey)) {
      this.gesture = { kind: "pan", x, y };
    } else if (e.button === 0 || e.pointerType !== "mouse") {
      this.gesture = { kind: "pick", tool, sx: x, sy: y, dragging: false };
      this.preview(x, y, null);
    }
  }

  move(e) {
    if (!this.pointers.has(e.pointerId)) return;
    const [x, y] = this.local(e);
    this.pointers.set(e.pointerId, { x, y });
    const g = this.gesture;
    if (!g) return;
    if (g.kind === "pan") {
      this.view.panBy(x - g.x, y - g.y);
      g.x = x;
      g.y = y;
      this.onViewChange();
    } else if (g.kind === "pinch" && this.pointers.size >= 2) {
      const now = this.pinchState();
      this.view.panBy(now.mx - g.mx, now.my - g.my);
      if (g.dist > 0 && now.dist > 0) this.view.zoomAt(now.mx, now.my, now.dist / g.dist);
      Object.assign(g, now);
      this.onViewChange();
    } else if (g.kind === "pick") {
      if (Math.hypot(x - g.sx, y - g.sy) >= DRAG_THRESHOLD_PX) g.dragging = true;
      this.preview(g.sx, g.sy, g.dragging ? View.screenDirectionToYaw(g.sx, g.sy, x, y) : null);
    }
  }

  up(e, cancelled) {
    if (!this.pointers.has(e.pointerId)) return;
    const [x, y] = this.local(e);
    this.pointers.delete(e.pointerId);
    const g = this.gesture;
    if (g?.kind === "pick" && !cancelled) {
      const yaw = Math.hypot(x - g.sx, y - g.sy) >= DRAG_THRESHOLD_PX ? View.screenDirectionToYaw(g.sx, g.sy, x, y) : null;
      const [wx, wy] = this.view.screenToWorld(g.sx, g.sy);
      this.gesture = null;
      this.onPreview(null);
      this.onPick(g.tool, wx, wy, yaw);
      return;
    }
    if (g?.kind === "pick") this.cancelPick();
    if (this.pointers.size === 1 && g?.kind === "pinch") {
      const [[, p]] = this.pointers;
      this.gesture = { kind: "pan", x: p.x, y: p.y }; // lifting one finger keeps panning with the other
    } else if (this.pointers.size === 0) {
      this.gesture = null;
    }
  }

  wheel(e) {
    e.preventDefault();
    const [x, y] = this.local(e);
    const pixels = e.deltaMode === 1 ? e.deltaY * 16 : e.deltaY;
    this.view.zoomAt(x, y, Math.exp(-pixels * WHEEL_ZOOM_PER_PIXEL));
    this.onViewChange();
  }

  pinchState() {
    const [a, b] = [...this.pointers.values()];
    return { mx: (a.x + b.x) / 2, my: (a.y + b.y) / 2, dist: Math.hypot(a.x - b.x, a.y - b.y) };
  }

  preview(sx, sy, yaw) {
    const [x, y] = this.view.screenToWorld(sx, sy);
    this.onPreview({ kind: this.gesture.tool, x, y, yaw });
  }

  cancelPick() {
    if (this.gesture?.kind === "pick") {
      this.gesture = null;
      this.onPreview(null);
    }
  }
}
