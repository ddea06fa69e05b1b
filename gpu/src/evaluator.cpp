#include "gpu/evaluator.hpp"

#include <GLES3/gl31.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <list>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "glsl_sources.hpp"
#include "terrain/node.hpp"

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

// The node types each category of instruction may name, and whether the shader has them.
bool shader_has(Op op, std::uint16_t type) {
  switch (op) {
    case Op::leaf:
      return type == 1 || type == 2 || type == 3;  // disc, curve, contour
    case Op::combine:
      return type == 17 || type == 18 || type == 19;  // replace, add, lod
    case Op::warp_begin:
    case Op::warp_end:
      return type == 32 || type == 33;  // transform, warp
    case Op::blend_begin:
    case Op::blend_add:
    case Op::blend_end:
    case Op::cull:
    case Op::group:
      return true;
  }
  return false;
}

std::string type_name(std::uint16_t id) {
  for (const terrain::NodeType* t : terrain::node_types()) {
    if (t->id == id) return std::string(t->name);
  }
  return "unknown";
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

}  // namespace

std::vector<float> prepare_pool(const terrain::Program& program) {
  std::vector<float> pool = program.pool;
  constexpr std::size_t kLacunarity = 6, kHurst = 7, kGain = 14, kFractalFloats = 16;
  auto fill = [&pool](std::size_t fractal) {
    if (fractal + kFractalFloats > pool.size()) return;
    pool[fractal + kGain] =
        static_cast<float>(std::pow(static_cast<double>(pool[fractal + kLacunarity]),
                                    -static_cast<double>(pool[fractal + kHurst])));
  };
  for (const terrain::Instruction& ins : program.code) {
    if (ins.op == Op::leaf && ins.type == 1) fill(ins.params + 4);  // disc: fractal after 4 floats
    if (ins.op == Op::warp_begin && ins.type == 33) fill(ins.params);  // warp: the fractal
  }
  return pool;
}

namespace {

struct Shader {
  GLuint program = 0;
  GLint program_size = -1, first = -1, count = -1, grid_width = -1, spacing = -1;
};

struct Uploaded {
  std::string key;
  GLuint code = 0;
  GLuint pool = 0;
  std::pair<int, int> stacks;
};

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
  std::map<std::pair<int, int>, Shader> shaders;
  std::list<Uploaded> programs;  // most recently used first
  GLuint positions = 0;
  std::size_t positions_bytes = 0;
  GLuint results = 0;
  std::size_t results_bytes = 0;
  GLuint max_groups = 65535;

  ~State() {
    for (auto& [key, s] : shaders) glDeleteProgram(s.program);
    for (Uploaded& u : programs) {
      glDeleteBuffers(1, &u.code);
      glDeleteBuffers(1, &u.pool);
    }
    glDeleteBuffers(1, &positions);
    glDeleteBuffers(1, &results);
  }
};

struct GpuEvaluator::Run {
  std::span<const float> positions;  // (x, y) pairs, or columns then rows
  std::size_t count = 0;
  int grid_width = 0;
  float spacing = 0.0f;
  float* f = nullptr;
  float* fx = nullptr;
  float* fy = nullptr;
};

std::string_view shared_glsl() {
  static const std::string text = std::string(glsl::noise()) + "\n" + std::string(glsl::nodes()) +
                                  "\n" + std::string(glsl::interpreter());
  return text;
}

std::string compute_shader_source(int max_fields, int max_frames) {
  return "#version 310 es\n#define TERRAIN_MAX_FIELDS " + std::to_string(max_fields) +
         "\n#define TERRAIN_MAX_FRAMES " + std::to_string(max_frames) + "\n" +
         std::string(glsl::compute_prelude()) + "\n" + std::string(shared_glsl()) + "\n" +
         std::string(glsl::compute_main());
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
  for (std::size_t pc = 0; pc < program.code.size(); ++pc) {
    const terrain::Instruction& ins = program.code[pc];
    if (static_cast<std::uint16_t>(ins.op) > static_cast<std::uint16_t>(Op::warp_end)) {
      return Error{"instruction " + std::to_string(pc) + " has an unknown op", ""};
    }
    if (!shader_has(ins.op, ins.type)) {
      return Error{"the GPU evaluator does not implement node type '" + type_name(ins.type) +
                       "' (id " + std::to_string(ins.type) + ", node " + std::to_string(ins.node) +
                       "); evaluate this program on the CPU",
                   ""};
    }
  }
  if (program.code.empty()) return Error{"the program is empty", ""};
  return terrain::Ok{};
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
  if (grid.width <= 0 || grid.height <= 0) return Error{"the grid is empty", ""};
  terrain::GridResult out;
  out.width = grid.width;
  out.height = grid.height;
  const auto w = static_cast<std::size_t>(grid.width);
  const auto h = static_cast<std::size_t>(grid.height);
  std::vector<float> table(w + h);
  // Rounded exactly as terrain::evaluate_grid does: double, then float.
  for (int i = 0; i < grid.width; ++i) {
    table[static_cast<std::size_t>(i)] = static_cast<float>(grid.origin_x + grid.step * i);
  }
  for (int j = 0; j < grid.height; ++j) {
    table[w + static_cast<std::size_t>(j)] = static_cast<float>(grid.origin_y + grid.step * j);
  }
  out.elevation.resize(w * h);
  out.gradient_x.resize(w * h);
  out.gradient_y.resize(w * h);
  Run request;
  request.positions = table;
  request.count = w * h;
  request.grid_width = grid.width;
  request.spacing = grid.lod_spacing < 0.0f ? static_cast<float>(grid.step) : grid.lod_spacing;
  request.f = out.elevation.data();
  request.fx = out.gradient_x.data();
  request.fy = out.gradient_y.data();
  if (terrain::Status s = run(program, request); !s) return s.error();
  return out;
}

terrain::Status GpuEvaluator::run(const terrain::Program& program, const Run& request) {
  if (terrain::Status s = supports(program); !s) return s;
  if (request.count == 0) return terrain::Ok{};
  if (request.count > 0xffffffffull / 2) return Error{"too many points for one call", ""};
  EglContext::Scope scope(*context_);
  if (!scope.ok()) return scope.status();
  State& st = *state_;
  // A stale error from elsewhere must not be blamed on this call.
  static_cast<void>(gl_check("before evaluation"));

  // The program's buffers, uploaded once per program version.
  const std::string key = program.scene_hash + "/" + std::to_string(fingerprint(program));
  auto it = std::find_if(st.programs.begin(), st.programs.end(),
                         [&](const Uploaded& u) { return u.key == key; });
  if (it != st.programs.end()) {
    st.programs.splice(st.programs.begin(), st.programs, it);
  } else {
    Uploaded u;
    u.key = key;
    u.code = make_buffer(program.code.data(), program.code.size() * sizeof(terrain::Instruction));
    const std::vector<float> pool = prepare_pool(program);
    u.pool = make_buffer(pool.data(), pool.size() * sizeof(float));
    u.stacks = {round_up(program.max_field_depth + 1, 4), round_up(program.max_frame_depth + 1, 2)};
    if (terrain::Status s = gl_check("uploading the program"); !s) {
      glDeleteBuffers(1, &u.code);
      glDeleteBuffers(1, &u.pool);
      return s;
    }
    st.programs.push_front(std::move(u));
    while (st.programs.size() > st.capacity) {
      glDeleteBuffers(1, &st.programs.back().code);
      glDeleteBuffers(1, &st.programs.back().pool);
      st.programs.pop_back();
    }
  }
  const Uploaded& uploaded = st.programs.front();

  // The shader for these stack sizes, compiled once.
  auto found = st.shaders.find(uploaded.stacks);
  if (found == st.shaders.end()) {
    std::string source = compute_shader_source(uploaded.stacks.first, uploaded.stacks.second);
    if (st.glsl_version == 320)
      source.replace(0, std::strlen("#version 310 es"), "#version 320 es");
    terrain::Result<unsigned> compiled = context_->compile_compute(source);
    if (!compiled) return compiled.error();
    Shader s;
    s.program = compiled.value();
    s.program_size = glGetUniformLocation(s.program, "u_program_size");
    s.first = glGetUniformLocation(s.program, "u_first");
    s.count = glGetUniformLocation(s.program, "u_count");
    s.grid_width = glGetUniformLocation(s.program, "u_grid_width");
    s.spacing = glGetUniformLocation(s.program, "u_spacing");
    found = st.shaders.emplace(uploaded.stacks, s).first;
  }
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

}  // namespace gpu
