#include "gpu/evaluator.hpp"

#include <GLES3/gl31.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <list>
#include <map>
#include <span>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "glsl_sources.hpp"
#include "gpu/program_glsl.hpp"
#include "terrain/fractal_layout.hpp"
#include "terrain/material.hpp"
#include "terrain/node.hpp"
#include "terrain/sphere_trace.hpp"

namespace gpu {
namespace {

using terrain::Error;
using terrain::Op;

constexpr GLuint kWorkgroupSize = 64;  // compute_main.glsl's local_size_x

std::string gl_error_text(GLenum e) {
  switch (e) {
    case GL_INVALID_ENUM:
      return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE:
      return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION:
      return "GL_INVALID_OPERATION";
    case GL_OUT_OF_MEMORY:
      return "GL_OUT_OF_MEMORY";
    case GL_INVALID_FRAMEBUFFER_OPERATION:
      return "GL_INVALID_FRAMEBUFFER_OPERATION";
    default:
      return "GL error 0x" + std::to_string(e);
  }
}

// Clears the GL error flag; reports the first error since the last check.
terrain::Status gl_check(const char* what) {
  GLenum first = GL_NO_ERROR;
  for (GLenum e = glGetError(); e != GL_NO_ERROR; e = glGetError()) {
    if (first == GL_NO_ERROR) first = e;
  }
  if (first != GL_NO_ERROR) return Error{std::string(what) + ": " + gl_error_text(first), ""};
  return terrain::Ok{};
}

// Shader stack sizes are rounded up so programs of similar depth share one compiled shader.
int round_up(int v, int to) {
  return (std::max(v, 1) + to - 1) / to * to;
}

// FNV-1a over the program's buffers: the cache key must change whenever the bytes do, whatever
// the scene hash says (a water program and compile options share one scene hash).
std::uint64_t fingerprint(const terrain::Program& p) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      h ^= bytes[i];
      h *= 1099511628211ull;
    }
  };
  mix(p.code.data(), p.code.size() * sizeof(terrain::Instruction));
  mix(p.pool.data(), p.pool.size() * sizeof(float));
  return h;
}

// Loop iterations llvmpipe allows one invocation, with room for the tracer's own loops.
constexpr std::size_t kLoopBudget = 60000;
// trace_bound's cell loops (at most a quarter of 64 × 64 cells over the levels a segment's band
// of spacings covers, their rows on each of five levels, and the level searches) and the step
// loop itself.
constexpr std::size_t kTraceStepLoops = 64 * 64 / 4 + 5 * 64 + 2 * 5 + 8;

}  // namespace

// One iteration per instruction, plus the node's own loops where its kernel runs: the node type's
// metadata knows how to read them from its parameters (NodeType::loop_iterations).
// LP_MAX_TGSI_LOOP_ITERATIONS is shared by all loops of a shader and ends them silently: work is
// split or refused so that no invocation comes near it.
std::size_t loop_iterations_per_evaluation(const terrain::Program& p) {
  const std::span<const float> pool(p.pool);
  std::size_t n = 0;
  for (const terrain::Instruction& ins : p.code) {
    n += 1;
    const bool runs_kernel = ins.op == Op::leaf || ins.op == Op::combine ||
                             ins.op == Op::warp_begin || ins.op == Op::blend_end;
    const terrain::NodeType* type = runs_kernel ? terrain::node_type_by_id(ins.type) : nullptr;
    if (type != nullptr && type->loop_iterations != nullptr && ins.params <= pool.size()) {
      n += type->loop_iterations(pool.subspan(ins.params));
    }
  }
  return n;
}

std::vector<float> prepare_pool(const terrain::Program& program) {
  std::vector<float> pool = program.pool;
  namespace layout = terrain::fractal_layout;
  auto fill = [&pool](std::size_t fractal) {
    if (fractal + layout::kFloats > pool.size()) return;
    pool[fractal + layout::kGain] =
        static_cast<float>(std::pow(static_cast<double>(pool[fractal + layout::kLacunarity]),
                                    -static_cast<double>(pool[fractal + layout::kHurst])));
  };
  for (const std::uint32_t at : fractal_offsets(program)) fill(at);
  return pool;
}

namespace {

struct Shader {
  GLuint program = 0;
  std::uint64_t last_used = 0;
  GLint program_size = -1, first = -1, count = -1, grid_width = -1, grid_samples = -1, spacing = -1;
};

// The tracer's uniforms (compute_trace_main.glsl).
struct TraceShader {
  GLuint program = 0;
  std::uint64_t last_used = 0;
  GLint program_size = -1, first = -1, count = -1, phase = -1, budget = -1, eye = -1, forward = -1,
        right = -1, up = -1, tan_half = -1, aspect = -1, size = -1, area = -1, elevation = -1,
        epsilon = -1, max_steps = -1, initial_step = -1, lod_per_metre = -1, t_max = -1,
        accelerated = -1, water_level = -1, span = -1, sun = -1, shadows = -1, occlusion = -1,
        material = -1, water_area = -1, water_size = -1;
};

// A LipschitzGrid uploaded for one (program, area): built on the CPU once, reused by later
// pictures of the same scene and area.
struct UploadedBounds {
  std::string key;
  GLuint buffer = 0;
};

struct Uploaded {
  std::string key;
  GLuint code = 0;
  GLuint pool = 0;
  ProgramShader shader;
  std::string shader_key;
};

// Keeps at most `capacity` compiled shaders, the least recently used going first. Unrolled
// shaders are one per program structure, so live editing would otherwise grow the set forever.
// Nothing runs between the evaluator's (serialised) calls, so no shader in use is deleted.
template <class ShaderMap>
void keep_recent_shaders(ShaderMap& shaders, std::size_t capacity) {
  while (shaders.size() > capacity) {
    auto oldest = std::min_element(
        shaders.begin(), shaders.end(),
        [](const auto& a, const auto& b) { return a.second.last_used < b.second.last_used; });
    glDeleteProgram(oldest->second.program);
    shaders.erase(oldest);
  }
}

GLuint make_buffer(const void* data, std::size_t bytes) {
  GLuint b = 0;
  glGenBuffers(1, &b);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, b);
  // A zero-sized SSBO cannot be bound: keep at least one vec4.
  const std::size_t size = std::max<std::size_t>(bytes, 16);
  glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(size), nullptr, GL_STATIC_DRAW);
  if (bytes > 0) {
    glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(bytes), data);
  }
  return b;
}

}  // namespace

struct GpuEvaluator::State {
  int glsl_version = 310;
  std::size_t capacity = 8;
  ShaderMode mode = ShaderMode::automatic;
  std::size_t shader_capacity = 32;
  std::uint64_t shader_clock = 0;         // ticks once per shader use: the LRU order
  std::map<std::string, Shader> shaders;  // by ProgramShader::key()
  std::map<std::string, TraceShader> trace_shaders;
  std::list<Uploaded> programs;      // most recently used first
  std::list<UploadedBounds> bounds;  // most recently used first
  GLuint positions = 0;
  std::size_t positions_bytes = 0;
  GLuint results = 0;
  std::size_t results_bytes = 0;
  GLuint max_groups = 65535;
  std::size_t uploads = 0;    // programs uploaded so far (cache misses)
  bool loop_limited = false;  // llvmpipe/softpipe: see loop_iterations_per_evaluation
  GLuint trace_states = 0;
  std::size_t trace_states_bytes = 0;
  GLuint trace_active = 0;
  GLuint trace_water = 0;  // the picture's WaterRaster, replaced by each picture

  ~State() {
    for (auto& [key, s] : shaders) glDeleteProgram(s.program);
    for (auto& [key, s] : trace_shaders) glDeleteProgram(s.program);
    for (UploadedBounds& b : bounds) glDeleteBuffers(1, &b.buffer);
    for (Uploaded& u : programs) {
      glDeleteBuffers(1, &u.code);
      glDeleteBuffers(1, &u.pool);
    }
    glDeleteBuffers(1, &positions);
    glDeleteBuffers(1, &results);
    glDeleteBuffers(1, &trace_states);
    glDeleteBuffers(1, &trace_active);
    glDeleteBuffers(1, &trace_water);
  }
};

struct GpuEvaluator::Run {
  std::span<const float> positions;  // (x, y) pairs, or per grid its columns then its rows
  std::size_t count = 0;
  int grid_width = 0;            // 0: (x, y) pairs
  std::size_t grid_samples = 0;  // samples per grid; the grids' spacings follow their tables
  float spacing = 0.0f;          // pairs only
  float* f = nullptr;
  float* fx = nullptr;
  float* fy = nullptr;
};

std::string_view shared_glsl() {
  // The registry's tables first (the node functions read fractal offsets from them), its
  // dispatch after the node functions it calls.
  static const std::string text = std::string(glsl::portable_math()) + "\n" + node_table_glsl() +
                                  "\n" + std::string(glsl::noise()) + "\n" +
                                  std::string(glsl::nodes()) + "\n" + node_dispatch_glsl() + "\n" +
                                  std::string(glsl::interpreter());
  return text;
}

std::pair<int, int> shader_stacks(const terrain::Program& program) {
  // Rounded up so that programs of similar depth share compiled shaders.
  return {round_up(program.max_field_depth + 1, 4), round_up(program.max_frame_depth + 1, 2)};
}

std::string_view material_glsl() {
  static const std::string text = terrain::material_glsl_declarations() +
                                  std::string(glsl::material()) + "\n" +
                                  std::string(glsl::lighting());
  return text;
}

std::string_view trace_glsl() {
  static const std::string text = std::string(material_glsl()) + "\n" + std::string(glsl::trace());
  return text;
}

namespace {

std::string shader_header(const ProgramShader& shader) {
  return "#version 310 es\n#define TERRAIN_MAX_FIELDS " + std::to_string(shader.max_fields) +
         "\n#define TERRAIN_MAX_FRAMES " + std::to_string(shader.max_frames) + "\n" +
         shader.defines + std::string(glsl::compute_prelude()) + "\n" + std::string(shared_glsl()) +
         "\n";
}

}  // namespace

std::string ProgramShader::key() const {
  return std::to_string(max_fields) + "/" + std::to_string(max_frames) + "\n" + defines + unrolled;
}

terrain::Result<ProgramShader> program_shader(const terrain::Program& program, ShaderMode mode) {
  ProgramShader out;
  std::tie(out.max_fields, out.max_frames) = shader_stacks(program);
  if (mode == ShaderMode::automatic) {
    mode = unroll_pays(program) ? ShaderMode::unrolled : ShaderMode::pruned;
  }
  if (mode == ShaderMode::pruned) out.defines = node_type_defines(program);
  if (mode == ShaderMode::unrolled) {
    terrain::Result<std::string> unrolled = specialised_program_glsl(program);
    if (!unrolled) return unrolled.error();
    out.defines = "#define TERRAIN_SPECIALISED\n" + node_type_defines(program);
    out.unrolled = std::move(unrolled).value();
  }
  return out;
}

std::string compute_shader_source(const ProgramShader& shader) {
  return shader_header(shader) + std::string(glsl::compute_main()) + "\n" + shader.unrolled;
}

std::string trace_shader_source(const ProgramShader& shader) {
  return shader_header(shader) + std::string(trace_glsl()) + "\n" +
         std::string(glsl::compute_trace_main()) + "\n" + shader.unrolled;
}

terrain::Result<std::unique_ptr<GpuEvaluator>> GpuEvaluator::create(const GpuOptions& options) {
  terrain::Result<std::unique_ptr<EglContext>> context = EglContext::create(options.context);
  if (!context) return context.error();
  std::unique_ptr<GpuEvaluator> out(new GpuEvaluator());
  out->context_ = std::move(context).value();
  EglContext::Scope scope(*out->context_);
  if (!scope.ok()) return scope.status().error();
  out->state_ = std::make_unique<State>();
  out->state_->capacity = static_cast<std::size_t>(std::max(options.cached_programs, 1));
  out->state_->mode = options.shaders;
  out->state_->shader_capacity = static_cast<std::size_t>(std::max(options.cached_shaders, 1));
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  // GLSL ES 3.20 has `precise`, which keeps the compiler from fusing a·b + c where the CPU
  // rounds twice; 3.10 builds the same code without it.
  out->state_->glsl_version = (major > 3 || (major == 3 && minor >= 2)) ? 320 : 310;
  GLint groups = 0;
  glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, 0, &groups);
  if (groups > 0) out->state_->max_groups = static_cast<GLuint>(std::min(groups, 65535));
  glGenBuffers(1, &out->state_->positions);
  glGenBuffers(1, &out->state_->results);
  glGenBuffers(1, &out->state_->trace_states);
  out->state_->trace_active = make_buffer(nullptr, 0);
  out->state_->trace_water = make_buffer(nullptr, 0);
  const std::string& renderer = out->context_->renderer();
  out->state_->loop_limited = renderer.find("llvmpipe") != std::string::npos ||
                              renderer.find("softpipe") != std::string::npos;
  if (terrain::Status s = gl_check("setting up the evaluator"); !s) return s.error();
  return out;
}

GpuEvaluator::~GpuEvaluator() {
  if (context_ && state_) {
    EglContext::Scope scope(*context_);
    state_.reset();  // GL objects go while the context is current
  }
}

std::string GpuEvaluator::device_name() const {
  return context_->description();
}

terrain::Status GpuEvaluator::supports(const terrain::Program& program) {
  return shaders_implement(program);
}

terrain::Status GpuEvaluator::evaluate(const terrain::Program& program, std::span<const float> x,
                                       std::span<const float> y, float spacing, float* f, float* fx,
                                       float* fy) {
  if (x.size() != y.size()) return Error{"x and y must have the same number of points", ""};
  if (f == nullptr) return Error{"the elevation output is required", ""};
  std::vector<float> pairs(2 * x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    pairs[2 * i] = x[i];
    pairs[2 * i + 1] = y[i];
  }
  Run request;
  request.positions = pairs;
  request.count = x.size();
  request.spacing = spacing;
  request.f = f;
  request.fx = fx;
  request.fy = fy;
  return run(program, request);
}

terrain::Result<terrain::GridResult> GpuEvaluator::evaluate_grid(const terrain::Program& program,
                                                                 const terrain::GridSpec& grid) {
  terrain::Result<std::vector<terrain::GridResult>> one =
      evaluate_grids(program, std::span<const terrain::GridSpec>(&grid, 1));
  if (!one) return one.error();
  return std::move(one->front());
}

terrain::Result<std::vector<terrain::GridResult>> GpuEvaluator::evaluate_grids(
    const terrain::Program& program, std::span<const terrain::GridSpec> grids) {
  if (grids.empty()) return std::vector<terrain::GridResult>{};
  const int width = grids.front().width, height = grids.front().height;
  if (width <= 0 || height <= 0) return Error{"the grid is empty", ""};
  for (const terrain::GridSpec& g : grids) {
    if (g.width != width || g.height != height) {
      return Error{"grids batched in one dispatch must share one size", ""};
    }
  }
  const auto w = static_cast<std::size_t>(width);
  const auto h = static_cast<std::size_t>(height);
  const std::size_t n = grids.size();
  // Per grid its column table and its row table, then one spacing per grid.
  std::vector<float> tables((w + h) * n + n);
  for (std::size_t k = 0; k < n; ++k) {
    const terrain::GridSpec& g = grids[k];
    float* table = tables.data() + k * (w + h);
    // Rounded exactly as terrain::evaluate_grid does: double, then float.
    for (int i = 0; i < width; ++i) {
      table[static_cast<std::size_t>(i)] = static_cast<float>(g.origin_x + g.step * i);
    }
    for (int j = 0; j < height; ++j) {
      table[w + static_cast<std::size_t>(j)] = static_cast<float>(g.origin_y + g.step * j);
    }
    tables[(w + h) * n + k] = g.lod_spacing < 0.0f ? static_cast<float>(g.step) : g.lod_spacing;
  }
  std::vector<float> f(w * h * n), fx(w * h * n), fy(w * h * n);
  Run request;
  request.positions = tables;
  request.count = w * h * n;
  request.grid_width = width;
  request.grid_samples = w * h;
  request.f = f.data();
  request.fx = fx.data();
  request.fy = fy.data();
  if (terrain::Status s = run(program, request); !s) return s.error();
  std::vector<terrain::GridResult> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    terrain::GridResult& r = out[k];
    r.width = width;
    r.height = height;
    const auto first = static_cast<std::ptrdiff_t>(k * w * h);
    const auto last = static_cast<std::ptrdiff_t>((k + 1) * w * h);
    r.elevation.assign(f.begin() + first, f.begin() + last);
    r.gradient_x.assign(fx.begin() + first, fx.begin() + last);
    r.gradient_y.assign(fy.begin() + first, fy.begin() + last);
  }
  return out;
}

terrain::Result<const void*> GpuEvaluator::upload(const terrain::Program& program) {
  State& st = *state_;
  // The program's buffers, uploaded once per program version (the key changes with any byte).
  const std::string key = program.scene_hash + "/" + std::to_string(fingerprint(program));
  auto it = std::find_if(st.programs.begin(), st.programs.end(),
                         [&](const Uploaded& u) { return u.key == key; });
  if (it != st.programs.end()) {
    st.programs.splice(st.programs.begin(), st.programs, it);
    return static_cast<const void*>(&st.programs.front());
  }
  Uploaded u;
  u.key = key;
  terrain::Result<ProgramShader> shader = program_shader(program, st.mode);
  if (!shader) return shader.error();
  u.shader = std::move(shader).value();
  u.shader_key = u.shader.key();
  u.code = make_buffer(program.code.data(), program.code.size() * sizeof(terrain::Instruction));
  const std::vector<float> pool = prepare_pool(program);
  u.pool = make_buffer(pool.data(), pool.size() * sizeof(float));
  if (terrain::Status s = gl_check("uploading the program"); !s) {
    glDeleteBuffers(1, &u.code);
    glDeleteBuffers(1, &u.pool);
    return s.error();
  }
  ++st.uploads;
  st.programs.push_front(std::move(u));
  while (st.programs.size() > st.capacity) {
    glDeleteBuffers(1, &st.programs.back().code);
    glDeleteBuffers(1, &st.programs.back().pool);
    st.programs.pop_back();
  }
  return static_cast<const void*>(&st.programs.front());
}

terrain::Result<unsigned> GpuEvaluator::compile(const std::string& source) {
  std::string text = source;
  if (state_->glsl_version == 320) {
    text.replace(0, std::strlen("#version 310 es"), "#version 320 es");
  }
  return context_->compile_compute(text);
}

std::size_t GpuEvaluator::compiled_shaders() const {
  EglContext::Scope scope(*context_);
  return state_->shaders.size() + state_->trace_shaders.size();
}

std::size_t GpuEvaluator::program_uploads() const {
  EglContext::Scope scope(*context_);
  return state_->uploads;
}

terrain::Status GpuEvaluator::run(const terrain::Program& program, const Run& request) {
  if (terrain::Status s = supports(program); !s) return s;
  if (request.count == 0) return terrain::Ok{};
  if (request.count > 0xffffffffull / 2) return Error{"too many points for one call", ""};
  EglContext::Scope scope(*context_);
  if (!scope.ok()) return scope.status();
  State& st = *state_;
  if (st.loop_limited && loop_iterations_per_evaluation(program) > kLoopBudget) {
    return Error{
        "the program is too large for this device's shader loop limit (llvmpipe stops "
        "loops after 65535 iterations); evaluate it on the CPU",
        ""};
  }
  // A stale error from elsewhere must not be blamed on this call.
  static_cast<void>(gl_check("before evaluation"));

  terrain::Result<const void*> uploaded_at = upload(program);
  if (!uploaded_at) return uploaded_at.error();
  const Uploaded& uploaded = *static_cast<const Uploaded*>(*uploaded_at);

  // The shader for these stack sizes, compiled once.
  auto found = st.shaders.find(uploaded.shader_key);
  if (found == st.shaders.end()) {
    terrain::Result<unsigned> compiled = compile(compute_shader_source(uploaded.shader));
    if (!compiled) return compiled.error();
    Shader s;
    s.program = compiled.value();
    s.program_size = glGetUniformLocation(s.program, "u_program_size");
    s.first = glGetUniformLocation(s.program, "u_first");
    s.count = glGetUniformLocation(s.program, "u_count");
    s.grid_width = glGetUniformLocation(s.program, "u_grid_width");
    s.grid_samples = glGetUniformLocation(s.program, "u_grid_samples");
    s.spacing = glGetUniformLocation(s.program, "u_spacing");
    found = st.shaders.emplace(uploaded.shader_key, s).first;
  }
  found->second.last_used = ++st.shader_clock;
  keep_recent_shaders(st.shaders, st.shader_capacity);
  const Shader& shader = found->second;

  const std::size_t in_bytes = request.positions.size() * sizeof(float);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.positions);
  if (in_bytes > st.positions_bytes) {
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(in_bytes), nullptr,
                 GL_DYNAMIC_DRAW);
    st.positions_bytes = in_bytes;
  }
  glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(in_bytes),
                  request.positions.data());
  const std::size_t out_bytes = request.count * 4 * sizeof(float);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.results);
  if (out_bytes > st.results_bytes) {
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(out_bytes), nullptr,
                 GL_DYNAMIC_READ);
    st.results_bytes = out_bytes;
  }
  if (terrain::Status s = gl_check("uploading the points"); !s) return s;

  glUseProgram(shader.program);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, uploaded.code);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, uploaded.pool);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, st.positions);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, st.results);
  glUniform1ui(shader.program_size, static_cast<GLuint>(program.code.size()));
  glUniform1ui(shader.count, static_cast<GLuint>(request.count));
  glUniform1ui(shader.grid_width, static_cast<GLuint>(request.grid_width));
  glUniform1ui(shader.grid_samples, static_cast<GLuint>(request.grid_samples));
  glUniform1f(shader.spacing, request.spacing);
  // Large requests go in several dispatches: the group count per dispatch is limited.
  const std::size_t per_dispatch = static_cast<std::size_t>(st.max_groups) * kWorkgroupSize;
  for (std::size_t first = 0; first < request.count; first += per_dispatch) {
    const std::size_t n = std::min(per_dispatch, request.count - first);
    glUniform1ui(shader.first, static_cast<GLuint>(first));
    glDispatchCompute(static_cast<GLuint>((n + kWorkgroupSize - 1) / kWorkgroupSize), 1, 1);
  }
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  if (terrain::Status s = gl_check("running the compute shader"); !s) return s;

  glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.results);
  const auto* mapped = static_cast<const float*>(glMapBufferRange(
      GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(out_bytes), GL_MAP_READ_BIT));
  if (mapped == nullptr) {
    terrain::Status s = gl_check("reading the results back");
    return s ? Error{"glMapBufferRange returned no memory", ""} : s;
  }
  for (std::size_t i = 0; i < request.count; ++i) {
    request.f[i] = mapped[4 * i];
    if (request.fx != nullptr) request.fx[i] = mapped[4 * i + 1];
    if (request.fy != nullptr) request.fy[i] = mapped[4 * i + 2];
  }
  glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
  return gl_check("reading the results back");
}

terrain::Result<terrain::Picture> GpuEvaluator::render(const terrain::Program& program,
                                                       const terrain::Box2& area,
                                                       const terrain::Camera& camera,
                                                       const terrain::RenderOptions& options) {
  if (terrain::Status s = supports(program); !s) return s.error();
  if (camera.width <= 0 || camera.height <= 0) return Error{"the picture is empty", ""};
  const std::size_t pixels =
      static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  if (pixels > 0xffffffffull / 2) return Error{"too many pixels for one picture", ""};
  const std::size_t per_step = loop_iterations_per_evaluation(program) + kTraceStepLoops;
  // Refused before any work (the bounds grid costs CPU time); loop_limited never changes. The
  // finishing phase evaluates once more, and the first step also clips the ray.
  if (state_->loop_limited && per_step + 64 > kLoopBudget) {
    return Error{
        "the program is too large for this device's shader loop limit (llvmpipe stops "
        "loops after 65535 iterations); render it on the CPU",
        ""};
  }

  // Everything terrain::render derives before tracing, derived the same way.
  const terrain::TraceDomain domain = terrain::trace_domain(program, area);
  const float span = std::max(area.size().x, area.size().y);
  terrain::TraceOptions trace = options.trace;
  if (trace.lod_per_metre == 0.0f) trace.lod_per_metre = terrain::pixel_footprint(camera);
  trace.t_max = std::min(trace.t_max, 4.0f * span + 1e4f);
  const terrain::Camera::Basis basis = camera.basis();
  const terrain::Vec3 sun = terrain::sun_direction();

  // The bounds grid: the caller's, or the one terrain::render builds (cached per program and
  // area, since building it walks the program 20 480 times on the CPU).
  std::vector<float> packed_bounds;
  std::string bounds_key;
  if (trace.bounds != nullptr) {
    packed_bounds = trace.bounds->pack();
  } else {
    bounds_key = program.scene_hash + "/" + std::to_string(fingerprint(program));
    for (float v : {area.lo.x, area.lo.y, area.hi.x, area.hi.y}) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, &v, sizeof bits);
      bounds_key += "/" + std::to_string(bits);
    }
  }
  bool cached_bounds = false;
  {
    EglContext::Scope scope(*context_);
    if (!scope.ok()) return scope.status().error();
    cached_bounds = !bounds_key.empty() &&
                    std::any_of(state_->bounds.begin(), state_->bounds.end(),
                                [&](const UploadedBounds& b) { return b.key == bounds_key; });
  }
  if (!cached_bounds && packed_bounds.empty()) {
    terrain::Evaluator evaluator(program);
    packed_bounds = terrain::LipschitzGrid(evaluator, area).pack();
  }

  EglContext::Scope scope(*context_);
  if (!scope.ok()) return scope.status().error();
  State& st = *state_;
  static_cast<void>(gl_check("before tracing"));
  // Steps per pixel and dispatch: all of them at once, or on llvmpipe as many as stay within its
  // loop limit (the trace resumes in the next dispatch; the result is the same).
  int budget = std::max(trace.max_steps, 1);
  if (st.loop_limited) budget = std::min(budget, static_cast<int>(kLoopBudget / per_step));
  terrain::Result<const void*> uploaded_at = upload(program);
  if (!uploaded_at) return uploaded_at.error();
  const Uploaded& uploaded = *static_cast<const Uploaded*>(*uploaded_at);

  // The bounds buffer: from the cache, or uploaded now (and cached when it is render's own).
  GLuint bounds_buffer = 0;
  GLuint temporary_bounds = 0;
  auto cached = std::find_if(st.bounds.begin(), st.bounds.end(), [&](const UploadedBounds& b) {
    return !bounds_key.empty() && b.key == bounds_key;
  });
  if (cached != st.bounds.end()) {
    st.bounds.splice(st.bounds.begin(), st.bounds, cached);
    bounds_buffer = st.bounds.front().buffer;
  } else {
    if (packed_bounds.empty()) {
      // Another thread evicted it between the two locks: rebuild.
      terrain::Evaluator evaluator(program);
      packed_bounds = terrain::LipschitzGrid(evaluator, area).pack();
    }
    const GLuint buffer = make_buffer(packed_bounds.data(), packed_bounds.size() * sizeof(float));
    if (terrain::Status s = gl_check("uploading the Lipschitz grid"); !s) {
      glDeleteBuffers(1, &buffer);
      return s.error();
    }
    if (bounds_key.empty()) {
      temporary_bounds = buffer;
    } else {
      st.bounds.push_front({bounds_key, buffer});
      while (st.bounds.size() > st.capacity) {
        glDeleteBuffers(1, &st.bounds.back().buffer);
        st.bounds.pop_back();
      }
    }
    bounds_buffer = buffer;
  }
  // Deletes a caller's grid when this call ends, whatever the path out.
  struct Release {
    GLuint buffer;
    ~Release() {
      if (buffer != 0) glDeleteBuffers(1, &buffer);
    }
  } release{temporary_bounds};

  auto found = st.trace_shaders.find(uploaded.shader_key);
  if (found == st.trace_shaders.end()) {
    terrain::Result<unsigned> compiled = compile(trace_shader_source(uploaded.shader));
    if (!compiled) return compiled.error();
    TraceShader s;
    s.program = compiled.value();
    auto at = [&](const char* name) { return glGetUniformLocation(s.program, name); };
    s.program_size = at("u_program_size");
    s.first = at("u_first");
    s.count = at("u_count");
    s.phase = at("u_phase");
    s.budget = at("u_budget");
    s.eye = at("u_eye");
    s.forward = at("u_forward");
    s.right = at("u_right");
    s.up = at("u_up");
    s.tan_half = at("u_tan_half");
    s.aspect = at("u_aspect");
    s.size = at("u_size");
    s.area = at("u_area");
    s.elevation = at("u_elevation");
    s.epsilon = at("u_epsilon");
    s.max_steps = at("u_max_steps");
    s.initial_step = at("u_initial_step");
    s.lod_per_metre = at("u_lod_per_metre");
    s.t_max = at("u_t_max");
    s.accelerated = at("u_accelerated");
    s.water_level = at("u_water_level");
    s.span = at("u_span");
    s.sun = at("u_sun");
    s.shadows = at("u_shadows");
    s.occlusion = at("u_occlusion");
    s.material = at("u_material");
    s.water_area = at("u_water_area");
    s.water_size = at("u_water_size");
    found = st.trace_shaders.emplace(uploaded.shader_key, s).first;
  }
  found->second.last_used = ++st.shader_clock;
  keep_recent_shaders(st.trace_shaders, st.shader_capacity);
  const TraceShader& shader = found->second;

  const std::size_t out_bytes = pixels * 4 * sizeof(std::uint32_t);
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.results);
  if (out_bytes > st.results_bytes) {
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(out_bytes), nullptr,
                 GL_DYNAMIC_READ);
    st.results_bytes = out_bytes;
  }
  const std::size_t state_bytes = pixels * 24 * sizeof(std::uint32_t);  // a PixelTrace each
  glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.trace_states);
  if (state_bytes > st.trace_states_bytes) {
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(state_bytes), nullptr,
                 GL_DYNAMIC_COPY);
    st.trace_states_bytes = state_bytes;
  }
  if (terrain::Status s = gl_check("allocating the picture"); !s) return s.error();

  glUseProgram(shader.program);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, uploaded.code);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, uploaded.pool);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, st.results);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, bounds_buffer);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, st.trace_states);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, st.trace_active);
  const terrain::WaterRaster* water = options.water;
  if (water != nullptr && water->size > 0) {
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.trace_water);
    glBufferData(GL_SHADER_STORAGE_BUFFER,
                 static_cast<GLsizeiptr>(water->surface.size() * sizeof(float)),
                 water->surface.data(), GL_STREAM_DRAW);
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, st.trace_water);
  glUniform1ui(shader.program_size, static_cast<GLuint>(program.code.size()));
  glUniform1ui(shader.count, static_cast<GLuint>(pixels));
  glUniform1i(shader.budget, budget);
  glUniform3f(shader.eye, camera.position.x, camera.position.y, camera.position.z);
  glUniform3f(shader.forward, basis.forward.x, basis.forward.y, basis.forward.z);
  glUniform3f(shader.right, basis.right.x, basis.right.y, basis.right.z);
  glUniform3f(shader.up, basis.up.x, basis.up.y, basis.up.z);
  glUniform1f(shader.tan_half, basis.tan_half);
  glUniform1f(shader.aspect, basis.aspect);
  glUniform2f(shader.size, static_cast<float>(camera.width), static_cast<float>(camera.height));
  glUniform4f(shader.area, domain.area.lo.x, domain.area.lo.y, domain.area.hi.x, domain.area.hi.y);
  glUniform2f(shader.elevation, domain.elevation.lo, domain.elevation.hi);
  glUniform1f(shader.epsilon, trace.epsilon);
  glUniform1i(shader.max_steps, trace.max_steps);
  glUniform1f(shader.initial_step, trace.initial_step);
  glUniform1f(shader.lod_per_metre, trace.lod_per_metre);
  glUniform1f(shader.t_max, trace.t_max);
  glUniform1i(shader.accelerated, trace.accelerated ? 1 : 0);
  glUniform1f(shader.water_level, options.water_level);
  glUniform1f(shader.span, span);
  glUniform3f(shader.sun, sun.x, sun.y, sun.z);
  glUniform1i(shader.shadows, options.shadows ? 1 : 0);
  glUniform1i(shader.occlusion, options.occlusion ? 1 : 0);
  const terrain::PackedMaterial material = terrain::pack_material(options.material);
  glUniform1fv(shader.material, static_cast<GLsizei>(material.size()), material.data());
  if (water != nullptr && water->size > 0) {
    glUniform4f(shader.water_area, water->area.lo.x, water->area.lo.y, water->area.hi.x,
                water->area.hi.y);
    glUniform1i(shader.water_size, water->size);
  } else {
    glUniform1i(shader.water_size, 0);
  }

  // One phase over every pixel, in as many dispatches as the group count limit asks.
  const std::size_t per_dispatch = static_cast<std::size_t>(st.max_groups) * kWorkgroupSize;
  auto dispatch_all = [&](int phase) {
    glUniform1i(shader.phase, phase);
    for (std::size_t first = 0; first < pixels; first += per_dispatch) {
      const std::size_t n = std::min(per_dispatch, pixels - first);
      glUniform1ui(shader.first, static_cast<GLuint>(first));
      glDispatchCompute(static_cast<GLuint>((n + kWorkgroupSize - 1) / kWorkgroupSize), 1, 1);
    }
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  };
  // Pixels still tracing after the last dispatch; zeroes the counter for the next one.
  auto still_running = [&]() -> terrain::Result<std::uint32_t> {
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.trace_active);
    const auto* count = static_cast<const std::uint32_t*>(
        glMapBufferRange(GL_SHADER_STORAGE_BUFFER, 0, sizeof(std::uint32_t), GL_MAP_READ_BIT));
    if (count == nullptr) return Error{"reading the tracer's progress failed", ""};
    const std::uint32_t running = *count;
    glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
    const std::uint32_t zero = 0;
    glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, sizeof zero, &zero);
    if (terrain::Status s = gl_check("reading the tracer's progress"); !s) return s.error();
    return running;
  };
  {
    const std::uint32_t zero = 0;
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.trace_active);
    glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, sizeof zero, &zero);
  }
  dispatch_all(0);
  for (;;) {
    if (terrain::Status s = gl_check("running the tracer"); !s) return s.error();
    terrain::Result<std::uint32_t> running = still_running();
    if (!running) return running.error();
    if (*running == 0) break;
    if (options.progress) {
      options.progress(1.0f - static_cast<float>(*running) / static_cast<float>(pixels));
    }
    dispatch_all(1);
  }
  dispatch_all(2);
  if (terrain::Status s = gl_check("shading the picture"); !s) return s.error();

  glBindBuffer(GL_SHADER_STORAGE_BUFFER, st.results);
  const auto* mapped = static_cast<const std::uint32_t*>(glMapBufferRange(
      GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(out_bytes), GL_MAP_READ_BIT));
  if (mapped == nullptr) {
    terrain::Status s = gl_check("reading the picture back");
    return s ? Error{"glMapBufferRange returned no memory", ""} : s.error();
  }
  terrain::Picture picture;
  picture.width = camera.width;
  picture.height = camera.height;
  picture.rgb.resize(pixels * 3);
  picture.depth.resize(pixels);
  for (std::size_t i = 0; i < pixels; ++i) {
    const std::uint32_t rgba = mapped[4 * i];
    picture.rgb[3 * i] = static_cast<std::uint8_t>(rgba & 0xffu);
    picture.rgb[3 * i + 1] = static_cast<std::uint8_t>((rgba >> 8) & 0xffu);
    picture.rgb[3 * i + 2] = static_cast<std::uint8_t>((rgba >> 16) & 0xffu);
    std::memcpy(&picture.depth[i], &mapped[4 * i + 1], sizeof(float));
    picture.total_steps += mapped[4 * i + 2];
  }
  glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
  if (options.progress) options.progress(1.0f);
  if (terrain::Status s = gl_check("reading the picture back"); !s) return s.error();
  return picture;
}

}  // namespace gpu
