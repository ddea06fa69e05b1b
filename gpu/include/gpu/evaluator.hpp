// GPU grid evaluation: interprets a terrain::Program in an OpenGL ES compute shader (gpu/glsl/,
// the same GLSL node functions the browser uses) and returns the CPU reference's heights and
// gradients (within float rounding; tests/gpu checks 1 cm and 0.5° on every example).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gpu/egl_context.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/result.hpp"
#include "terrain/sphere_trace.hpp"

namespace gpu {

/// How the shaders evaluate a program (gpu/program_glsl.hpp).
enum class ShaderMode {
  interpreter,  ///< one shader per stack size interprets every program
  pruned,       ///< the interpreter without the code of node types the program does not use
  unrolled,     ///< the program's own unrolled evaluate_program: a shader per program structure
  automatic,    ///< unrolled where that pays (gpu::unroll_pays), else pruned
};

struct GpuOptions {
  ContextOptions context;
  ShaderMode shaders = ShaderMode::automatic;
  int cached_shaders = 32;  ///< compiled shader programs kept (least recently used goes)
  int cached_programs = 8;  ///< uploaded programs kept on the GPU (least recently used goes)
};

/// Evaluates compiled programs on one headless EGL context. Thread-safe (calls are serialised).
class GpuEvaluator {
 public:
  static terrain::Result<std::unique_ptr<GpuEvaluator>> create(const GpuOptions& options = {});
  ~GpuEvaluator();
  GpuEvaluator(const GpuEvaluator&) = delete;
  GpuEvaluator& operator=(const GpuEvaluator&) = delete;

  /// Whether this backend can run the program; the error names the first node type it cannot
  /// (so a caller falls back to the CPU instead of getting wrong heights).
  static terrain::Status supports(const terrain::Program& program);

  /// f and ∇f at the points (x[i], y[i]) (scene metres, the floats the CPU would use) at level
  /// of detail `spacing` (metres; 0 = full detail). fx and fy may be null.
  terrain::Status evaluate(const terrain::Program& program, std::span<const float> x,
                           std::span<const float> y, float spacing, float* f, float* fx, float* fy);

  /// The same over a regular grid, positions rounded exactly as terrain::evaluate_grid does
  /// (double, then float): only a column and a row table are uploaded.
  terrain::Result<terrain::GridResult> evaluate_grid(const terrain::Program& program,
                                                     const terrain::GridSpec& grid);

  /// Several grids of one size (tiles of one zoom and size, each with its own origin, step and
  /// level of detail) in one upload and one dispatch: every sample equals what evaluate_grid
  /// gives for its grid alone. Grids of different sizes are refused.
  terrain::Result<std::vector<terrain::GridResult>> evaluate_grids(
      const terrain::Program& program, std::span<const terrain::GridSpec> grids);

  /// The picture terrain::render draws for the same arguments, sphere-traced on the GPU by
  /// gpu/glsl/trace.glsl: same rays, same accelerated sphere tracing over the same
  /// LipschitzGrid (options.trace.bounds, or the one render builds, cached per program and
  /// area), same shading. The shader writes RGBA8 and the hit distance per pixel; the result is
  /// returned as terrain::Picture (RGB, depth −1 where the ray missed, total steps).
  /// options.threads is ignored; options.progress is called between dispatches.
  terrain::Result<terrain::Picture> render(const terrain::Program& program,
                                           const terrain::Box2& area, const terrain::Camera& camera,
                                           const terrain::RenderOptions& options = {});

  /// How many programs have been uploaded (upload cache misses) since creation.
  std::size_t program_uploads() const;
  /// How many compiled shaders are kept now (grid and tracing shaders), at most
  /// GpuOptions::cached_shaders of each.
  std::size_t compiled_shaders() const;

  /// The GL renderer and version (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
  std::string device_name() const;

 private:
  GpuEvaluator() = default;
  struct State;
  struct Run;
  terrain::Status run(const terrain::Program& program, const Run& request);
  // Within a Scope: the program's uploaded buffers (an Uploaded), from the cache or uploaded now.
  terrain::Result<const void*> upload(const terrain::Program& program);
  // Within a Scope: compiles a compute shader at the context's GLSL version.
  terrain::Result<unsigned> compile(const std::string& source);
  std::unique_ptr<EglContext> context_;
  std::unique_ptr<State> state_;
};

/// An upper estimate of the loop iterations one evaluation of `program` runs in the shaders: one
/// per instruction plus each node's own (NodeType::loop_iterations). llvmpipe silently ends the
/// loops of an invocation past 65 535 iterations in all, so work is split or refused by it.
std::size_t loop_iterations_per_evaluation(const terrain::Program& program);

/// The parameter pool as the shaders read it: the program's pool with each fractal's spare slot
/// 14 set to its octave gain r^−H, rounded from double as the CPU does (GLSL has no double pow,
/// and the warped fractal amplifies an ulp without bound). Every GLSL loader (the browser too)
/// uploads this, not Program::pool.
std::vector<float> prepare_pool(const terrain::Program& program);

/// The GLSL sources shared with the browser, in the order they are concatenated (after a
/// backend prelude): portable_math.glsl, noise.glsl, nodes.glsl, interpreter.glsl.
std::string_view shared_glsl();
/// The material model (material.glsl), light and air (lighting.glsl) and the sphere tracer
/// (trace.glsl) that shades with them, concatenated after shared_glsl(); besides the prelude's
/// program access it needs fetch_bounds(i) over terrain::LipschitzGrid::pack() and
/// fetch_water(i) over terrain::WaterRaster::surface.
std::string_view trace_glsl();
/// The material model and its lighting (material.glsl and lighting.glsl: the twins of
/// terrain/material.hpp and terrain/lighting.hpp), for shaders that
/// colour terrain without tracing it (the browser's planet mode).
std::string_view material_glsl();
/// The field- and frame-stack sizes (TERRAIN_MAX_FIELDS, TERRAIN_MAX_FRAMES) that a shader
/// interpreting `program` declares.
std::pair<int, int> shader_stacks(const terrain::Program& program);

/// What the shader evaluating one program is built from; programs with equal ones share it.
struct ProgramShader {
  int max_fields = 1;  ///< TERRAIN_MAX_FIELDS, TERRAIN_MAX_FRAMES (shader_stacks)
  int max_frames = 1;
  std::string defines;   ///< put before the shared GLSL (node_type_defines, TERRAIN_SPECIALISED)
  std::string unrolled;  ///< put after everything else (specialised_program_glsl), or empty
  /// Everything above in one string: equal keys, equal shaders.
  std::string key() const;
};
terrain::Result<ProgramShader> program_shader(const terrain::Program& program, ShaderMode mode);
/// The complete compute shader (for tests and diagnostics).
std::string compute_shader_source(const ProgramShader& shader);
/// The complete tracing compute shader.
std::string trace_shader_source(const ProgramShader& shader);

}  // namespace gpu
