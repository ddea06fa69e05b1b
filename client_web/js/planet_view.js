// Planet mode: streams a planet's quantized-mesh tiles (GET /api/v1/planets/{id}/mesh/{z}/{x}/{y}.terrain,
// geographic EPSG:4326 TMS, two root tiles, y from the south) and draws them on the planet's
// sphere or ellipsoid with WebGL2.
//
// - Level of detail: a quadtree from the two roots. A tile is refined while its screen-space
//   error — its geometric error divided by the distance to its bounding sphere, times the
//   viewport's pixels per unit of tangent — exceeds MAX_SCREEN_ERROR pixels.
// - Culling: the tile's bounding sphere against the view frustum's side planes, and horizon
//   culling with an occludee point computed as Cesium's EllipsoidalOccluder does, but against the
//   planet's own surface (the header's volumes are for WGS84, which is not this planet).
// - Precision: vertex positions are float32 relative to the tile's centre; the centre minus the
//   eye is computed in double on the CPU and folded into each tile's matrix, so nothing large
//   ever reaches float32 and the ground does not jitter near the surface of an Earth-sized planet.
//   Depth is logarithmic (written per fragment), so one depth buffer holds orbit and ground views.
// - Water: the terrain is drawn with its heights clamped at sea level, so the sea is a smooth
//   surface at sea level, and coloured as water where the tile's water mask (a 256² texture per
//   tile, or the one-byte all-land / all-water form) says so; rivers and lakes come from the mask
//   too. Sea vertices are lit with the ellipsoid's up vector and a specular sun glint.
// - No holes: a tile is drawn only once all its visible children can be drawn; until then it
//   stands in for them. Tiles live in a bounded LRU cache and at most MAX_FETCHES are fetched at
//   a time, coarser levels first.
import { ApiError, fetchJson, fetchText } from './api.js';
import { compileProgram, createPictureTarget, deletePictureTarget } from './gl.js';
import { decodeQuantizedMesh } from './quantized_mesh.js';
import { Geodesy } from './planet_camera.js';
import { SKY_FS, SKY_VS, TERRAIN_VS, terrainFragmentShader } from './planet_shaders.js';
import { curveMesh, GRID_CELLS, tileBounds, tileKey } from './planet_tiles.js';
import { cross, dot, length as len, sub } from './vector.js';

// Where the tests and other modules have always found it.
export { tileBounds } from './planet_tiles.js';

const MAX_SCREEN_ERROR = 2;     // pixels
const MAX_FETCHES = 6;          // concurrent tile requests (a browser's per-host limit)
const MAX_TILES = 300;          // decoded tiles kept (GPU buffers, water mask textures)
const ATMOSPHERE = 80e3;        // metres: the sky and fog shell above the reference surface
const FOG_SCALE = 700e3;        // metres of atmosphere that fog a surface by 1 − 1/e
const RETRY_MS = 3000;          // a failed tile is asked for again after this
const ACCEPT = 'application/vnd.quantized-mesh;extensions=octvertexnormals-watermask';
const FLOATS_PER_VERTEX = 12;   // position 3, normal 3, up 3, uv 2, height 1

export class PlanetView {
  /// Fetches the planet's definition and layer.json; throws an ApiError that names the planet
  /// when it does not exist.
  static async open(gl, id) {
    let definition, layer, material, colours;
    try {
      definition = await fetchJson(`/api/v1/planets/${encodeURIComponent(id)}`);
      layer = await fetchJson(`/api/v1/planets/${encodeURIComponent(id)}/layer.json`);
      colours = await fetchJson(`/api/v1/planets/${encodeURIComponent(id)}/material.json`);
      material = await fetchText('/api/v1/glsl/material.glsl');
    } catch (e) {
      if (e instanceof ApiError && (e.status === 404 || e.status === 400)) {
        throw new ApiError(`There is no planet "${id}"${e.status === 400 ? ` (${e.message})` : ''}.`, { status: e.status });
      }
      throw e;
    }
    if (!gl.getExtension('EXT_color_buffer_float')) {
      throw new Error('This browser cannot render to float textures (EXT_color_buffer_float), which the viewer needs.');
    }
    return new PlanetView(gl, id, definition, layer, material, colours);
  }

  /// `material`: the server's material model (GET /api/v1/glsl/material.glsl), which colours land
  /// here as it does scene pictures and colour tiles; `colours`: the planet's parameters for it
  /// (GET …/material.json: the packed material, the relief and the shore band of its colour tiles).
  constructor(gl, id, definition, layer, material, colours) {
    this.gl = gl;
    this.colours = colours;
    this.id = id;
    this.definition = definition;
    this.geodesy = new Geodesy(definition.radius, definition.flattening ?? 0);
    this.radius = definition.radius;
    this.seaLevel = definition.sea_level ?? 0;
    this.maxHeight = definition.max_mountain_altitude ?? 10000;
    this.maxZoom = layer.maxzoom ?? 23;
    // The id's immutable URL template (layer.json reached through "default" points there).
    const template = (layer.tiles && layer.tiles[0]) || `/api/v1/planets/${id}/mesh/{z}/{x}/{y}.terrain`;
    this.tileUrl = (z, x, y) => new URL(template.replace('{z}', z).replace('{x}', x).replace('{y}', y)
      .replace('{version}', layer.version ?? '1'), `${location.origin}/api/v1/planets/${id}/`).href;
    // The occluder for horizon culling: nothing drawn lies below sea level (heights are clamped
    // there), so the reference ellipsoid raised to min(sea level, 0) less a metre hides what is
    // behind it.
    const s = Math.min(this.seaLevel, 0) - 1;
    this.occluderRadii = [this.geodesy.a + s, this.geodesy.a + s, this.geodesy.b + s];

    this.terrainProgram = compileProgram(gl, TERRAIN_VS, terrainFragmentShader(material));
    this.skyProgram = compileProgram(gl, SKY_VS, SKY_FS);
    this.uniforms = new Map();
    for (const program of [this.terrainProgram, this.skyProgram]) {
      const u = {};
      const count = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
      for (let i = 0; i < count; ++i) {
        const name = gl.getActiveUniform(program, i).name;
        u[name] = gl.getUniformLocation(program, name);
      }
      this.uniforms.set(program, u);
    }
    this.skyVao = gl.createVertexArray();
    this.tiles = new Map();
    this.frame = 0;
    this.inFlight = 0;
    this.arrived = true;   // a tile arrived (or failed) since the last draw: draw again
    this.error = null;     // the last tile failure, as a message
    this.target = null;
    this.stats = { drawn: 0, missing: 0, triangles: 0 };
    this.disposed = false;
  }

  dispose() {
    const gl = this.gl;
    this.disposed = true;
    for (const tile of this.tiles.values()) this.release(tile);
    this.tiles.clear();
    if (this.target) deletePictureTarget(gl, this.target);
    gl.deleteVertexArray(this.skyVao);
    gl.deleteProgram(this.terrainProgram);
    gl.deleteProgram(this.skyProgram);
  }

  /// Whether something arrived that the picture should show; resets the flag.
  takeArrived() {
    const a = this.arrived;
    this.arrived = false;
    return a;
  }

  /// Geometric error of a tile at zoom z: the server meshes a 65² grid with a largest vertical
  /// error of a quarter of the sample spacing (ProductOptions::max_error's default), so that is
  /// the error a tile has against the grid (Cesium's terrain providers estimate it the same way).
  geometricError(z) {
    return (Math.PI * this.radius) / (2 ** z * GRID_CELLS) / 4;
  }

  /// The tile (z, x, y), made on first use. A tile not loaded yet gets a bounding volume from
  /// its parent's heights (children are only visited once their parent is loaded), or, for the
  /// roots, from sea level to the highest mountain the definition allows.
  tile(z, x, y, parent = null) {
    const key = tileKey(z, x, y);
    let t = this.tiles.get(key);
    if (!t) {
      t = { key, z, x, y, bounds: tileBounds(z, x, y), state: 'none', lastUsed: 0, volume: null };
      this.tiles.set(key, t);
    }
    if (!t.volume) {
      // Finer samples add detail below the parent's sample spacing: allow a few of its errors.
      const margin = parent ? 4 * this.geometricError(parent.z) : 0;
      const range = parent?.range ?? [this.seaLevel, this.maxHeight];
      t.volume = this.estimateVolume(t, Math.max(this.seaLevel, range[0] - margin), range[1] + margin);
    }
    return t;
  }

  /// A bounding sphere and occludee point for a tile not loaded yet: its bounds on a grid of
  /// points between heights `bottom` and `top`, widened by how far the surface bulges between
  /// grid points.
  estimateVolume(t, bottom, top) {
    const { west, south, east, north } = t.bounds;
    const n = t.z < 2 ? 9 : 5;
    const bulge = (this.radius + top) * (1 - Math.cos((((north - south) / (n - 1)) * Math.PI) / 180));
    const points = [];
    for (let i = 0; i < n; ++i) {
      for (let j = 0; j < n; ++j) {
        const lat = south + ((north - south) * i) / (n - 1);
        const lon = west + ((east - west) * j) / (n - 1);
        points.push(this.geodesy.ecef(lat, lon, bottom));
        points.push(this.geodesy.ecef(lat, lon, top + bulge));
      }
    }
    return this.volumeOf(points, bulge);
  }

  /// Bounding sphere (centre of the points' box, radius to the farthest) and Cesium's
  /// occludee point in the occluder's scaled space (null when no finite point exists, as for
  /// hemisphere-wide tiles: then the tile is never horizon-culled).
  volumeOf(points, margin = 0) {
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (const p of points) for (let i = 0; i < 3; ++i) { lo[i] = Math.min(lo[i], p[i]); hi[i] = Math.max(hi[i], p[i]); }
    const centre = [0, 1, 2].map((i) => (lo[i] + hi[i]) / 2);
    let radius = 0;
    for (const p of points) radius = Math.max(radius, len(sub(p, centre)));
    radius += margin;
    const r = this.occluderRadii;
    const scaled = (p) => [p[0] / r[0], p[1] / r[1], p[2] / r[2]];
    const c = scaled(centre);
    const direction = c.map((v) => v / len(c));
    let magnitude = 0;
    for (const p of points) {
      const m = occludeeMagnitude(scaled(p), direction);
      if (!(m > 0) || !Number.isFinite(m)) return { centre, radius, occludee: null };
      magnitude = Math.max(magnitude, m);
    }
    return { centre, radius, occludee: direction.map((v) => v * magnitude) };
  }

  // ---------------------------------------------------------------- tile loading

  request(tile) {
    tile.state = 'loading';
    this.inFlight += 1;
    const url = this.tileUrl(tile.z, tile.x, tile.y);
    fetch(url, { headers: { Accept: ACCEPT } })
      .then(async (response) => {
        if (!response.ok) throw new ApiError(`${response.status} ${response.statusText} for ${url}`, { status: response.status });
        return decodeQuantizedMesh(await response.arrayBuffer());
      }, (e) => {
        throw new ApiError(`The terrain server is unreachable (${url}): ${e.message}`);
      })
      .then((mesh) => {
        if (this.disposed) return;
        this.upload(tile, mesh);
        tile.state = 'ready';
        this.error = null;
      })
      .catch((e) => {
        if (this.disposed) return;
        tile.state = 'failed';
        tile.failedAt = performance.now();
        this.error = e.message;
        setTimeout(() => { this.arrived = true; }, RETRY_MS);
      })
      .finally(() => {
        this.inFlight -= 1;
        this.arrived = true;
      });
  }

  /// Builds the tile's vertex and index buffers (with skirts), water mask texture, exact
  /// bounding volume, and the heights heightAt() reads.
  upload(tile, received) {
    const gl = this.gl;
    const { west, south, east, north } = tile.bounds;
    const mesh = curveMesh(received, tile.z);
    const count = mesh.vertexCount;
    const edgeCount = mesh.edges.west.length + mesh.edges.south.length + mesh.edges.east.length + mesh.edges.north.length;
    const total = count + edgeCount;
    const ecef = new Float64Array(3 * count);
    const ups = new Float64Array(3 * count);
    const rendered = new Float64Array(count);  // heights as drawn: clamped at sea level
    const points = [];
    for (let i = 0; i < count; ++i) {
      const lon = west + ((east - west) * mesh.u[i]) / 32767;
      const lat = south + ((north - south) * mesh.v[i]) / 32767;
      rendered[i] = Math.max(mesh.heights[i], this.seaLevel);
      const p = this.geodesy.ecef(lat, lon, rendered[i]);
      ecef.set(p, 3 * i);
      ups.set(this.geodesy.frame(lat, lon).up, 3 * i);
      points.push(p);
    }
    const volume = this.volumeOf(points);
    const centre = volume.centre;
    let lowest = Infinity, highest = -Infinity;
    for (const value of rendered) { lowest = Math.min(lowest, value); highest = Math.max(highest, value); }

    // Interleaved vertices relative to the centre; the skirt vertices (one below each edge
    // vertex) hide the cracks between tiles of different levels.
    const data = new Float32Array(total * FLOATS_PER_VERTEX);
    const put = (slot, i, drop) => {
      const o = slot * FLOATS_PER_VERTEX;
      for (let c = 0; c < 3; ++c) {
        data[o + c] = ecef[3 * i + c] - ups[3 * i + c] * drop - centre[c];
        data[o + 3 + c] = mesh.normals ? mesh.normals[3 * i + c] : ups[3 * i + c];
        data[o + 6 + c] = ups[3 * i + c];
      }
      data[o + 9] = mesh.u[i] / 32767;
      data[o + 10] = mesh.v[i] / 32767;
      data[o + 11] = mesh.heights[i];
    };
    for (let i = 0; i < count; ++i) put(i, i, 0);
    const skirt = this.geometricError(tile.z) * 5;
    const skirtIndices = [];
    let slot = count;
    for (const side of ['west', 'south', 'east', 'north']) {
      const list = mesh.edges[side];
      for (let j = 0; j < list.length; ++j) {
        put(slot + j, list[j], skirt);
        if (j > 0) {
          const a = list[j - 1], b = list[j], as = slot + j - 1, bs = slot + j;
          skirtIndices.push(a, b, as, b, bs, as);
        }
      }
      slot += list.length;
    }
    const indexCount = mesh.indices.length + skirtIndices.length;
    const wide = total > 65535;
    const indices = wide ? new Uint32Array(indexCount) : new Uint16Array(indexCount);
    indices.set(mesh.indices);
    indices.set(skirtIndices, mesh.indices.length);

    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const vbo = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vbo);
    gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
    const stride = FLOATS_PER_VERTEX * 4;
    [[0, 3, 0], [1, 3, 3], [2, 3, 6], [3, 2, 9], [4, 1, 11]].forEach(([loc, size, offset]) => {
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, size, gl.FLOAT, false, stride, offset * 4);
    });
    const ibo = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ibo);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);

    let mask = null;
    let water = 0;
    if (mesh.waterMask && mesh.waterMask.length === 65536) {
      mask = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, mask);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.R8, 256, 256, 0, gl.RED, gl.UNSIGNED_BYTE, mesh.waterMask);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
      gl.bindTexture(gl.TEXTURE_2D, null);
      water = -1;
    } else if (mesh.waterMask) {
      water = mesh.waterMask[0] / 255;
    }
    tile.gpu = { vao, vbo, ibo, mask, water, indexCount, indexType: wide ? gl.UNSIGNED_INT : gl.UNSIGNED_SHORT };
    tile.centre = centre;
    tile.volume = volume;
    tile.range = [lowest, highest];
    tile.mesh = { u: mesh.u, v: mesh.v, heights: rendered, indices: mesh.indices, header: received.header,
      vertexCount: count, receivedVertices: received.vertexCount };
  }

  release(tile) {
    const gl = this.gl;
    if (tile.gpu) {
      gl.deleteVertexArray(tile.gpu.vao);
      gl.deleteBuffer(tile.gpu.vbo);
      gl.deleteBuffer(tile.gpu.ibo);
      if (tile.gpu.mask) gl.deleteTexture(tile.gpu.mask);
    }
    tile.gpu = null;
    tile.mesh = null;
  }

  // Least recently used tiles go once more than MAX_TILES are loaded (never the roots, never
  // one drawn or visited in this frame).
  evict() {
    const ready = [...this.tiles.values()].filter((t) => t.state === 'ready');
    if (ready.length > MAX_TILES) {
      ready.sort((a, b) => a.lastUsed - b.lastUsed);
      for (const t of ready.slice(0, ready.length - MAX_TILES)) {
        if (t.z === 0 || t.lastUsed === this.frame) continue;
        this.release(t);
        this.tiles.delete(t.key);
      }
    }
    // Tiles never loaded and not visited for a while are only bookkeeping: drop them too.
    if (this.tiles.size > 4 * MAX_TILES) {
      for (const t of this.tiles.values()) {
        if (t.state !== 'ready' && t.state !== 'loading' && t.lastUsed < this.frame - 10) this.tiles.delete(t.key);
      }
    }
  }

  // ---------------------------------------------------------------- selection

  /// Chooses the tiles to draw for a camera: returns { draws, wanted, complete }.
  select(pose, width, height, fov, near) {
    const eye = pose.eye;
    const tanY = Math.tan((fov * Math.PI) / 360);
    const tanX = tanY * (width / height);
    const plane = (f, s, t) => {
      const n = [0, 1, 2].map((i) => pose.forward[i] * t + s * f[i]);
      const l = len(n);
      return n.map((v) => v / l);
    };
    const planes = [plane(pose.right, 1, tanX), plane(pose.right, -1, tanX), plane(pose.up, 1, tanY), plane(pose.up, -1, tanY)];
    const pixelsPerTangent = height / (2 * tanY);
    const r = this.occluderRadii;
    const cam = [eye[0] / r[0], eye[1] / r[1], eye[2] / r[2]];
    const camSq = dot(cam, cam) - 1;
    const visible = (volume) => {
      const c = sub(volume.centre, eye);
      if (dot(c, pose.forward) < near - volume.radius) return false;  // behind the eye
      for (const p of planes) if (dot(c, p) < -volume.radius) return false;
      if (volume.occludee && camSq > 0) {
        // Cesium's EllipsoidalOccluder.isScaledSpacePointVisible.
        const vt = sub(volume.occludee, cam);
        const vtDotVc = -dot(vt, cam);
        if (vtDotVc > camSq && (vtDotVc * vtDotVc) / dot(vt, vt) > camSq) return false;
      }
      return true;
    };
    const draws = [];
    const wanted = [];
    let complete = true;
    const frame = this.frame;
    const now = performance.now();
    const want = (tile, distance) => {
      complete = false;
      if (tile.state === 'none' || (tile.state === 'failed' && now - tile.failedAt > RETRY_MS)) wanted.push({ tile, distance });
    };
    // Returns whether the tile's area is covered by what it pushed to `draws` (or needs nothing).
    let visited = 0;
    const visit = (tile) => {
      visited += 1;
      tile.lastUsed = frame;
      const volume = tile.volume;
      if (!visible(volume)) return true;
      const distance = Math.max(len(sub(volume.centre, eye)) - volume.radius, near);
      // Only a loaded tile is refined: its children's volumes then come from its real heights,
      // and the levels load from the top, each deciding with the best knowledge there is.
      if (tile.state !== 'ready') {
        want(tile, distance);
        return false;
      }
      const error = (this.geometricError(tile.z) / distance) * pixelsPerTangent;
      if (tile.z >= this.maxZoom || error <= MAX_SCREEN_ERROR) {
        draws.push(tile);
        return true;
      }
      const before = draws.length;
      let covered = true;
      for (let j = 0; j < 2; ++j) {
        for (let i = 0; i < 2; ++i) {
          if (!visit(this.tile(tile.z + 1, 2 * tile.x + i, 2 * tile.y + j, tile))) covered = false;
        }
      }
      if (covered) return true;
      // Some child cannot be drawn yet: this tile stands in for all four (no holes, no overlap).
      draws.length = before;
      draws.push(tile);
      return true;
    };
    for (let x = 0; x < 2; ++x) visit(this.tile(0, x, 0));
    return { draws, wanted, complete, visited };
  }

  /// Starts fetches for wanted tiles, coarser and nearer first, up to MAX_FETCHES at a time.
  fetchWanted(wanted) {
    wanted.sort((a, b) => a.tile.z - b.tile.z || a.distance - b.distance);
    for (const { tile } of wanted) {
      if (this.inFlight >= MAX_FETCHES) break;
      this.request(tile);
    }
  }

  /// Height of the drawn surface (metres, clamped at sea level) at a latitude and longitude,
  /// from the finest loaded tile holding the point; sea level where none is loaded.
  heightAt(lat, lon) {
    const wrapped = ((((lon + 180) % 360) + 360) % 360) - 180;
    let best = null;
    let z = 0;
    let x = Math.min(1, Math.floor((wrapped + 180) / 180));
    let y = 0;
    for (;;) {
      const t = this.tiles.get(tileKey(z, x, y));
      if (!t || t.state !== 'ready') break;
      best = t;
      if (z >= this.maxZoom) break;
      const b = t.bounds;
      x = 2 * x + (wrapped >= (b.west + b.east) / 2 ? 1 : 0);
      y = 2 * y + (lat >= (b.south + b.north) / 2 ? 1 : 0);
      z += 1;
    }
    if (!best) return this.seaLevel;
    const { west, south, east, north } = best.bounds;
    const pu = ((wrapped - west) / (east - west)) * 32767;
    const pv = ((Math.max(south, Math.min(north, lat)) - south) / (north - south)) * 32767;
    const { u, v, heights, indices } = best.mesh;
    for (let i = 0; i < indices.length; i += 3) {
      const a = indices[i], b = indices[i + 1], c = indices[i + 2];
      const det = (v[b] - v[c]) * (u[a] - u[c]) + (u[c] - u[b]) * (v[a] - v[c]);
      if (det === 0) continue;
      const l1 = ((v[b] - v[c]) * (pu - u[c]) + (u[c] - u[b]) * (pv - v[c])) / det;
      const l2 = ((v[c] - v[a]) * (pu - u[c]) + (u[a] - u[c]) * (pv - v[c])) / det;
      const l3 = 1 - l1 - l2;
      const eps = -1e-9;
      if (l1 >= eps && l2 >= eps && l3 >= eps) return l1 * heights[a] + l2 * heights[b] + l3 * heights[c];
    }
    return this.seaLevel;
  }

  // ---------------------------------------------------------------- drawing

  ensureTarget(width, height) {
    if (this.target && this.target.width === width && this.target.height === height) return this.target;
    if (this.target) deletePictureTarget(this.gl, this.target);
    this.target = createPictureTarget(this.gl, width, height, { depthBuffer: true });
    return this.target;
  }

  /// Selects, requests and draws the tiles for `camera` into the offscreen target and shows it
  /// on the canvas. Returns { ms, complete, tiles, loading, triangles }: complete when every
  /// tile the view needs was loaded and drawn.
  draw(camera, width, height, { show = true, fetch = true } = {}) {
    const gl = this.gl;
    const start = performance.now();
    this.frame += 1;
    const pose = camera.pose(this.geodesy);
    const eye = pose.eye;
    // Clip planes: near a fraction of the height above the ground, far beyond the horizon of
    // the highest mountain. Depth precision comes from the logarithmic depth, not from these.
    const ground = this.heightAt(camera.lat, camera.lon);
    const clearance = Math.max(camera.alt - ground, 1);
    const near = Math.min(Math.max(clearance * 0.05, 0.05), 1e5);
    const rEye = len(eye);
    const rMin = Math.min(...this.occluderRadii);
    const rTop = this.radius + this.maxHeight;
    const far = Math.sqrt(Math.max(rEye * rEye - rMin * rMin, 0)) + Math.sqrt(rTop * rTop - rMin * rMin) + rTop * 0.01;

    const { draws, wanted, complete, visited } = this.select(pose, width, height, camera.fov, near);
    if (fetch) this.fetchWanted(wanted);

    const target = this.ensureTarget(width, height);
    gl.bindFramebuffer(gl.FRAMEBUFFER, target.framebuffer);
    gl.viewport(0, 0, width, height);
    gl.disable(gl.SCISSOR_TEST);
    gl.disable(gl.CULL_FACE);  // skirts are seen from both sides
    gl.disable(gl.BLEND);

    const centreRel = eye.map((v) => -v);
    const cc = dot(centreRel, centreRel);
    const atmosphere = (program) => {
      const u = this.uniforms.get(program);
      gl.uniform3fv(u.u_centre, centreRel);
      gl.uniform1f(u.u_c_atmosphere, cc - (this.radius + ATMOSPHERE) ** 2);
      gl.uniform1f(u.u_c_ground, cc - (this.radius + this.seaLevel) ** 2);
      return u;
    };

    // Sky (and space) behind everything.
    gl.disable(gl.DEPTH_TEST);
    gl.depthMask(false);
    gl.useProgram(this.skyProgram);
    const tanY = Math.tan((camera.fov * Math.PI) / 360);
    let u = atmosphere(this.skyProgram);
    gl.uniform3fv(u.u_forward, pose.forward);
    gl.uniform3fv(u.u_right, pose.right);
    gl.uniform3fv(u.u_up, pose.up);
    gl.uniform2f(u.u_tan, tanY * (width / height), tanY);
    gl.uniform2f(u.u_size, width, height);
    gl.uniform1f(u.u_atmosphere, ATMOSPHERE);
    gl.bindVertexArray(this.skyVao);
    gl.drawArrays(gl.TRIANGLES, 0, 3);

    // Terrain.
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    gl.depthMask(true);
    gl.clearDepth(1);
    gl.clear(gl.DEPTH_BUFFER_BIT);
    gl.useProgram(this.terrainProgram);
    u = atmosphere(this.terrainProgram);
    // The sun stands over the viewer's shoulder (north-east, 55° up, in the frame of the point
    // under the camera) so that whatever one looks at is lit.
    const sun = [0, 1, 2].map((i) => 0.35 * pose.east[i] + 0.45 * pose.north[i] + 0.82 * pose.localUp[i]);
    const sunLength = len(sun);
    gl.uniform3fv(u.u_sun, sun.map((v) => v / sunLength));
    gl.uniform1f(u.u_sea_level, this.seaLevel);
    gl.uniform2fv(u.u_relief, this.colours.relief);
    gl.uniform1f(u.u_shore_band, this.colours.shore_band);
    gl.uniform1fv(u['u_material[0]'], new Float32Array(this.colours.material));
    gl.uniform1f(u.u_log_depth, 2 / Math.log2(far + 1));
    gl.uniform1f(u.u_fog_scale, FOG_SCALE);
    gl.uniform1i(u.u_mask, 0);
    gl.activeTexture(gl.TEXTURE0);
    const projection = perspective(camera.fov, width / height, near, far);
    // Rows of the rotation into the camera frame: right, up, back.
    const rot = [pose.right, pose.up, pose.forward.map((v) => -v)];
    const mvp = new Float32Array(16);
    let triangles = 0;
    for (const tile of draws) {
      const offset = sub(tile.centre, eye);  // double
      const t = rot.map((row) => dot(row, offset));
      // model-view = [rot | t]; mvp = projection × model-view, column-major.
      const mv = [
        rot[0][0], rot[1][0], rot[2][0], 0,
        rot[0][1], rot[1][1], rot[2][1], 0,
        rot[0][2], rot[1][2], rot[2][2], 0,
        t[0], t[1], t[2], 1,
      ];
      multiply(projection, mv, mvp);
      gl.uniformMatrix4fv(u.u_mvp, false, mvp);
      gl.uniform3fv(u.u_offset, offset);
      gl.uniform1f(u.u_water, tile.gpu.water);
      gl.bindTexture(gl.TEXTURE_2D, tile.gpu.mask);
      gl.bindVertexArray(tile.gpu.vao);
      gl.drawElements(gl.TRIANGLES, tile.gpu.indexCount, tile.gpu.indexType, 0);
      triangles += tile.gpu.indexCount / 3;
    }
    gl.bindVertexArray(null);
    gl.bindTexture(gl.TEXTURE_2D, null);
    gl.disable(gl.DEPTH_TEST);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);

    if (show) {
      gl.bindFramebuffer(gl.READ_FRAMEBUFFER, target.framebuffer);
      gl.readBuffer(gl.COLOR_ATTACHMENT0);
      gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, null);
      gl.blitFramebuffer(0, 0, width, height, 0, 0, width, height, gl.COLOR_BUFFER_BIT, gl.NEAREST);
      gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
      const probe = new Uint8Array(4);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, probe);  // waits for the GPU
    }
    this.evict();
    const ms = performance.now() - start;
    this.stats = { tiles: draws.length, visited, loading: this.inFlight, triangles, ms, complete };
    return this.stats;
  }

  /// The view drawn afresh at `width` × `height` from the tiles loaded now, for tests and
  /// screenshots: { width, height, rgba (top row first), depth (metres, −1 for sky), ms, tiles }.
  capture(camera, width, height) {
    const gl = this.gl;
    const start = performance.now();
    const stats = this.draw(camera, width, height, { show: false, fetch: false });
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, this.target.framebuffer);
    gl.readBuffer(gl.COLOR_ATTACHMENT0);
    const bottomUp = new Uint8Array(width * height * 4);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, bottomUp);
    const ms = performance.now() - start;  // the frame, GPU work included (readPixels waits)
    gl.readBuffer(gl.COLOR_ATTACHMENT1);
    const distances = new Float32Array(width * height * 4);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.FLOAT, distances);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
    const rgba = new Array(width * height * 4);
    const depth = new Array(width * height);
    for (let y = 0; y < height; ++y) {
      const from = (height - 1 - y) * width;
      for (let x = 0; x < width; ++x) {
        for (let c = 0; c < 4; ++c) rgba[(y * width + x) * 4 + c] = bottomUp[(from + x) * 4 + c];
        depth[y * width + x] = distances[(from + x) * 4];
      }
    }
    return { width, height, rgba, depth, ms, tiles: stats.tiles, triangles: stats.triangles, complete: stats.complete };
  }
}

/// Cesium's magnitude for the occludee point along `direction` (unit, scaled space) that puts
/// scaled-space point `p` below the horizon whenever the occludee is.
function occludeeMagnitude(p, direction) {
  let magnitudeSquared = dot(p, p);
  let magnitude = Math.sqrt(magnitudeSquared);
  const d = p.map((v) => v / magnitude);
  magnitudeSquared = Math.max(1, magnitudeSquared);
  magnitude = Math.max(1, magnitude);
  const cosAlpha = dot(d, direction);
  const sinAlpha = len(cross(d, direction));
  const cosBeta = 1 / magnitude;
  const sinBeta = Math.sqrt(magnitudeSquared - 1) * cosBeta;
  return 1 / (cosAlpha * cosBeta - sinAlpha * sinBeta);
}

/// OpenGL perspective projection (column-major), fov in degrees (vertical).
function perspective(fov, aspect, near, far) {
  const f = 1 / Math.tan((fov * Math.PI) / 360);
  return [
    f / aspect, 0, 0, 0,
    0, f, 0, 0,
    0, 0, (far + near) / (near - far), -1,
    0, 0, (2 * far * near) / (near - far), 0,
  ];
}

/// out = a × b for column-major 4×4 matrices (double arithmetic, float32 result).
function multiply(a, b, out) {
  for (let c = 0; c < 4; ++c) {
    for (let r = 0; r < 4; ++r) {
      let s = 0;
      for (let k = 0; k < 4; ++k) s += a[k * 4 + r] * b[c * 4 + k];
      out[c * 4 + r] = s;
    }
  }
}
