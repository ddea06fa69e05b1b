// libFuzzer target: scene JSON validation must refuse any input with an Error (never crash,
// never hang, never throw) and accept only scenes that compile.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "terrain/program.hpp"
#include "terrain/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  // Erosion within a small budget: the example scenes' 512² grids are refused (the refusal is
  // what is fuzzed there), and a mutated one never spends seconds of the run.
  terrain::ParseOptions options;
  options.limits.max_erosion_work = std::int64_t{1} << 18;
  options.limits.max_erosion_evaluations = std::int64_t{1} << 22;
  terrain::Result<terrain::Scene> scene = terrain::parse_scene_text(text, options);
  if (scene) {
    terrain::Result<terrain::Program> program = terrain::compile(*scene);
    (void)program;
  }
  return 0;
}
