// The browser's quantized-mesh decoder (client_web/js/quantized_mesh.js) on tiles written here
// byte by byte from the specification: what it decodes, and that every malformed tile is an
// error, never garbage. Run by ctest (client_unit) with Node's test runner.
import assert from 'node:assert/strict';
import { test } from 'node:test';

import {
  decodeQuantizedMesh, EXTENSION_METADATA, EXTENSION_OCT_NORMALS, EXTENSION_WATER_MASK, QuantizedMeshError,
} from '../../../client_web/js/quantized_mesh.js';

// Little-endian bytes of a tile, field by field.
class Writer {
  constructor() { this.bytes = []; }
  u8(v) { this.bytes.push(v & 0xff); return this; }
  u16(v) { return this.u8(v).u8(v >> 8); }
  u32(v) { return this.u16(v & 0xffff).u16(v >>> 16); }
  f32(v) { const b = new DataView(new ArrayBuffer(4)); b.setFloat32(0, v, true); for (let i = 0; i < 4; ++i) this.u8(b.getUint8(i)); return this; }
  f64(v) { const b = new DataView(new ArrayBuffer(8)); b.setFloat64(0, v, true); for (let i = 0; i < 8; ++i) this.u8(b.getUint8(i)); return this; }
  done() { return new Uint8Array(this.bytes); }
}

const zigZag = (n) => (n << 1) ^ (n >> 31);

// One quad of two triangles: vertices (u, v, k) at the four corners, k rising eastwards.
const CORNERS = [[0, 0, 0], [32767, 0, 32767], [0, 32767, 0], [32767, 32767, 32767]];

function header(w, minimum = 100, maximum = 300) {
  w.f64(1).f64(2).f64(3).f32(minimum).f32(maximum).f64(1).f64(2).f64(3).f64(10).f64(0).f64(0).f64(1);
}

function quadTile({ extensions = [], minimum = 100, maximum = 300, indices = [0, 1, 2, 2, 1, 3] } = {}) {
  const w = new Writer();
  header(w, minimum, maximum);
  w.u32(CORNERS.length);
  for (let axis = 0; axis < 3; ++axis) {
    let previous = 0;
    for (const corner of CORNERS) { w.u16(zigZag(corner[axis] - previous)); previous = corner[axis]; }
  }
  // High-water-mark codes of the indices.
  w.u32(indices.length / 3);
  let highest = 0;
  for (const index of indices) { w.u16(highest - index); if (index === highest) ++highest; }
  for (const edge of [[0, 2], [0, 1], [1, 3], [2, 3]]) { w.u32(edge.length); for (const i of edge) w.u16(i); }
  for (const [id, data] of extensions) { w.u8(id).u32(data.length); for (const b of data) w.u8(b); }
  return w.done();
}

test('a quad decodes to its corners, heights, triangles and edges', () => {
  const t = decodeQuantizedMesh(quadTile());
  assert.equal(t.vertexCount, 4);
  assert.deepEqual([...t.u], [0, 32767, 0, 32767]);
  assert.deepEqual([...t.v], [0, 0, 32767, 32767]);
  assert.deepEqual([...t.heights], [100, 300, 100, 300]);
  assert.deepEqual([...t.indices], [0, 1, 2, 2, 1, 3]);
  assert.deepEqual([...t.edges.west], [0, 2]);
  assert.deepEqual([...t.edges.north], [2, 3]);
  assert.equal(t.header.boundingSphere.radius, 10);
  assert.equal(t.normals, null);
  assert.equal(t.waterMask, null);
});

test('extensions: oct normals, a one-byte water mask and metadata JSON', () => {
  const json = new TextEncoder().encode('{"available":[]}');
  const metadata = [json.length & 0xff, json.length >> 8, 0, 0, ...json];
  const t = decodeQuantizedMesh(quadTile({ extensions: [
    [EXTENSION_OCT_NORMALS, [128, 128, 128, 128, 128, 128, 128, 128]],
    [EXTENSION_WATER_MASK, [255]],
    [EXTENSION_METADATA, metadata],
    [99, [1, 2, 3]],
  ] }));
  for (let i = 0; i < 4; ++i) {
    const n = t.normals.subarray(3 * i, 3 * i + 3);
    assert.ok(Math.abs(Math.hypot(...n) - 1) < 1e-6);
    assert.ok(n[2] > 0.99, 'bytes (128, 128) are the up vector');
  }
  assert.deepEqual([...t.waterMask], [255]);
  assert.deepEqual(t.metadata, { available: [] });
  assert.deepEqual(t.unknownExtensions, [99]);
});

test('malformed tiles are errors that say what is wrong', () => {
  const good = quadTile();
  const cases = [
    ['truncated header', good.slice(0, 40), /header/],
    ['truncated vertices', good.slice(0, 95), /vertex data/],
    ['truncated edges', good.slice(0, good.length - 3), /edge/],
    ['index above the high-water mark', quadTile({ indices: [1, 0, 2, 2, 1, 3] }), /high-water mark/],
    ['minimum above maximum', quadTile({ minimum: 400, maximum: 300 }), /minimum height/],
    ['normals of the wrong size', quadTile({ extensions: [[EXTENSION_OCT_NORMALS, [1, 2]]] }), /normals/],
    ['a water mask of 2 bytes', quadTile({ extensions: [[EXTENSION_WATER_MASK, [1, 2]]] }), /water mask/],
    ['an extension twice', quadTile({ extensions: [[EXTENSION_WATER_MASK, [1]], [EXTENSION_WATER_MASK, [1]]] }), /twice/],
    ['metadata JSON that does not parse', quadTile({ extensions: [[EXTENSION_METADATA, [1, 0, 0, 0, 123]]] }), /JSON/],
  ];
  for (const [name, bytes, message] of cases) {
    assert.throws(() => decodeQuantizedMesh(bytes), (e) => e instanceof QuantizedMeshError && message.test(e.message), name);
  }
});
