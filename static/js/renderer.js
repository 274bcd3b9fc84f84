// Draws the state on the map canvas: map tiles in world coordinates, then everything else in screen
// pixels (so markers keep their size at any zoom). Redraws only when the state or the view changed.

import { covarianceEllipse } from "./geometry.js";
import { View } from "./view.js";

const MIN_ROBOT_RADIUS_PX = 9;
const COLORS = {
  background: "#e8ebef",
  grid: "rgba(40, 60, 90, 0.09)",
  particle: "rgba(232, 93, 4, 0.55)",
  scan: "rgba(220, 38, 38, 0.85)",
  path: "#2563eb",
  goal: "#2563eb",
  robot: "#0f766e",
  robotLost: "#b45309",
  landmark: "#7c3aed",
  place: "#be185d",
  preview: "#2563eb",
  previewPose: "#0f766e",
  scaleBacking: "rgba(255, 255, 255, 0.8)",
};

export class Renderer {
  constructor(canvas, state, view = new View()) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.state = state;
    this.view = view;
    this.preview = null; // {kind: "goal" | "pose" | "place", x, y, yaw | null}
    this.dpr = 1;
    this.viewChanged = true;
    this.frames = 0;
    this.layers = { scan: true, particles: true, path: true, landmarks: true, places: true };
    this.overlays = []; // objects with drawWorld(ctx) (map transform) and drawScreen(ctx, view) (pixels)
  }

  showLayer(name, visible) {
    this.layers[name] = visible;
    this.viewChanged = true;
  }

  resize() {
    const rect = this.canvas.getBoundingClientRect();
    this.dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(rect.width * this.dpr));
    const h = Math.max(1, Math.round(rect.height * this.dpr));
    if (this.canvas.width !== w || this.canvas.height !== h) {
      this.canvas.width = w;
      this.canvas.height = h;
    }
    this.view.resize(rect.width, rect.height);
    this.viewChanged = true;
  }

  invalidate() {
    this.viewChanged = true;
  }

  // Draw when anything changed; called from requestAnimationFrame.
  frame() {
    if (!this.viewChanged && !this.state.dirty) return false;
    this.viewChanged = false;
    this.state.dirty = false;
    this.draw();
    this.frames++;
    return true;
  }

  draw() {
    const { ctx, view, state, dpr } = this;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = COLORS.background;
    ctx.fillRect(0, 0, this.canvas.width, this.canvas.height);

    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    this.drawGrid(); // under the map: it shows only where there is no map
    ctx.setTransform(...view.matrix(dpr));
    state.map.draw(ctx);
    for (const overlay of this.overlays) overlay.drawWorld(ctx);

    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    for (const overlay of this.overlays) overlay.drawScreen(ctx, view);
    const layers = this.layers;
    if (layers.landmarks) this.drawLandmarks();
    if (layers.scan) this.drawScan();
    if (layers.particles) this.drawParticles();
    if (layers.path) this.drawPath();
    this.drawRobot();
    if (layers.places) this.drawPlaces(); // labels stay readable over the robot
    this.drawPreview();
    this.drawScaleBar();
  }

  // Metre grid lines when zoomed in far enough for them to help.
  drawGrid() {
    const { ctx, view } = this;
    const step = view.scale >= 25 ? 1 : view.scale >= 6 ? 5 : 0;
    if (!step) return;
    const [x0, y0, x1, y1] = view.visibleWorld();
    ctx.strokeStyle = COLORS.grid;
    ctx.lineWidth = 1;
    ctx.beginPath();
    for (let x = Math.ceil(x0 / step) * step; x <= x1; x += step) {
      const [sx] = view.worldToScreen(x, 0);
      ctx.moveTo(Math.round(sx) + 0.5, 0);
      ctx.lineTo(Math.round(sx) + 0.5, view.height);
    }
    for (let y = Math.ceil(y0 / step) * step; y <= y1; y += step) {
      const [, sy] = view.worldToScreen(0, y);
      ctx.moveTo(0, Math.round(sy) + 0.5);
      ctx.lineTo(view.width, Math.round(sy) + 0.5);
    }
    ctx.stroke();
  }

  drawParticles() {
    const { ctx, view } = this;
    const particles = this.state.particles;
    if (!particles.length) return;
    ctx.fillStyle = COLORS.particle;
    ctx.strokeStyle = COLORS.particle;
    ctx.lineWidth = 1;
    const tick = view.scale > 60 ? 6 : 0; // heading ticks only when zoomed in
    ctx.beginPath();
    for (const [x, y, yaw] of particles) {
      const [sx, sy] = view.worldToScreen(x, y);
      ctx.rect(sx - 1.5, sy - 1.5, 3, 3);
      if (tick) {
        ctx.moveTo(sx, sy);
        ctx.lineTo(sx + tick * Math.cos(yaw), sy - tick * Math.sin(yaw));
      }
    }
    ctx.fill();
    if (tick) ctx.stroke();
  }

  drawScan() {
    const { ctx, view } = this;
    const scan = this.state.scan;
    if (!scan || !scan.points.length) return;
    const [ox, oy] = view.worldToScreen(scan.pose[0], scan.pose[1]);
    ctx.strokeStyle = "rgba(220, 38, 38, 0.07)";
    ctx.lineWidth = 1;
    ctx.beginPath();
    for (const [x, y] of scan.points) {
      const [sx, sy] = view.worldToScreen(x, y);
      ctx.moveTo(ox, oy);
      ctx.lineTo(sx, sy);
    }
    ctx.stroke();
    ctx.fillStyle = COLORS.scan;
    ctx.beginPath();
    for (const [x, y] of scan.points) {
      const [sx, sy] = view.worldToScreen(x, y);
      ctx.rect(sx - 1.5, sy - 1.5, 3, 3);
    }
    ctx.fill();
  }

  drawPath() {
    const { ctx, view } = this;
    const { path, goal } = this.state.path;
    if (path.length >= 2) {
      ctx.strokeStyle = COLORS.path;
      ctx.lineWidth = 3;
      ctx.lineJoin = "round";
      ctx.lineCap = "round";
      ctx.beginPath();
      path.forEach(([x, y], i) => {
        const [sx, sy] = view.worldToScreen(x, y);
        if (i === 0) ctx.moveTo(sx, sy);
        else ctx.lineTo(sx, sy);
      });
      ctx.stroke();
    }
    if (goal) {
      const [sx, sy] = view.worldToScreen(goal.x, goal.y);
      this.drawFlag(sx, sy, COLORS.goal, this.state.goalYaw());
    }
  }

  drawFlag(sx, sy, color, yaw) {
    const { ctx } = this;
    ctx.strokeStyle = color;
    ctx.fillStyle = color;
    ctx.lineWidth = 2.5;
    ctx.beginPath();
    ctx.arc(sx, sy, 8, 0, 2 * Math.PI);
    ctx.stroke();
    ctx.beginPath();
    ctx.arc(sx, sy, 3, 0, 2 * Math.PI);
    ctx.fill();
    if (yaw !== null && yaw !== undefined) this.drawArrow(sx, sy, yaw, 26, color);
  }

  drawArrow(sx, sy, yaw, length, color) {
    const { ctx } = this;
    const a = View.yawToScreenAngle(yaw);
    const ex = sx + length * Math.cos(a);
    const ey = sy + length * Math.sin(a);
    ctx.strokeStyle = color;
    ctx.fillStyle = color;
    ctx.lineWidth = 2.5;
    ctx.beginPath();
    ctx.moveTo(sx, sy);
    ctx.lineTo(ex, ey);
    ctx.stroke();
    ctx.beginPath();
    ctx.moveTo(ex + 9 * Math.cos(a), ey + 9 * Math.sin(a));
    ctx.lineTo(ex + 7 * Math.cos(a + 2.3), ey + 7 * Math.sin(a + 2.3));
    ctx.lineTo(ex + 7 * Math.cos(a - 2.3), ey + 7 * Math.sin(a - 2.3));
    ctx.closePath();
    ctx.fill();
  }

  drawRobot() {
    const pose = this.state.pose;
    if (!pose) return;
    this.drawRobotAt(pose.x, pose.y, pose.yaw, pose.localized === false ? COLORS.robotLost : COLORS.robot, 1);
  }

  // The robot: a disc of its real size (the robot file's footprint radius; at least MIN_ROBOT_RADIUS_PX)
  // with an arrow along its heading.
  drawRobotAt(x, y, yaw, color, alpha) {
    const { ctx, view } = this;
    const [sx, sy] = view.worldToScreen(x, y);
    const radius = this.state.robot?.footprint_radius ?? 0;
    const r = Math.max(MIN_ROBOT_RADIUS_PX, radius * view.scale);
    const a = View.yawToScreenAngle(yaw);
    ctx.save();
    ctx.globalAlpha = alpha;
    ctx.fillStyle = color;
    ctx.strokeStyle = "#ffffff";
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.arc(sx, sy, r, 0, 2 * Math.PI);
    ctx.fill();
    ctx.stroke();
    ctx.fillStyle = "#ffffff";
    ctx.beginPath();
    ctx.moveTo(sx + 0.85 * r * Math.cos(a), sy + 0.85 * r * Math.sin(a));
    ctx.lineTo(sx + 0.6 * r * Math.cos(a + 2.5), sy + 0.6 * r * Math.sin(a + 2.5));
    ctx.lineTo(sx + 0.25 * r * Math.cos(a + Math.PI), sy + 0.25 * r * Math.sin(a + Math.PI));
    ctx.lineTo(sx + 0.6 * r * Math.cos(a - 2.5), sy + 0.6 * r * Math.sin(a - 2.5));
    ctx.closePath();
    ctx.fill();
    ctx.restore();
  }

  drawLandmarks() {
    const { ctx, view } = this;
    const { landmarks, covariances } = this.state.landmarks;
    if (!landmarks.length) return;
    ctx.strokeStyle = COLORS.landmark;
    ctx.fillStyle = COLORS.landmark;
    ctx.lineWidth = 1.5;
    landmarks.forEach(([x, y], i) => {
      const [sx, sy] = view.worldToScreen(x, y);
      const cov = covariances[i];
      if (cov) {
        const { a, b, angle } = covarianceEllipse(cov);
        ctx.beginPath();
        ctx.ellipse(sx, sy, Math.max(a * view.scale, 1), Math.max(b * view.scale, 1), View.yawToScreenAngle(angle), 0, 2 * Math.PI);
        ctx.stroke();
      }
      ctx.beginPath();
      ctx.moveTo(sx - 4, sy);
      ctx.lineTo(sx + 4, sy);
      ctx.moveTo(sx, sy - 4);
      ctx.lineTo(sx, sy + 4);
      ctx.stroke();
    });
  }

  drawPlaces() {
    const { ctx, view } = this;
    ctx.font = "600 12px system-ui, sans-serif";
    ctx.textBaseline = "middle";
    for (const place of this.state.places) {
      const [sx, sy] = view.worldToScreen(place.x, place.y);
      ctx.fillStyle = COLORS.place;
      ctx.beginPath();
      ctx.moveTo(sx, sy);
      ctx.arc(sx, sy - 14, 6, Math.PI * 0.8, Math.PI * 0.2);
      ctx.closePath();
      ctx.fill();
      ctx.fillStyle = "#ffffff";
      ctx.beginPath();
      ctx.arc(sx, sy - 14, 2.5, 0, 2 * Math.PI);
      ctx.fill();
      const width = ctx.measureText(place.name).width;
      ctx.fillStyle = "rgba(255, 255, 255, 0.85)";
      ctx.fillRect(sx + 8, sy - 22, width + 8, 16);
      ctx.fillStyle = COLORS.place;
      ctx.fillText(place.name, sx + 12, sy - 14);
    }
  }

  // What the user is dragging right now: a goal arrow, a pose to set, a place to add.
  drawPreview() {
    const p = this.preview;
    if (!p) return;
    const [sx, sy] = this.view.worldToScreen(p.x, p.y);
    if (p.kind === "pose") this.drawRobotAt(p.x, p.y, p.yaw ?? 0, COLORS.previewPose, 0.6);
    else this.drawFlag(sx, sy, p.kind === "place" ? COLORS.place : COLORS.preview, p.yaw);
  }

  drawScaleBar() {
    const { ctx, view } = this;
    const target = 90 / view.scale; // metres in ~90 px
    const magnitude = 10 ** Math.floor(Math.log10(target));
    const metres = [1, 2, 5, 10].map((k) => k * magnitude).filter((m) => m <= target).pop() ?? magnitude;
    const px = metres * view.scale;
    const x = 12;
    const y = view.height - 14;
    const label = metres >= 1 ? `${metres} m` : `${Math.round(metres * 100)} cm`;
    ctx.font = "11px system-ui, sans-serif";
    ctx.fillStyle = COLORS.scaleBacking; // legible over walls and the scan as over free space
    ctx.fillRect(x - 5, y - 18, Math.max(px, ctx.measureText(label).width + 4) + 10, 23);
    ctx.strokeStyle = "#1f2937";
    ctx.fillStyle = "#1f2937";
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(x, y - 5);
    ctx.lineTo(x, y);
    ctx.lineTo(x + px, y);
    ctx.lineTo(x + px, y - 5);
    ctx.stroke();
    ctx.textBaseline = "bottom";
    ctx.fillText(label, x + 4, y - 3);
  }
}
