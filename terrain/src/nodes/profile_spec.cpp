#include "nodes/profile_spec.hpp"

#include <vector>

#include "terrain/contour.hpp"

namespace terrain {
namespace {

std::optional<Profile> take(FieldReader& reader, Result<Profile> profile) {
  if (!profile) {
    reader.fail(profile.error().message);
    return std::nullopt;
  }
  return std::move(profile).value();
}

float num(FieldReader& r, std::string_view key, double fallback, double min, double max) {
  return static_cast<float>(r.number(key, fallback, {min, max}));
}

}  // namespace

std::optional<Profile> read_profile(FieldReader& r, std::span<const std::string_view> presets) {
  const std::string preset = r.choice("preset", std::nullopt, presets);
  if (!r.ok()) return std::nullopt;
  std::optional<Profile> out;
  if (preset == "stream") {
    const float width = num(r, "width", 4.0, 0.01, 1e4);
    const float depth = num(r, "depth", 1.0, 0.0, 1e3);
    if (r.ok()) out = take(r, Profile::stream(width, depth));
  } else if (preset == "river" || preset == "meander") {
    const float width = num(r, "width", 30.0, 0.01, 1e4);
    const float depth = num(r, "depth", 4.0, 0.0, 1e3);
    const float bank = num(r, "bank_width", 20.0, 0.0, 1e4);
    const float asym = preset == "meander" ? num(r, "asymmetry", 0.5, -1.0, 1.0) : 0.0f;
    if (r.ok()) {
      out = take(r, preset == "river" ? Profile::river(width, depth, bank)
                                      : Profile::meander(width, depth, bank, asym));
    }
  } else if (preset == "road") {
    const float width = num(r, "width", 12.0, 0.1, 1e3);
    const float carriageway = num(r, "carriageway", 7.0, 0.1, 1e3);
    const float embankment = num(r, "embankment", 10.0, 0.0, 1e3);
    const float crown = num(r, "crown", 0.0, 0.0, 10.0);
    if (r.ok()) out = take(r, Profile::road(width, carriageway, embankment, crown));
  } else if (preset == "lake") {
    const float depth = num(r, "depth", 10.0, 0.0, 1e4);
    const float shore = num(r, "shore_width", 0.2, 0.0, 1.0);
    if (r.ok()) out = take(r, lake_profile(depth, shore));
  } else if (preset == "crater") {
    const float depth = num(r, "depth", 50.0, 0.0, 1e4);
    const float rim = num(r, "rim_height", 15.0, 0.0, 1e4);
    const float rim_width = num(r, "rim_width", 0.4, 0.0, 10.0);
    if (r.ok()) out = take(r, crater_profile(depth, rim, rim_width));
  } else if (preset == "plateau") {
    const float height = num(r, "height", 50.0, -1e4, 1e4);
    const float cliff = num(r, "cliff_width", 0.2, 0.0, 2.0);
    if (r.ok()) out = take(r, plateau_profile(height, cliff));
  } else if (preset == "custom") {
    const nlohmann::json* points = r.raw("points");
    std::vector<ProfilePoint> parsed;
    nlohmann::json canonical = nlohmann::json::array();
    if (points == nullptr || !points->is_array()) {
      r.fail("must be an array of [d, h] pairs", "points");
      return std::nullopt;
    }
    for (std::size_t i = 0; i < points->size(); ++i) {
      const nlohmann::json& p = (*points)[i];
      if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number() ||
          !std::isfinite(p[0].get<double>()) || !std::isfinite(p[1].get<double>())) {
        r.fail_at("must be a pair of finite numbers [d, h]",
                  pointer_join(r.pointer() + "/points", i));
        return std::nullopt;
      }
      parsed.push_back(
          {static_cast<float>(p[0].get<double>()), static_cast<float>(p[1].get<double>())});
      canonical.push_back({p[0].get<double>(), p[1].get<double>()});
    }
    r.canonical()["points"] = canonical;
    out = take(r, Profile::custom(parsed));
  }
  return out;
}

}  // namespace terrain
