// The map as the browser keeps it: one offscreen canvas per 64x64-cell tile, filled from decoded map
// frames (mapframe.js), and blitted into one offscreen image of the whole map. A FULL frame replaces
// every tile; a delta repaints only the tiles it carries. The map image is drawn in world coordinates
// (view.matrix) with one drawImage, so pan, zoom and the 15 Hz redraws cost no re-decoding.

import { UNKNOWN } from "./mapframe.js";

const UNKNOWN_RGBA = [205, 210, 216, 255];
const FREE_RGB = [252, 252, 250];
const OCCUPIED_RGB = [33, 37, 48];
const RAMP_FROM = 20; // percent
const RAMP_TO = 80;

// Cell value (0..100 percent occupied, 255 unknown) -> packed little-endian RGBA (for a Uint32Array).
function buildPalette() {
  const palette = new Uint32Array(256);
  const pack = (r, g, b, a) => ((a << 24) | (b << 16) | (g << 8) | r) >>> 0;
  palette.fill(pack(...UNKNOWN_RGBA));
  for (let p = 0; p <= 100; p++) {
    // Likely free (<= 20 %) shows white, likely occupied (>= 80 %) dark, a ramp between: cells the
    // robot has seen only a few times stay clearly apart from the unknown colour.
    const t = Math.min(1, Math.max(0, (p - RAMP_FROM) / (RAMP_TO - RAMP_FROM)));
    const rgb = FREE_RGB.map((free, k) => Math.round(free + (OCCUPIED_RGB[k] - free) * t));
    palette[p] = pack(rgb[0], rgb[1], rgb[2], 255);
  }
  return palette;
}

export const PALETTE = buildPalette();
export const UNKNOWN_COLOR = UNKNOWN_RGBA;

function makeCanvas(width, height) {
  if (typeof OffscreenCanvas !== "undefined") return new OffscreenCanvas(width, height);
  const canvas = document.createElement("canvas");
  canvas.width = width;
  canvas.height = height;
  return canvas;
}

const UNKNOWN_CSS = `rgb(${UNKNOWN_RGBA.slice(0, 3).join(",")})`;

export class MapTiles {
  constructor() {
    this.image = null; // the whole map, tilesX*T x tilesY*T pixels, row 0 = smallest y
    this.clear();
  }

  clear() {
    this.tiles = new Map(); // tile index -> {tx, ty, canvas, cells, known, box}; only tiles with known cells
    this.spare = []; // canvases of dropped tiles, for re-use
    this.meta = null; // {tileSize, resolution, originX, originY, width, height, tilesX, tilesY, seq}
    this.version = 0; // bumps on every applied frame (the renderer redraws when it changes)
  }

  get ready() {
    return this.meta !== null;
  }

  // Apply a decoded frame; returns false for a delta that does not fit the current map (dropped).
  apply(frame) {
    if (frame.full) {
      // Canvases of the old tiles are re-used for the new ones (a full frame follows every growth).
      for (const t of this.tiles.values()) if (t.canvas.width === frame.tileSize) this.spare.push(t.canvas);
      this.tiles = new Map();
      this.meta = {
        tileSize: frame.tileSize,
        resolution: frame.resolution,
        originX: frame.originX,
        originY: frame.originY,
        width: frame.width,
        height: frame.height,
        tilesX: frame.tilesX,
        tilesY: frame.tilesY,
        seq: frame.seq,
      };
      this._resetImage();
    } else {
      const m = this.meta;
      const fits =
        m !== null &&
        m.tileSize === frame.tileSize &&
        m.width === frame.width &&
        m.height === frame.height &&
        m.originX === frame.originX &&
        m.originY === frame.originY;
      if (!fits) return false;
      m.seq = frame.seq;
    }
    for (const tile of frame.tiles) this._paint(tile);
    this.version++;
    return true;
  }

  _resetImage() {
    const { tilesX, tilesY, tileSize } = this.meta;
    const [w, h] = [tilesX * tileSize, tilesY * tileSize];
    if (!this.image || this.image.width !== w || this.image.height !== h) this.image = makeCanvas(w, h);
    const ctx = this.image.getContext("2d");
    ctx.fillStyle = UNKNOWN_CSS;
    ctx.fillRect(0, 0, w, h);
  }

  _paint({ index, tx, ty, cells }) {
    const size = this.meta.tileSize;
    let known = 0;
    const box = [size, size, -1, -1]; // known cells' [ix0, iy0, ix1, iy1] inside the tile
    for (let i = 0; i < cells.length; i++) {
      if (cells[i] === UNKNOWN) continue;
      known++;
      const ix = i % size;
      const iy = (i - ix) / size;
      if (ix < box[0]) box[0] = ix;
      if (iy < box[1]) box[1] = iy;
      if (ix > box[2]) box[2] = ix;
      if (iy > box[3]) box[3] = iy;
    }
    const mapImage = this.image.getContext("2d");
    let entry = this.tiles.get(index);
    if (known === 0) {
      // Nothing known: no tile canvas, the map image shows the unknown colour there.
      if (entry) this.spare.push(entry.canvas);
      this.tiles.delete(index);
      mapImage.fillStyle = UNKNOWN_CSS;
      mapImage.fillRect(tx * size, ty * size, size, size);
      return;
    }
    if (!entry) {
      entry = { tx, ty, canvas: this.spare.pop() ?? makeCanvas(size, size), cells: null, known: 0 };
      this.tiles.set(index, entry);
    }
    const image = new ImageData(size, size);
    const pixels = new Uint32Array(image.data.buffer);
    for (let i = 0; i < cells.length; i++) pixels[i] = PALETTE[cells[i]];
    // Row 0 of the tile is its smallest y; the world transform (y up) puts image row 0 at the bottom.
    entry.canvas.getContext("2d").putImageData(image, 0, 0);
    mapImage.putImageData(image, tx * size, ty * size);
    entry.box = box;
    entry.known = known;
    entry.cells = Uint8Array.from(cells); // the frame's buffer is not kept
  }

  // The cell value (0..100, 255 unknown) at world point (x, y); 255 outside the map.
  cellAt(x, y) {
    const m = this.meta;
    if (!m) return UNKNOWN;
    const ix = Math.floor((x - m.originX) / m.resolution);
    const iy = Math.floor((y - m.originY) / m.resolution);
    if (ix < 0 || iy < 0 || ix >= m.width || iy >= m.height) return UNKNOWN;
    const tx = Math.floor(ix / m.tileSize);
    const ty = Math.floor(iy / m.tileSize);
    const tile = this.tiles.get(ty * m.tilesX + tx);
    if (!tile) return UNKNOWN;
    return tile.cells[(iy - ty * m.tileSize) * m.tileSize + (ix - tx * m.tileSize)];
  }

  // World rectangle [x0, y0, x1, y1] covered by the map, or null before the first full frame.
  bounds() {
    const m = this.meta;
    if (!m) return null;
    return [m.originX, m.originY, m.originX + m.width * m.resolution, m.originY + m.height * m.resolution];
  }

  // World rectangle of the known cells (for "fit map"), or the whole map when nothing is known.
  knownBounds() {
    const m = this.meta;
    if (!m) return null;
    let x0 = Infinity;
    let y0 = Infinity;
    let x1 = -Infinity;
    let y1 = -Infinity;
    for (const t of this.tiles.values()) {
      if (t.known === 0) continue;
      const ix = t.tx * m.tileSize;
      const iy = t.ty * m.tileSize;
      x0 = Math.min(x0, ix + t.box[0]);
      y0 = Math.min(y0, iy + t.box[1]);
      x1 = Math.max(x1, ix + t.box[2] + 1);
      y1 = Math.max(y1, iy + t.box[3] + 1);
    }
    if (x0 === Infinity) return this.bounds();
    const r = m.resolution;
    return [m.originX + x0 * r, m.originY + y0 * r, m.originX + x1 * r, m.originY + y1 * r];
  }

  // Draw the map (its W x H cells; the padding of edge tiles is cropped). ctx carries the world
  // transform (view.matrix), so the image's row 0 lands at the map's smallest y.
  draw(ctx) {
    const m = this.meta;
    if (!m) return;
    ctx.save();
    ctx.imageSmoothingEnabled = false;
    const r = m.resolution;
    ctx.drawImage(this.image, 0, 0, m.width, m.height, m.originX, m.originY, m.width * r, m.height * r);
    ctx.restore();
  }
}
