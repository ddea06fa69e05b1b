// libFuzzer target: planet definition JSON (docs/planet.md) must refuse any input with an Error
// (never crash, never throw), and a definition it accepts must round-trip: its canonical JSON
// parses back to the same canonical text, hence the same planet id.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "planet/definition.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const planet::Result<planet::PlanetDefinition> definition = planet::parse_planet_text(text);
  if (!definition) return 0;
  const std::string canonical = planet::canonical_text(*definition);
  const planet::Result<planet::PlanetDefinition> again = planet::parse_planet_text(canonical);
  if (!again || planet::canonical_text(*again) != canonical ||
      planet::planet_id(*again) != planet::planet_id(*definition)) {
    std::abort();
  }
  return 0;
}
