// Parses a cross-section profile object shared by curve and contour nodes:
// {"preset": "stream" | "river" | "meander" | "road" | "lake" | "crater" | "plateau" | "custom",
// …}.
#pragma once

#include <span>
#include <string_view>

#include "field_reader.hpp"
#include "terrain/profile.hpp"

namespace terrain {

/// Reads one profile; `presets` lists those allowed here (curves: channel and road shapes,
/// contours: radial shapes). On error the reader holds the message.
std::optional<Profile> read_profile(FieldReader& reader, std::span<const std::string_view> presets);

}  // namespace terrain
