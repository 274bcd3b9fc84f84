// The map view: world (metres, REP-103: x right, y UP, yaw counter-clockwise) <-> screen (CSS pixels,
// y down). The view keeps the world point shown at the centre of the canvas and a scale in pixels per
// metre; panning moves the centre, zooming changes the scale about a fixed screen point.

export const MIN_SCALE = 2; // px per metre: a whole house on a phone
export const MAX_SCALE = 800; // px per metre: single cells of a 5 cm grid are 40 px wide
export const DEFAULT_SCALE = 40;

export class View {
  constructor(width = 1, height = 1) {
    this.width = width;
    this.height = height;
    this.cx = 0; // world x at the canvas centre
    this.cy = 0; // world y at the canvas centre
    this.scale = DEFAULT_SCALE;
  }

  resize(width, height) {
    this.width = width;
    this.height = height;
  }

  worldToScreen(x, y) {
    return [this.width / 2 + (x - this.cx) * this.scale, this.height / 2 - (y - this.cy) * this.scale];
  }

  screenToWorld(sx, sy) {
    return [this.cx + (sx - this.width / 2) / this.scale, this.cy - (sy - this.height / 2) / this.scale];
  }

  // A yaw (CCW from +x) as the canvas angle (clockwise from +x because the canvas y axis points down).
  static yawToScreenAngle(yaw) {
    return -yaw;
  }

  // The yaw of the world direction from screen point a to screen point b.
  static screenDirectionToYaw(ax, ay, bx, by) {
    return Math.atan2(ay - by, bx - ax);
  }

  // The canvas transform that draws world coordinates directly: ctx.setTransform(...view.matrix(dpr)).
  matrix(dpr = 1) {
    const s = this.scale * dpr;
    return [s, 0, 0, -s, (this.width / 2 - this.cx * this.scale) * dpr, (this.height / 2 + this.cy * this.scale) * dpr];
  }

  panBy(dxPixels, dyPixels) {
    this.cx -= dxPixels / this.scale;
    this.cy += dyPixels / this.scale;
  }

  // Multiply the scale by `factor`, keeping the world point under screen point (sx, sy) where it is.
  zoomAt(sx, sy, factor) {
    const [wx, wy] = this.screenToWorld(sx, sy);
    this.scale = Math.min(MAX_SCALE, Math.max(MIN_SCALE, this.scale * factor));
    this.cx = wx - (sx - this.width / 2) / this.scale;
    this.cy = wy + (sy - this.height / 2) / this.scale;
  }

  centerOn(x, y) {
    this.cx = x;
    this.cy = y;
  }

  // Fit the world rectangle [x0, x1] x [y0, y1] into the canvas with a margin in pixels, leaving `top`
  // pixels free above it (for the toolbar drawn over the map).
  fit(x0, y0, x1, y1, margin = 20, top = 0) {
    const w = Math.max(x1 - x0, 1e-6);
    const h = Math.max(y1 - y0, 1e-6);
    const sx = (this.width - 2 * margin) / w;
    const sy = (this.height - 2 * margin - top) / h;
    this.scale = Math.min(MAX_SCALE, Math.max(MIN_SCALE, Math.min(sx, sy)));
    this.centerOn((x0 + x1) / 2, (y0 + y1) / 2);
    this.panBy(0, top / 2);
  }

  // The world rectangle visible on the canvas, [x0, y0, x1, y1].
  visibleWorld() {
    const [x0, y1] = this.screenToWorld(0, 0);
    const [x1, y0] = this.screenToWorld(this.width, this.height);
    return [x0, y0, x1, y1];
  }
}
