// GPU grid evaluation: interprets a terrain::Program in an OpenGL ES compute shader (gpu/glsl/,
// the same GLSL node functions the browser uses) and returns the CPU reference's heights and
// gradients (within float rounding; tests/gpu checks 1 cm and 0.5° on every example).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/egl_context.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/result.hpp"

namespace gpu {

struct GpuOptions {
  ContextOptions context;
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

  /// The GL renderer and version (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
  std::string device_name() const;

 private:
  GpuEvaluator() = default;
  struct State;
  struct Run;
  terrain::Status run(const terrain::Program& program, const Run& request);
  std::unique_ptr<EglContext> context_;
  std::unique_ptr<State> state_;
};

/// The parameter pool as the shaders read it: the program's pool with each fractal's spare slot
/// 14 set to its octave gain r^−H, rounded from double as the CPU does (GLSL has no double pow,
/// and the warped fractal amplifies an ulp without bound). Every GLSL loader (the browser too)
/// uploads this, not Program::pool.
std::vector<float> prepare_pool(const terrain::Program& program);

/// The GLSL sources shared with the browser, in the order they are concatenated (after a
/// backend prelude): noise.glsl, nodes.glsl, interpreter.glsl.
std::string_view shared_glsl();
/// The complete compute shader for the given stack sizes (for tests and diagnostics).
std::string compute_shader_source(int max_fields, int max_frames);

}  // namespace gpu
