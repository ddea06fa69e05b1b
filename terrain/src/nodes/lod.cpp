#include "nodes/lod.hpp"

#include <algorithm>
#include <cmath>

#include "field_reader.hpp"

namespace terrain {
namespace {

// Pool: ln(coarse_spacing), ln(fine_spacing).
Result<NodeParams> parse_lod(FieldReader& reader, ParseContext&) {
  NodeParams out;
  const double coarse = reader.number("coarse_spacing", std::nullopt, {0.0, 1e6, true});
  const double fine = reader.number("fine_spacing", std::nullopt, {0.0, 1e6, true});
  if (reader.ok() && !(fine < coarse)) {
    reader.fail("must be smaller than coarse_spacing", "fine_spacing");
  }
  if (!reader.ok()) return reader.error();
  out.pool = {static_cast<float>(std::log(coarse)), static_cast<float>(std::log(fine))};
  out.canonical = reader.canonical();
  return out;
}

void lod_combine(const float* params, const PointBlock& points, const FieldBlock& a,
                 const FieldBlock& b, FieldBlock& out) {
  const float t = lod_blend_factor(params, points.spacing);
  const float s = 1.0f - t;
  for (int i = 0; i < points.count; ++i) {
    out.f[i] = s * a.f[i] + t * b.f[i];
    out.fx[i] = s * a.fx[i] + t * b.fx[i];
    out.fy[i] = s * a.fy[i] + t * b.fy[i];
    out.a[i] = s * a.a[i] + t * b.a[i];
    out.ax[i] = s * a.ax[i] + t * b.ax[i];
    out.ay[i] = s * a.ay[i] + t * b.ay[i];
  }
}

// The mix of the two children's bounds at one blend factor.
NodeBounds mixed(float t, const NodeBounds& a, const NodeBounds& b) {
  if (t <= 0.0f) return a;
  if (t >= 1.0f) return b;
  const float s = 1.0f - t;
  NodeBounds out;
  out.support = a.support.united(b.support);
  out.elevation = {s * a.elevation.lo + t * b.elevation.lo,
                   s * a.elevation.hi + t * b.elevation.hi};
  out.weight = {s * a.weight.lo + t * b.weight.lo, s * a.weight.hi + t * b.weight.hi};
  out.elevation_lipschitz = s * a.elevation_lipschitz + t * b.elevation_lipschitz;
  out.weight_lipschitz = s * a.weight_lipschitz + t * b.weight_lipschitz;
  return out;
}

// f = (1 − t)A + tB with t a function of the spacing alone: over a band of spacings the bounds
// are linear in t, so the mixes at the band's two ends hold between them.
NodeBounds lod_bounds(const float* params, const BoundsQuery& query, const NodeBounds& a,
                      const NodeBounds& b) {
  const float fine = lod_blend_factor(params, query.spacing);
  const float coarse = lod_blend_factor(params, query.coarsest());
  if (fine == coarse) return mixed(fine, a, b);
  const NodeBounds x = mixed(fine, a, b), y = mixed(coarse, a, b);
  NodeBounds out;
  out.support = x.support.united(y.support);
  out.elevation = x.elevation.hull(y.elevation);
  out.weight = x.weight.hull(y.weight);
  out.elevation_lipschitz = std::max(x.elevation_lipschitz, y.elevation_lipschitz);
  out.weight_lipschitz = std::max(x.weight_lipschitz, y.weight_lipschitz);
  return out;
}

}  // namespace

float lod_blend_factor(const float* params, float spacing) {
  if (spacing <= 0.0f) return 1.0f;
  const float x = (params[0] - std::log(spacing)) / (params[0] - params[1]);
  const float t = std::clamp(x, 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

const NodeType& lod_node_type() {
  static const NodeType type{
      .id = 19,
      .name = "lod",
      .category = NodeCategory::binary,
      .min_children = 2,
      .max_children = 2,
      .summary =
          "level-of-detail switch: the first child when sampled coarsely, the second when "
          "sampled finely, interpolated between",
      .parse = parse_lod,
      .kernels = {.combine = lod_combine, .combine_bounds = lod_bounds},
      .example_json = R"({"type": "lod", "coarse_spacing": 50, "fine_spacing": 5, "children": [
 {"type": "disc", "center": [0, 0], "radius": 1000, "elevation": 150},
 {"type": "disc", "center": [0, 0], "radius": 1000, "elevation": 150,
  "noise": {"kind": "fbm", "amplitude": 20, "wavelength": 100, "seed": 9}}]})",
      .loop_iterations = no_loops,
      .shader = {.call = "lod_combine($at, $s, $a, $b)"},
  };
  return type;
}

}  // namespace terrain
