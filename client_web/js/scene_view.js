// Sphere tracing a scene's compiled program in a fragment shader. The program, its parameter
// pool and the Lipschitz grid arrive in a trace bundle (GET /api/v1/scenes/{ref}/trace.json) and
// live in textures; the node functions, the interpreter and the tracer itself are the server's
// own GLSL (GET /api/v1/glsl/trace.glsl), after a prelude that reads those textures. The bundle's
// `glsl_defines` leave out the interpreter's code for node types the program does not use, and
// `program_glsl` is the program unrolled into straight-line GLSL (gpu/program_glsl.hpp).
import { decodeBase64 } from './api.js';
import { ShaderError, compileProgram, createPictureTarget, dataTexture, deletePictureTarget } from './gl.js';

const TEXTURE_WIDTH = 1024;  // texels per row of every data texture (a power of two: shifts)

const VERTEX = `#version 300 es
void main() {
  // One triangle that covers the viewport.
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}`;

function prelude({ maxFields, maxFrames, specialised, defines }) {
  return `#version 300 es
precision highp float;
precision highp int;
precision highp usampler2D;
precision highp sampler2D;
${specialised ? '#define TERRAIN_SPECIALISED' : ''}
${defines}
#define TERRAIN_PRECISE
#define TERRAIN_MAX_FIELDS ${maxFields}
#define TERRAIN_MAX_FRAMES ${maxFrames}
uniform usampler2D u_code;    // one instruction (uvec4) per texel
uniform usampler2D u_pool;    // pool words as bits
uniform sampler2D u_bounds;   // terrain::LipschitzGrid::pack()
uniform sampler2D u_water;    // terrain::WaterRaster::surface (one texel when there is none)
uniform uint u_program_size;

ivec2 texel_of(uint i) { return ivec2(int(i & ${TEXTURE_WIDTH - 1}u), int(i >> ${Math.log2(TEXTURE_WIDTH)}u)); }
uvec4 fetch_code(uint pc) { return texelFetch(u_code, texel_of(pc), 0); }
uint fetch_pool_uint(uint i) { return texelFetch(u_pool, texel_of(i), 0).r; }
float fetch_pool(uint i) { return uintBitsToFloat(fetch_pool_uint(i)); }
uint program_size() { return u_program_size; }
float fetch_bounds(uint i) { return texelFetch(u_bounds, texel_of(i), 0).r; }
float fetch_water(uint i) { return texelFetch(u_water, texel_of(i), 0).r; }
`;
}

const MAIN = `
uniform vec3 u_eye;
uniform vec3 u_forward;
uniform vec3 u_right;
uniform vec3 u_up;
uniform float u_tan_half;
uniform float u_aspect;
uniform vec2 u_size;        // the traced picture, pixels
uniform vec4 u_area;
uniform vec2 u_elevation;
uniform float u_epsilon;
uniform int u_max_steps;
uniform float u_initial_step;
uniform float u_lod_per_metre;
uniform float u_t_max;
uniform float u_water_level;
uniform float u_span;
uniform vec3 u_sun;
uniform vec4 u_water_area;
uniform int u_water_size;

layout(location = 0) out vec4 out_colour;
layout(location = 1) out vec4 out_depth;

void main() {
  TraceCamera camera = TraceCamera(u_eye, u_forward, u_right, u_up, u_tan_half, u_aspect, u_size);
  TraceSetup setup = TraceSetup(u_area.xy, u_area.zw, u_elevation.x, u_elevation.y, u_epsilon,
                                u_max_steps, u_initial_step, u_lod_per_metre, u_t_max, true,
                                u_water_level, u_span, u_sun, true, true, u_water_area,
                                u_water_size);
  // Pixel centres with y = 0 at the top, as terrain::Camera counts them.
  vec2 pixel = vec2(gl_FragCoord.x, u_size.y - gl_FragCoord.y);
  TracePixel result = trace_pixel(camera, setup, pixel);
  out_colour = vec4(vec3(trace_to_bytes(result.colour)) / 255.0, 1.0);
  out_depth = vec4(result.depth, float(result.steps), 0.0, 1.0);
}
`;

// What the shader is built from besides the shared GLSL, for a shader mode: the prelude's
// defines (node types and fractal kinds used, and TERRAIN_SPECIALISED when unrolled) and the
// unrolled evaluate_program that follows main.
function shaderParts(bundle, mode) {
  const unroll = typeof bundle.program_glsl === 'string' &&
    (mode === 'unrolled' || (mode === 'automatic' && bundle.unroll_pays === true));
  const defines = mode === 'interpreter' ? '' : bundle.glsl_defines ?? '';
  return { specialised: unroll, defines, unrolled: unroll ? bundle.program_glsl : '' };
}

/// Sample spacing per metre of distance that matches one pixel (terrain::pixel_footprint).
function pixelFootprint(tanHalf, height) {
  return Math.fround((2 * tanHalf) / height);
}

export class SceneView {
  /// `mode` says how the tracer evaluates the program (gpu::ShaderMode): 'automatic' (the
  /// default: unrolled where the server says unrolling pays, else pruned), 'pruned' (the
  /// interpreter without the node types and fractal kinds the scene does not use), 'unrolled'
  /// (the bundle's program_glsl) or 'interpreter'.
  static create(gl, glsl, bundle, mode = 'automatic') {
    if (!gl.getExtension('EXT_color_buffer_float')) {
      throw new Error('This browser cannot render to float textures (EXT_color_buffer_float), which the viewer needs.');
    }
    const build = (m) => {
      const shader = shaderParts(bundle, m);
      const source = prelude({ maxFields: bundle.stacks.fields, maxFrames: bundle.stacks.frames, ...shader }) +
        glsl + MAIN + shader.unrolled;
      return compileProgram(gl, VERTEX, source);
    };
    try {
      return new SceneView(gl, build(mode), bundle, mode);
    } catch (error) {
      // A driver may refuse a long unrolled shader; the pruned interpreter computes the same.
      if (!(error instanceof ShaderError) || mode !== 'automatic' || !shaderParts(bundle, mode).specialised) throw error;
      console.warn(`The unrolled tracer did not compile here; tracing with the interpreter. ${error.message.slice(0, 200)}`);
      return new SceneView(gl, build('pruned'), bundle, 'pruned');
    }
  }

  constructor(gl, program, bundle, mode) {
    this.gl = gl;
    this.mode = mode;
    this.program = program;
    this.uniforms = {};
    const count = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
    for (let i = 0; i < count; ++i) {
      const name = gl.getActiveUniform(program, i).name;
      this.uniforms[name] = gl.getUniformLocation(program, name);
    }
    this.vao = gl.createVertexArray();
    this.targets = {};  // 'preview' (reduced resolution) and 'full'
    this.fullFrameMs = 0;  // the viewer's sum of band times for the last complete view
    this.loadData(bundle);
  }

  // The program, pool and bounds of a bundle into textures.
  loadData(bundle) {
    const gl = this.gl;
    const code = new Uint32Array(decodeBase64(bundle.code).buffer);
    const pool = new Uint32Array(decodeBase64(bundle.pool).buffer);
    const bounds = new Float32Array(decodeBase64(bundle.bounds).buffer);
    // The scene's water layer as the tracers look it up (terrain::WaterRaster), if it has one.
    const water = bundle.water ? new Float32Array(decodeBase64(bundle.water.surface).buffer) : new Float32Array(1);
    for (const [, t] of this.textures ?? []) gl.deleteTexture(t);
    this.bundle = bundle;
    this.programSize = code.length / 4;
    this.textures = [
      ['u_code', dataTexture(gl, code, { width: TEXTURE_WIDTH, format: 'rgba32ui' })],
      ['u_pool', dataTexture(gl, pool, { width: TEXTURE_WIDTH, format: 'r32ui' })],
      ['u_bounds', dataTexture(gl, bounds, { width: TEXTURE_WIDTH, format: 'r32f' })],
      ['u_water', dataTexture(gl, water, { width: TEXTURE_WIDTH, format: 'r32f' })],
    ];
  }

  /// Shows another version of the scene: when the shader fits it (the same stack sizes, and the
  /// same node types or unrolled program: only parameter values changed) only its data textures
  /// change, which is much quicker than compiling the tracer again. Returns false when the
  /// bundle needs a new SceneView.
  replaceBundle(bundle) {
    const { fields, frames } = this.bundle.stacks;
    if (bundle.stacks.fields !== fields || bundle.stacks.frames !== frames) return false;
    const now = shaderParts(this.bundle, this.mode);
    const next = shaderParts(bundle, this.mode);
    if (next.defines !== now.defines || next.unrolled !== now.unrolled) return false;
    this.loadData(bundle);
    for (const target of Object.values(this.targets)) target.complete = target.camera = null;
    return true;
  }

  /// The ray distance (metres; −1 for sky) at canvas pixel (x, y) (y from the top) of the last
  /// picture traced for `camera`, full resolution if it is complete, else the preview; null
  /// when neither shows this camera.
  depthAt(camera, x, y, width, height) {
    const full = this.targets.full;
    const preview = this.targets.preview;
    const target = full?.complete?.equals(camera) && full.width === width && full.height === height ? full :
      preview?.camera?.equals(camera) ? preview : null;
    if (!target) return null;
    const px = Math.min(target.width - 1, Math.max(0, Math.floor((x * target.width) / width)));
    const py = Math.min(target.height - 1, Math.max(0, Math.floor((y * target.height) / height)));
    const gl = this.gl;
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, target.framebuffer);
    gl.readBuffer(gl.COLOR_ATTACHMENT1);
    const texel = new Float32Array(4);
    gl.readPixels(px, target.height - 1 - py, 1, 1, gl.RGBA, gl.FLOAT, texel);
    gl.readBuffer(gl.COLOR_ATTACHMENT0);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
    return texel[0];
  }

  dispose() {
    const gl = this.gl;
    for (const [, t] of this.textures) gl.deleteTexture(t);
    this.releaseTargets();
    gl.deleteVertexArray(this.vao);
    gl.deleteProgram(this.program);
  }

  releaseTargets() {
    for (const target of Object.values(this.targets)) deletePictureTarget(this.gl, target);
    this.targets = {};
  }

  ensureTarget(name, width, height) {
    const existing = this.targets[name];
    if (existing && existing.width === width && existing.height === height) return existing;
    if (existing) deletePictureTarget(this.gl, existing);
    const target = { ...createPictureTarget(this.gl, width, height), camera: null, complete: null };
    this.targets[name] = target;
    return target;
  }

  /// Traces the whole view at `fraction` of the canvas resolution and shows it stretched over
  /// the canvas (while the camera moves); returns the time taken in milliseconds, GPU work
  /// included (it waits for a pixel of the result).
  preview(camera, width, height, fraction) {
    const w = Math.max(1, Math.round(width * fraction));
    const h = Math.max(1, Math.round(height * fraction));
    const start = performance.now();
    const target = this.ensureTarget('preview', w, h);
    target.complete = null;
    this.trace(target, camera, 0, h);
    target.camera = camera.clone();
    this.show(target, 0, h, width, height);
    return performance.now() - start;
  }

  /// Traces rows [top, bottom) of the full-resolution view (rows counted from the top) and shows
  /// them; a slow GPU thus never runs one long draw (browsers reset a GPU stuck for seconds).
  /// Returns the time taken in milliseconds. Once every row of a view is traced, capture() reads
  /// it without tracing again.
  drawBand(camera, width, height, top, bottom) {
    const start = performance.now();
    const target = this.ensureTarget('full', width, height);
    if (top === 0) {
      target.complete = null;
      target.camera = camera.clone();
    }
    this.trace(target, camera, top, bottom);
    this.show(target, top, bottom, width, height);
    if (bottom >= height) target.complete = target.camera;
    return performance.now() - start;
  }

  // Copies rows [top, bottom) of a target onto the canvas (scaled to width × height).
  show(target, top, bottom, width, height) {
    const gl = this.gl;
    const sy = height / target.height;
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, target.framebuffer);
    gl.readBuffer(gl.COLOR_ATTACHMENT0);
    gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, null);
    gl.blitFramebuffer(0, target.height - bottom, target.width, target.height - top,
      0, Math.round(height - bottom * sy), width, Math.round(height - top * sy),
      gl.COLOR_BUFFER_BIT, target.width === width ? gl.NEAREST : gl.LINEAR);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
    const probe = new Uint8Array(4);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, probe);  // waits for the GPU
  }

  // Traces rows [top, bottom) of `target` for `camera`.
  trace(target, camera, top, bottom) {
    const gl = this.gl;
    const { width, height } = target;
    const { forward, right, up, tanHalf } = camera.basis();
    const b = this.bundle.setup;
    const u = this.uniforms;
    gl.bindFramebuffer(gl.FRAMEBUFFER, target.framebuffer);
    gl.viewport(0, 0, width, height);
    gl.enable(gl.SCISSOR_TEST);
    gl.scissor(0, height - bottom, width, bottom - top);
    gl.useProgram(this.program);
    this.textures.forEach(([name, texture], unit) => {
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, texture);
      gl.uniform1i(u[name], unit);
    });
    gl.uniform1ui(u.u_program_size, this.programSize);
    gl.uniform3fv(u.u_eye, camera.eye);
    gl.uniform3fv(u.u_forward, forward);
    gl.uniform3fv(u.u_right, right);
    gl.uniform3fv(u.u_up, up);
    gl.uniform1f(u.u_tan_half, tanHalf);
    gl.uniform1f(u.u_aspect, Math.fround(width / height));
    gl.uniform2f(u.u_size, width, height);
    gl.uniform4fv(u.u_area, b.area);
    gl.uniform2fv(u.u_elevation, b.elevation);
    gl.uniform1f(u.u_epsilon, b.epsilon);
    gl.uniform1i(u.u_max_steps, b.max_steps);
    gl.uniform1f(u.u_initial_step, b.initial_step);
    gl.uniform1f(u.u_lod_per_metre, pixelFootprint(tanHalf, height));
    gl.uniform1f(u.u_t_max, b.t_max);
    gl.uniform1f(u.u_water_level, b.water_level);
    gl.uniform1f(u.u_span, b.span);
    gl.uniform3fv(u.u_sun, b.sun);
    const water = this.bundle.water;
    gl.uniform4fv(u.u_water_area, water ? water.area : [0, 0, 1, 1]);
    gl.uniform1i(u.u_water_size, water ? water.size : 0);
    // The scene's material, packed by the server as its tracers read it (terrain::pack_material).
    gl.uniform1fv(u['u_material[0]'], new Float32Array(this.bundle.material));
    gl.bindVertexArray(this.vao);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.bindVertexArray(null);
    gl.disable(gl.SCISSOR_TEST);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  }

  /// The picture (RGBA, top row first) and ray distances (−1 where a ray missed) of a view at
  /// `width` × `height`, for tests and screenshots.
  capture(camera, width, height) {
    const gl = this.gl;
    const drawn = this.targets.full;
    const ready = drawn && drawn.width === width && drawn.height === height && drawn.complete?.equals(camera);
    const start = performance.now();
    const target = ready ? drawn : this.ensureTarget('full', width, height);
    if (!ready) {
      target.complete = null;
      this.trace(target, camera, 0, height);
      target.camera = target.complete = camera.clone();
    }
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, target.framebuffer);
    gl.readBuffer(gl.COLOR_ATTACHMENT0);
    const bottomUp = new Uint8Array(width * height * 4);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, bottomUp);
    const ms = ready ? this.fullFrameMs : performance.now() - start;
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
    return { width, height, rgba, depth, ms };
  }
}
