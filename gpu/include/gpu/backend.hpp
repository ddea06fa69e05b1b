// The GPU as terrain's PointsBackend, and the choice between GPU and CPU that the server's
// `generation.backend` option (auto | gpu | cpu) makes.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/evaluator.hpp"
#include "terrain/tile_source.hpp"

namespace gpu {

/// Adapts GpuEvaluator to terrain::PointsBackend; programs it cannot run are refused, so the
/// caller evaluates them on the CPU.
class GpuPointsBackend final : public terrain::PointsBackend {
 public:
  explicit GpuPointsBackend(std::unique_ptr<GpuEvaluator> evaluator);
  std::string name() const override { return name_; }
  terrain::Status evaluate(const terrain::Program& program, std::span<const float> x,
                           std::span<const float> y, float spacing, float* f, float* fx,
                           float* fy) override;
  /// GpuEvaluator::render; programs it cannot run are refused (the caller renders on the CPU).
  terrain::Result<terrain::Picture> render(const terrain::Program& program,
                                           const terrain::Box2& area, const terrain::Camera& camera,
                                           const terrain::RenderOptions& options) override;
  GpuEvaluator& evaluator() { return *evaluator_; }

 private:
  std::unique_ptr<GpuEvaluator> evaluator_;
  std::string name_;
};

/// An EGL device as EGL_EXT_device_enumeration lists it.
struct EglDeviceInfo {
  int index = 0;
  std::string extensions;
  bool software = false;  ///< Mesa's llvmpipe/softpipe (EGL_MESA_device_software)
};
/// The EGL devices of this machine (empty when EGL cannot enumerate devices).
std::vector<EglDeviceInfo> list_egl_devices();

/// What the configuration asks for, and why the result is what it is.
struct BackendChoice {
  std::shared_ptr<terrain::PointsBackend> backend;  ///< null: the CPU
  std::string reason;  ///< one line for the log: which device, or why the CPU
};

/// "cpu": the CPU. "gpu": the first EGL device that works, software rasterisers included (for
/// tests and llvmpipe benchmarks); an error when none does. "auto": a hardware EGL device when
/// there is one, else the CPU (llvmpipe is much slower than the CPU interpreter).
terrain::Result<BackendChoice> choose_backend(std::string_view choice);

}  // namespace gpu
