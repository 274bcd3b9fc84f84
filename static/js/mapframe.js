// Decoder for the server's binary map frame (app/streaming/PROTOCOL.md, "Binary map frame"):
// a 44-byte little-endian header `<BBHIdddIII` followed by N records of uint32 tile index + T*T
// uint8 cells (0..100 occupancy percent, 255 unknown), optionally zlib-compressed.

export const MAP_MESSAGE_TYPE = 1;
export const HEADER_BYTES = 44;
export const FLAG_FULL = 1;
export const FLAG_ZLIB = 2;
export const UNKNOWN = 255;

export class MapFrameError extends Error {}

// The header fields of a map frame (no payload decoding).
export function parseHeader(buffer) {
  if (buffer.byteLength < HEADER_BYTES) {
    throw new MapFrameError(`map frame is ${buffer.byteLength} bytes, shorter than its ${HEADER_BYTES}-byte header`);
  }
  const view = new DataView(buffer);
  const type = view.getUint8(0);
  if (type !== MAP_MESSAGE_TYPE) throw new MapFrameError(`binary frame of unknown type ${type} (map frames are 1)`);
  const flags = view.getUint8(1);
  const header = {
    full: (flags & FLAG_FULL) !== 0,
    zlib: (flags & FLAG_ZLIB) !== 0,
    tileSize: view.getUint16(2, true),
    seq: view.getUint32(4, true),
    resolution: view.getFloat64(8, true),
    originX: view.getFloat64(16, true),
    originY: view.getFloat64(24, true),
    width: view.getUint32(32, true),
    height: view.getUint32(36, true),
    count: view.getUint32(40, true),
  };
  if (header.tileSize === 0) throw new MapFrameError("map frame has tile size 0");
  if (!(header.resolution > 0)) throw new MapFrameError(`map frame has resolution ${header.resolution} (must be > 0)`);
  header.tilesX = Math.ceil(header.width / header.tileSize);
  header.tilesY = Math.ceil(header.height / header.tileSize);
  return header;
}

// zlib (RFC 1950) inflate with the browser's own DecompressionStream ("deflate" is the zlib format).
export async function inflate(bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate"));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

// Split an (uncompressed) payload into tiles: [{index, tx, ty, cells}], cells a T*T Uint8Array view.
export function splitTiles(header, payload) {
  const cellsPerTile = header.tileSize * header.tileSize;
  const record = 4 + cellsPerTile;
  if (payload.byteLength !== header.count * record) {
    throw new MapFrameError(
      `map frame payload is ${payload.byteLength} bytes; ${header.count} tiles of ${header.tileSize}x${header.tileSize} need ${header.count * record}`,
    );
  }
  const view = new DataView(payload.buffer, payload.byteOffset, payload.byteLength);
  const tiles = [];
  for (let i = 0; i < header.count; i++) {
    const offset = i * record;
    const index = view.getUint32(offset, true);
    const tx = index % header.tilesX;
    const ty = Math.floor(index / header.tilesX);
    if (ty >= header.tilesY) {
      throw new MapFrameError(`tile index ${index} is outside the ${header.tilesX}x${header.tilesY} tile grid`);
    }
    tiles.push({ index, tx, ty, cells: payload.subarray(offset + 4, offset + 4 + cellsPerTile) });
  }
  return tiles;
}

// Decode a whole binary map frame: the header fields plus `tiles`.
export async function decodeMapFrame(buffer) {
  const header = parseHeader(buffer);
  let payload = new Uint8Array(buffer, HEADER_BYTES);
  if (header.zlib) payload = await inflate(payload);
  return { ...header, tiles: splitTiles(header, payload) };
}

// Build a map frame (the inverse of decodeMapFrame, uncompressed): used by the browser checks of the
// decoder and handy for replaying frames offline.
export function encodeMapFrame({ full, tileSize, seq, resolution, originX, originY, width, height, tiles }) {
  const cellsPerTile = tileSize * tileSize;
  const buffer = new ArrayBuffer(HEADER_BYTES + tiles.length * (4 + cellsPerTile));
  const view = new DataView(buffer);
  view.setUint8(0, MAP_MESSAGE_TYPE);
  view.setUint8(1, full ? FLAG_FULL : 0);
  view.setUint16(2, tileSize, true);
  view.setUint32(4, seq, true);
  view.setFloat64(8, resolution, true);
  view.setFloat64(16, originX, true);
  view.setFloat64(24, originY, true);
  view.setUint32(32, width, true);
  view.setUint32(36, height, true);
  view.setUint32(40, tiles.length, true);
  const bytes = new Uint8Array(buffer);
  tiles.forEach((tile, i) => {
    const offset = HEADER_BYTES + i * (4 + cellsPerTile);
    view.setUint32(offset, tile.index, true);
    bytes.set(tile.cells, offset + 4);
  });
  return buffer;
}
