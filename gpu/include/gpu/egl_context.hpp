// A headless OpenGL ES 3.1+ context through EGL, with no window system: EGL_EXT_platform_device
// (NVIDIA, Mesa and others) first, then Mesa's surfaceless platform. Every EGL call is checked;
// a failed setup releases what it made and says why.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "terrain/result.hpp"

namespace gpu {

/// Which EGL platform to open.
enum class EglPlatform {
  automatic,    ///< devices (EGL_EXT_platform_device) in order, then Mesa surfaceless
  device,       ///< only EGL_EXT_platform_device
  surfaceless,  ///< only EGL_MESA_platform_surfaceless
};

struct ContextOptions {
  EglPlatform platform = EglPlatform::automatic;
  int device = -1;  ///< index among the EGL devices (platform device); -1: the first that works
};

/// One headless GLES context. Use it from one thread at a time: Scope makes it current on the
/// calling thread (under the context's lock) and releases it at the end.
class EglContext {
 public:
  /// Opens a display, initialises EGL and makes an ES 3.1 context that can run compute shaders.
  static terrain::Result<std::unique_ptr<EglContext>> create(const ContextOptions& options = {});
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  /// GL_RENDERER, GL_VERSION and the platform used, e.g. "llvmpipe (LLVM 15.0.6, 256 bits); OpenGL
  /// ES 3.2 Mesa 22.3.6; surfaceless".
  const std::string& description() const { return description_; }
  const std::string& renderer() const { return renderer_; }

  /// Holds the context current on this thread (and its lock) while alive.
  class Scope {
   public:
    explicit Scope(EglContext& context);
    ~Scope();
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;
    /// Whether making the context current worked (else status() says why).
    bool ok() const { return status_.ok(); }
    const terrain::Status& status() const { return status_; }

   private:
    EglContext& context_;
    std::unique_lock<std::mutex> lock_;
    terrain::Status status_{terrain::Ok{}};
  };

  /// Compiles and links a compute shader; the error carries the driver's info log. Call within a
  /// Scope. Returns the GL program name.
  terrain::Result<unsigned> compile_compute(std::string_view source);
  /// Compiles (without linking) a fragment shader: tests use it to check that the GLSL the
  /// browser concatenates is valid GLSL ES 3.00. Call within a Scope.
  terrain::Status check_fragment_shader(std::string_view source);

  struct Handles;  ///< the EGL objects (defined in the source file)

 private:
  EglContext() = default;
  std::unique_ptr<Handles> handles_;
  std::mutex mutex_;
  std::string renderer_;
  std::string description_;
};

}  // namespace gpu
