// Planet mode's tiles: the geographic quadtree's addresses and bounds, and the curving of a
// tile's mesh so that its long triangles follow the globe.

export const GRID_CELLS = 64;  // the server's default mesh grid: 65 samples a side

export function tileKey(z, x, y) {
  return `${z}/${x}/${y}`;
}

/// Degrees of the tile's bounds: { west, south, east, north }.
export function tileBounds(z, x, y) {
  const size = 180 / 2 ** z;
  return { west: -180 + x * size, south: -90 + y * size, east: -180 + (x + 1) * size, north: -90 + (y + 1) * size };
}

/// The server's mesh is adaptive in (longitude, latitude, height): over flat sea floor a zoom-0
/// triangle may span tens of degrees, and drawn as a flat triangle between points on the sphere
/// its chord would sag hundreds of kilometres below the surface. So triangles are bisected at
/// the midpoint of their longest edge (the RTIN hypotenuse; u, v, height and normal
/// interpolated there) until the chord sag R·θ²/8 of the longest edge is at most the tile's
/// geometric error, a quarter of the sample spacing s (θ² ≤ 2s/R: θ ≤ √(40.7·2^z) grid
/// cells). That is the uniform RTIN level OR-ed with the server's splits, so the result is still
/// conforming (a shared midpoint is made once, by its edge's key), and tile edges, already one
/// grid cell per segment, are untouched.
export function curveMesh(mesh, z) {
  const cell = 32767 / GRID_CELLS;
  const limit = Math.max(1, Math.floor(Math.sqrt((2 * GRID_CELLS * 2 ** z) / Math.PI))) * cell;
  const limitSquared = limit * limit * 1.0001;
  const u = Array.from(mesh.u), v = Array.from(mesh.v), h = Array.from(mesh.heights);
  const normals = mesh.normals ? Array.from(mesh.normals) : null;
  const midpoints = new Map();
  const midpoint = (a, b) => {
    const key = a < b ? `${a},${b}` : `${b},${a}`;
    let m = midpoints.get(key);
    if (m === undefined) {
      m = u.length;
      u.push((u[a] + u[b]) / 2);
      v.push((v[a] + v[b]) / 2);
      h.push((h[a] + h[b]) / 2);
      if (normals) {
        const n = [0, 1, 2].map((c) => normals[3 * a + c] + normals[3 * b + c]);
        const l = Math.hypot(n[0], n[1], n[2]) || 1;
        normals.push(n[0] / l, n[1] / l, n[2] / l);
      }
      midpoints.set(key, m);
    }
    return m;
  };
  const edge = (a, b) => (u[a] - u[b]) ** 2 + (v[a] - v[b]) ** 2;
  const out = [];
  const stack = [];
  for (let i = mesh.indices.length - 3; i >= 0; i -= 3) stack.push([mesh.indices[i], mesh.indices[i + 1], mesh.indices[i + 2]]);
  while (stack.length) {
    let [a, b, c] = stack.pop();
    // Rotate so that (a, b) is the longest edge; the corner order (winding) is kept.
    const ab = edge(a, b), bc = edge(b, c), ca = edge(c, a);
    if (bc > ab && bc >= ca) [a, b, c] = [b, c, a];
    else if (ca > ab && ca > bc) [a, b, c] = [c, a, b];
    if (edge(a, b) <= limitSquared) {
      out.push(a, b, c);
      continue;
    }
    const m = midpoint(a, b);
    stack.push([m, b, c], [a, m, c]);
  }
  if (out.length === mesh.indices.length) return mesh;
  return {
    ...mesh,
    vertexCount: u.length,
    u: Float64Array.from(u),
    v: Float64Array.from(v),
    heights: Float64Array.from(h),
    normals: normals ? Float32Array.from(normals) : null,
    indices: u.length > 65535 ? Uint32Array.from(out) : Uint16Array.from(out),
  };
}
