// Small WebGL2 helpers: shader programs with readable compile errors, and data textures that
// stand in for the server's storage buffers.

export class ShaderError extends Error {}

function annotate(source, log) {
  // Show the failing lines with their numbers: the log names lines of the concatenated source.
  const lines = source.split('\n');
  const wanted = new Set();
  for (const m of log.matchAll(/\d+:(\d+)/g)) wanted.add(Number(m[1]));
  const excerpt = [...wanted].slice(0, 5).map((n) => `${n}: ${lines[n - 1] ?? ''}`);
  return excerpt.length ? `${log}\n${excerpt.join('\n')}` : log;
}

export function compileProgram(gl, vertexSource, fragmentSource) {
  const compile = (type, source) => {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, source);
    gl.compileShader(shader);
    if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
      const log = gl.getShaderInfoLog(shader) || 'unknown error';
      gl.deleteShader(shader);
      throw new ShaderError(`shader compilation failed: ${annotate(source, log)}`);
    }
    return shader;
  };
  const vs = compile(gl.VERTEX_SHADER, vertexSource);
  const fs = compile(gl.FRAGMENT_SHADER, fragmentSource);
  const program = gl.createProgram();
  gl.attachShader(program, vs);
  gl.attachShader(program, fs);
  gl.linkProgram(program);
  gl.deleteShader(vs);
  gl.deleteShader(fs);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
    const log = gl.getProgramInfoLog(program) || 'unknown error';
    gl.deleteProgram(program);
    throw new ShaderError(`shader link failed: ${log}`);
  }
  return program;
}

/// A 2D texture `width` texels wide holding `data` (typed array) as `texelSize` components per
/// texel, rows as needed: unfiltered, read with texelFetch.
export function dataTexture(gl, data, { width = 1024, format }) {
  const formats = {
    rgba32ui: [gl.RGBA32UI, gl.RGBA_INTEGER, gl.UNSIGNED_INT, 4, Uint32Array],
    r32ui: [gl.R32UI, gl.RED_INTEGER, gl.UNSIGNED_INT, 1, Uint32Array],
    r32f: [gl.R32F, gl.RED, gl.FLOAT, 1, Float32Array],
  };
  const [internal, layout, type, components, Typed] = formats[format];
  const texels = Math.max(1, Math.ceil(data.length / components));
  const rows = Math.ceil(texels / width);
  const padded = new Typed(width * rows * components);
  padded.set(data);
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
  gl.texImage2D(gl.TEXTURE_2D, 0, internal, width, rows, 0, layout, type, padded);
  gl.bindTexture(gl.TEXTURE_2D, null);
  return texture;
}

/// An offscreen picture target: an RGBA8 picture (attachment 0) and per-pixel ray distances in
/// an RGBA32F texture (attachment 1, needs EXT_color_buffer_float), plus a depth buffer when
/// `depthBuffer` (meshes; traced pictures need none).
export function createPictureTarget(gl, width, height, { depthBuffer = false } = {}) {
  const texture = (internal, format, type) => {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, internal, width, height, 0, format, type, null);
    return t;
  };
  const colour = texture(gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE);
  const distance = texture(gl.RGBA32F, gl.RGBA, gl.FLOAT);
  let depth = null;
  if (depthBuffer) {
    depth = gl.createRenderbuffer();
    gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT32F, width, height);
  }
  const framebuffer = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, colour, 0);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT1, gl.TEXTURE_2D, distance, 0);
  if (depth) gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
  gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.COLOR_ATTACHMENT1]);
  const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  const target = { framebuffer, colour, distance, depth, width, height };
  if (status !== gl.FRAMEBUFFER_COMPLETE) {
    deletePictureTarget(gl, target);
    throw new Error(`offscreen target incomplete (0x${status.toString(16)})`);
  }
  return target;
}

export function deletePictureTarget(gl, target) {
  gl.deleteFramebuffer(target.framebuffer);
  gl.deleteTexture(target.colour);
  gl.deleteTexture(target.distance);
  if (target.depth) gl.deleteRenderbuffer(target.depth);
}
