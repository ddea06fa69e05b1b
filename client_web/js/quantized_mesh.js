// A quantized-mesh-1.0 decoder written from the specification
// (https://github.com/CesiumGS/quantized-mesh and docs/quantized-mesh.md, which says what the
// server writes): the header, zig-zag delta vertex data, high-water-mark indices (16- or 32-bit),
// the four edge lists and the extensions (oct-encoded normals, water mask, metadata). It reads
// nothing past the input and throws on anything malformed, so a bad tile is an error message,
// not garbage on the screen. Plain JavaScript without DOM access: it runs in the browser and
// in Node (the tests use it there too).

export const EXTENSION_OCT_NORMALS = 1;
export const EXTENSION_WATER_MASK = 2;
export const EXTENSION_METADATA = 4;

const HEADER_BYTES = 88;  // centre (3 doubles), min/max height (2 floats), sphere (4), horizon (3)

export class QuantizedMeshError extends Error {}

// Sequential little-endian reads that refuse to run past the end.
class Reader {
  constructor(buffer) {
    this.view = new DataView(buffer.buffer ?? buffer, buffer.byteOffset ?? 0, buffer.byteLength);
    this.offset = 0;
  }

  need(bytes, what) {
    if (this.offset + bytes > this.view.byteLength) {
      throw new QuantizedMeshError(`truncated tile: ${what} needs ${bytes} bytes at ${this.offset}, ` +
        `${this.view.byteLength - this.offset} left`);
    }
  }

  u8(what) { this.need(1, what); return this.view.getUint8(this.offset++); }
  u16(what) { this.need(2, what); const v = this.view.getUint16(this.offset, true); this.offset += 2; return v; }
  u32(what) { this.need(4, what); const v = this.view.getUint32(this.offset, true); this.offset += 4; return v; }
  f32(what) { this.need(4, what); const v = this.view.getFloat32(this.offset, true); this.offset += 4; return v; }
  f64(what) { this.need(8, what); const v = this.view.getFloat64(this.offset, true); this.offset += 8; return v; }

  bytes(count, what) {
    this.need(count, what);
    const out = new Uint8Array(this.view.buffer, this.view.byteOffset + this.offset, count).slice();
    this.offset += count;
    return out;
  }
}

function zigZag(value) {
  return (value >> 1) ^ -(value & 1);
}

/// Decodes one tile. `bytes` is an ArrayBuffer or Uint8Array of the (already un-gzipped) tile.
/// Returns { header, vertexCount, u, v, k, heights, indices, edges: { west, south, east, north },
/// normals (Float32Array, 3 per vertex, or null), waterMask (Uint8Array of 1 or 65 536 bytes,
/// or null), metadata (parsed JSON or null), unknownExtensions }.
/// `u`, `v` are 0..32767 across the tile (v grows north), `k` the quantized heights and `heights`
/// metres: h = m + (M − m)·k/32767 evaluated in the order docs/quantized-mesh.md §2.2 makes exact.
export function decodeQuantizedMesh(bytes) {
  const r = new Reader(bytes instanceof ArrayBuffer ? new Uint8Array(bytes) : bytes);
  r.need(HEADER_BYTES, 'the header');
  const header = {
    center: [r.f64(), r.f64(), r.f64()],
    minimumHeight: r.f32(),
    maximumHeight: r.f32(),
    boundingSphere: { center: [r.f64(), r.f64(), r.f64()], radius: r.f64() },
    horizonOcclusionPoint: [r.f64(), r.f64(), r.f64()],
  };
  const finite = [...header.center, header.minimumHeight, header.maximumHeight,
    ...header.boundingSphere.center, header.boundingSphere.radius, ...header.horizonOcclusionPoint];
  if (!finite.every(Number.isFinite)) throw new QuantizedMeshError('non-finite value in the header');
  if (header.minimumHeight > header.maximumHeight) throw new QuantizedMeshError('minimum height above the maximum');
  if (header.boundingSphere.radius < 0) throw new QuantizedMeshError('negative bounding sphere radius');

  // Vertex data: three arrays (u, then v, then height) of zig-zag encoded deltas.
  const vertexCount = r.u32('the vertex count');
  r.need(vertexCount * 6, 'the vertex data');
  const u = new Uint16Array(vertexCount);
  const v = new Uint16Array(vertexCount);
  const k = new Uint16Array(vertexCount);
  for (const [array, name] of [[u, 'u'], [v, 'v'], [k, 'height']]) {
    let value = 0;
    for (let i = 0; i < vertexCount; ++i) {
      value += zigZag(r.u16(name));
      if (value < 0 || value > 32767) throw new QuantizedMeshError(`${name} of vertex ${i} decodes to ${value}, outside 0..32767`);
      array[i] = value;
    }
  }
  const m = header.minimumHeight;
  const range = header.maximumHeight - header.minimumHeight;
  const heights = new Float64Array(vertexCount);
  for (let i = 0; i < vertexCount; ++i) heights[i] = Math.fround(Math.fround(Math.fround(range * k[i]) / 32767) + m);

  // Indices: 32-bit (aligned to 4 bytes) when the vertices do not fit 16 bits.
  const wide = vertexCount > 65536;
  if (wide && r.offset % 4 !== 0) r.offset += 4 - (r.offset % 4);
  const readIndex = wide ? (w) => r.u32(w) : (w) => r.u16(w);
  const width = wide ? 4 : 2;
  const triangleCount = r.u32('the triangle count');
  r.need(triangleCount * 3 * width, 'the triangle indices');
  const indices = wide ? new Uint32Array(triangleCount * 3) : new Uint16Array(triangleCount * 3);
  let highest = 0;
  for (let i = 0; i < indices.length; ++i) {
    const code = readIndex('an index');
    if (code > highest) throw new QuantizedMeshError(`index code ${code} above the high-water mark ${highest}`);
    const index = highest - code;
    if (index >= vertexCount) throw new QuantizedMeshError(`index ${index} out of range (${vertexCount} vertices)`);
    indices[i] = index;
    if (code === 0) ++highest;
  }

  // Edge lists: plain indices (no high-water-mark code), west, south, east, north.
  const edges = {};
  for (const side of ['west', 'south', 'east', 'north']) {
    const count = r.u32(`the ${side} edge count`);
    r.need(count * width, `the ${side} edge`);
    const list = wide ? new Uint32Array(count) : new Uint16Array(count);
    for (let i = 0; i < count; ++i) {
      list[i] = readIndex(`the ${side} edge`);
      if (list[i] >= vertexCount) throw new QuantizedMeshError(`${side} edge index ${list[i]} out of range`);
    }
    edges[side] = list;
  }

  // Extensions: id (uint8), length (uint32), data.
  let normals = null;
  let waterMask = null;
  let metadata = null;
  const unknownExtensions = [];
  const seen = new Set();
  while (r.offset < r.view.byteLength) {
    const id = r.u8('an extension id');
    const length = r.u32('an extension length');
    if (seen.has(id)) throw new QuantizedMeshError(`extension ${id} appears twice`);
    seen.add(id);
    const data = r.bytes(length, `extension ${id}`);
    if (id === EXTENSION_OCT_NORMALS) {
      if (length !== 2 * vertexCount) throw new QuantizedMeshError(`normals extension has ${length} bytes for ${vertexCount} vertices`);
      normals = new Float32Array(3 * vertexCount);
      for (let i = 0; i < vertexCount; ++i) octDecode(data[2 * i], data[2 * i + 1], normals, 3 * i);
    } else if (id === EXTENSION_WATER_MASK) {
      if (length !== 1 && length !== 65536) throw new QuantizedMeshError(`water mask of ${length} bytes (1 or 65 536 expected)`);
      waterMask = data;
    } else if (id === EXTENSION_METADATA) {
      if (length < 4) throw new QuantizedMeshError('metadata extension too short');
      const jsonLength = new DataView(data.buffer).getUint32(0, true);
      if (jsonLength + 4 !== length) throw new QuantizedMeshError('metadata length disagrees with its JSON length');
      try {
        metadata = JSON.parse(new TextDecoder().decode(data.subarray(4)));
      } catch (e) {
        throw new QuantizedMeshError(`metadata JSON does not parse: ${e.message}`);
      }
    } else {
      unknownExtensions.push(id);
    }
  }
  return { header, vertexCount, u, v, k, heights, indices, edges, normals, waterMask, metadata, unknownExtensions };
}

/// Cesium's AttributeCompression.octDecode of two bytes into a unit vector written at out[at..].
export function octDecode(xByte, yByte, out, at) {
  let x = (xByte / 255) * 2 - 1;
  let y = (yByte / 255) * 2 - 1;
  const z = 1 - Math.abs(x) - Math.abs(y);
  if (z < 0) {
    const ox = x;
    x = (1 - Math.abs(y)) * (ox >= 0 ? 1 : -1);
    y = (1 - Math.abs(ox)) * (y >= 0 ? 1 : -1);
  }
  const l = Math.hypot(x, y, z);
  out[at] = x / l;
  out[at + 1] = y / l;
  out[at + 2] = z / l;
}
