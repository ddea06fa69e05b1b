#include "nodes/contour.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "nodes/profile_spec.hpp"
#include "nodes/stored_bounds.hpp"
#include "terrain/contour.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

// Pool layout: 0 elevation, 1 falloff (in ρ), 2 λ_f, 3 λ_α, 4 c_lo, 5 c_hi, 6..9 support box,
// then the contour block (terrain/contour.hpp).
constexpr int kElevation = 0, kFalloff = 1, kLipschitz = 2, kWeightLipschitz = 3, kCLo = 4,
              kCHi = 5, kBox = 6, kContour = 10;

// A millimetre at least: the sector profiles are scaled by 1/radius, whose bounds overflow
// float32 for radii near the smallest float.
constexpr NumberRule kContourRadiusRule{1e-3, 1e7};

constexpr std::array<std::string_view, 4> kContourPresets{"lake", "crater", "plateau", "custom"};

Result<NodeParams> parse_contour(FieldReader& reader, ParseContext&) {
  const Vec2 center = reader.vec2("center", std::nullopt, {-1e7, 1e7});
  const double elevation = reader.number("elevation", 0.0, {-1e5, 1e5});
  const double orientation = reader.number("orientation", 0.0, {-360.0, 360.0});
  std::vector<float> radii;
  if (reader.has("radius") && reader.has("radii")) {
    reader.fail("give either radius (a circle) or radii, not both", "radii");
    return reader.error();
  }
  if (reader.has("radii")) {
    const nlohmann::json* raw = reader.raw("radii");
    nlohmann::json canonical = nlohmann::json::array();
    if (!raw->is_array()) {
      reader.fail("must be an array of radii at equally spaced angles", "radii");
      return reader.error();
    }
    constexpr NumberRule kRadiusRule = kContourRadiusRule;
    for (std::size_t i = 0; i < raw->size(); ++i) {
      const nlohmann::json& r = (*raw)[i];
      reader.declare_number(pointer_join(reader.pointer() + "/radii", i), kRadiusRule);
      if (!r.is_number() || !std::isfinite(r.get<double>()) ||
          !within_as_float(r.get<double>(), kRadiusRule)) {
        return Error{"must be a radius in metres from 0.001 to 10000000",
                     pointer_join(reader.pointer() + "/radii", i)};
      }
      radii.push_back(static_cast<float>(r.get<double>()));
      canonical.push_back(r.get<double>());
    }
    reader.canonical()["radii"] = canonical;
  } else {
    const double r = reader.number("radius", std::nullopt, kContourRadiusRule);
    radii.assign(3, static_cast<float>(r));
    reader.canonical().erase("radius");
    reader.canonical()["radii"] = nlohmann::json::array({r, r, r});
  }
  if (!reader.ok()) return reader.error();

  const nlohmann::json* raw_profiles = reader.raw("profiles");
  if (raw_profiles == nullptr || !raw_profiles->is_array() || raw_profiles->empty()) {
    reader.fail("must be an array of 1 to 64 sector profiles", "profiles");
    return reader.error();
  }
  std::vector<Profile> profiles;
  nlohmann::json canonical_profiles = nlohmann::json::array();
  for (std::size_t i = 0; i < raw_profiles->size(); ++i) {
    FieldReader pr((*raw_profiles)[i], pointer_join(reader.pointer() + "/profiles", i));
    std::optional<Profile> profile = read_profile(pr, kContourPresets);
    pr.reject_unknown();
    if (!pr.ok()) return pr.error();
    profiles.push_back(*profile);
    canonical_profiles.push_back(pr.canonical());
  }
  reader.canonical()["profiles"] = std::move(canonical_profiles);

  const float angle = static_cast<float>(orientation * std::numbers::pi / 180.0);
  Result<Contour> contour = Contour::build(center, angle, radii, profiles);
  if (!contour) return Error{contour.error().message, reader.pointer() + contour.error().pointer};
  const double falloff = reader.number(
      "falloff", std::max(1.25, static_cast<double>(contour->max_rho()) * 1.1), {0.01, 100.0});
  if (!reader.ok()) return reader.error();

  // |∇ρ| ≤ sqrt(1 + (R'/R)²) / R over the plane (∇r and r·∇θ are orthonormal).
  const Interval radius = contour->radius_range();
  const float rho_gradient =
      std::sqrt(1.0f + std::pow(contour->max_radius_slope() / radius.lo, 2.0f)) / radius.lo;
  const Box2 support = contour->bounds(static_cast<float>(falloff));
  NodeParams out;
  out.pool = {static_cast<float>(elevation),
              static_cast<float>(falloff),
              contour->lipschitz(),
              Falloff::lipschitz(static_cast<float>(falloff)) * rho_gradient,
              contour->range().lo,
              contour->range().hi,
              support.lo.x,
              support.lo.y,
              support.hi.x,
              support.hi.y};
  contour->pack(out.pool);
  out.canonical = reader.canonical();
  return out;
}

void contour_leaf(const float* params, const PointBlock& points, FieldBlock& out) {
  const float falloff = params[kFalloff];
  const float cx = params[kContour], cy = params[kContour + 1];
  for (int i = 0; i < points.count; ++i) {
    const ContourSample c = contour_eval(params + kContour, {points.x[i], points.y[i]});
    out.f[i] = params[kElevation] + c.value;
    out.fx[i] = c.grad.x;
    out.fy[i] = c.grad.y;
    float g, dg;
    Falloff::eval(c.rho, falloff, g, dg);
    // ∇ρ = ∇r / R − r R' ∇θ / R², with ∇r = (p − c)/r and ∇θ = (−dy, dx)/r².
    float gx = 0.0f, gy = 0.0f;
    if (c.r > 0.0f) {
      const float dx = points.x[i] - cx, dy = points.y[i] - cy;
      const float inv_r = 1.0f / c.r;
      const float k = c.radius_slope / (c.radius * c.radius) * inv_r;
      gx = dx * inv_r / c.radius + k * dy;
      gy = dy * inv_r / c.radius - k * dx;
    }
    out.a[i] = g;
    out.ax[i] = dg * gx;
    out.ay[i] = dg * gy;
  }
}

NodeBounds contour_bounds(const float* params, const BoundsQuery& query) {
  return stored_bounds(stored_box(params + kBox),
                       {params[kElevation] + params[kCLo], params[kElevation] + params[kCHi]},
                       params[kLipschitz], params[kWeightLipschitz], query);
}

}  // namespace

namespace {
// Two profile searches: the sector's two neighbouring profiles.
std::size_t contour_loop_iterations(std::span<const float>) {
  return 2 * kShaderSearchLoops;
}
}  // namespace

const NodeType& contour_node_type() {
  static const NodeType type{
      .id = 3,
      .name = "contour",
      .category = NodeCategory::primitive,
      .min_children = 0,
      .max_children = 0,
      .summary =
          "a lake, crater or plateau: radial profiles around a centre inside a closed "
          "contour",
      .parse = parse_contour,
      .kernels = {.leaf = contour_leaf,
                  .leaf_bounds = contour_bounds,
                  .varies_with_spacing = never_varies_with_spacing},
      .example_json = R"({"type": "contour", "center": [0, 0], "elevation": 120, "orientation": 15,
 "radii": [900, 1100, 1000, 1250, 950, 800, 1000, 1150],
 "profiles": [{"preset": "lake", "depth": 25, "shore_width": 0.25},
              {"preset": "crater", "depth": 25, "rim_height": 30, "rim_width": 0.4}]})",
      .loop_iterations = contour_loop_iterations,
      .shader = {.call = "contour_leaf($at, $p)", .heavy = true},
  };
  return type;
}

}  // namespace terrain
