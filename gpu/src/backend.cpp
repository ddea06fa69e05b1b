#include "gpu/backend.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

namespace gpu {

GpuPointsBackend::GpuPointsBackend(std::unique_ptr<GpuEvaluator> evaluator)
    : evaluator_(std::move(evaluator)), name_("gpu: " + evaluator_->device_name()) {}

terrain::Status GpuPointsBackend::evaluate(const terrain::Program& program,
                                           std::span<const float> x, std::span<const float> y,
                                           float spacing, float* f, float* fx, float* fy) {
  if (terrain::Status supported = GpuEvaluator::supports(program); !supported) return supported;
  return evaluator_->evaluate(program, x, y, spacing, f, fx, fy);
}

terrain::Result<terrain::Picture> GpuPointsBackend::render(const terrain::Program& program,
                                                           const terrain::Box2& area,
                                                           const terrain::Camera& camera,
                                                           const terrain::RenderOptions& options) {
  return evaluator_->render(program, area, camera, options);
}

std::vector<EglDeviceInfo> list_egl_devices() {
  std::vector<EglDeviceInfo> devices;
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client == nullptr ||
      std::string_view(client).find("EGL_EXT_device_enumeration") == std::string_view::npos) {
    return devices;
  }
  auto query_devices =
      reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto query_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
      eglGetProcAddress("eglQueryDeviceStringEXT"));
  if (query_devices == nullptr || query_string == nullptr) return devices;
  EGLDeviceEXT found[16];
  EGLint count = 0;
  if (query_devices(16, found, &count) != EGL_TRUE) return devices;
  for (EGLint i = 0; i < count; ++i) {
    const char* extensions = query_string(found[i], EGL_EXTENSIONS);
    EglDeviceInfo info;
    info.index = i;
    info.extensions = extensions == nullptr ? "" : extensions;
    info.software = info.extensions.find("EGL_MESA_device_software") != std::string::npos;
    devices.push_back(std::move(info));
  }
  return devices;
}

terrain::Result<BackendChoice> choose_backend(std::string_view choice) {
  if (choice == "cpu") return BackendChoice{nullptr, "cpu: as configured"};
  if (choice != "gpu" && choice != "auto") {
    return terrain::Error{"backend must be auto, gpu or cpu", "/generation.backend"};
  }
  GpuOptions options;
  if (choice == "auto") {
    // Only hardware: pick the first EGL device that is not a software rasteriser.
    int hardware = -1;
    for (const EglDeviceInfo& d : list_egl_devices()) {
      if (!d.software) {
        hardware = d.index;
        break;
      }
    }
    if (hardware < 0) {
      return BackendChoice{nullptr,
                           "cpu: no hardware EGL device (software rasterisers are used only "
                           "with backend = gpu)"};
    }
    options.context.platform = EglPlatform::device;
    options.context.device = hardware;
  }
  terrain::Result<std::unique_ptr<GpuEvaluator>> evaluator = GpuEvaluator::create(options);
  if (!evaluator) {
    if (choice == "gpu") return evaluator.error();
    return BackendChoice{nullptr, "cpu: the GPU failed to start: " + evaluator.error().message};
  }
  auto backend = std::make_shared<GpuPointsBackend>(std::move(evaluator).value());
  std::string reason = backend->name();
  return BackendChoice{std::move(backend), std::move(reason)};
}

}  // namespace gpu
