#include "nodes/blend.hpp"

#include <algorithm>

#include "field_reader.hpp"
#include "simd.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

constexpr int kThreshold = 0, kBase = 1;

Result<NodeParams> parse_blend(FieldReader& reader, ParseContext& context) {
  NodeParams out;
  // The background's weight is divided by the threshold: below 1e-4 the bounds of a blend whose
  // base is far from its children's heights overflow float32 (docs/scene-format.md).
  const double threshold = reader.number("threshold", 0.5, {1e-4, 1.0});
  // The default background is the scene's base level.
  const double base = reader.number("base", context.base_elevation, {-1e5, 1e5});
  if (!reader.ok()) return reader.error();
  out.pool = {static_cast<float>(threshold), static_cast<float>(base)};
  out.canonical = reader.canonical();
  return out;
}

}  // namespace

void blend_clear(FieldBlock& acc, int count) {
  acc.clear(count);
}

TERRAIN_SIMD_CLONES void blend_accumulate(FieldBlock& acc, const FieldBlock& c, int count) {
  for (int i = 0; i < count; ++i) {
    acc.f[i] += c.a[i] * c.f[i];
    acc.a[i] += c.a[i];
    acc.fx[i] += c.ax[i] * c.f[i] + c.a[i] * c.fx[i];
    acc.fy[i] += c.ay[i] * c.f[i] + c.a[i] * c.fy[i];
    acc.ax[i] += c.ax[i];
    acc.ay[i] += c.ay[i];
  }
}

TERRAIN_SIMD_CLONES void blend_finish(const float* params, FieldBlock& acc, int count) {
  const float threshold = params[kThreshold];
  const float base = params[kBase];
  for (int i = 0; i < count; ++i) {
    // Both cases are computed and one is selected, so the loop vectorises; the other's division
    // by a possibly zero sum is dropped.
    const float sum = acc.a[i];
    const float f = acc.f[i] / sum;
    const float fx = (acc.fx[i] - f * acc.ax[i]) / sum;
    const float fy = (acc.fy[i] - f * acc.ay[i]) / sum;
    const float bf = (acc.f[i] + (threshold - sum) * base) / threshold;
    const float bfx = (acc.fx[i] - base * acc.ax[i]) / threshold;
    const float bfy = (acc.fy[i] - base * acc.ay[i]) / threshold;
    const std::uint32_t weighted = simd::mask_of(sum >= threshold);
    acc.f[i] = simd::select(weighted, f, bf);
    acc.fx[i] = simd::select(weighted, fx, bfx);
    acc.fy[i] = simd::select(weighted, fy, bfy);
  }
}

void BlendBoundsAccumulator::add(const NodeBounds& child) {
  if (child.weight.hi <= 0.0f) return;  // no weight here: no influence
  support = support.united(child.support);
  elevation = elevation.hull(child.elevation);
  weight = {weight.lo + child.weight.lo, weight.hi + child.weight.hi};
  max_elevation_lipschitz = std::max(max_elevation_lipschitz, child.elevation_lipschitz);
  sum_weight_lipschitz += child.weight_lipschitz;
}

NodeBounds BlendBoundsAccumulator::finish(const float* params) const {
  const float threshold = params[kThreshold];
  const float base = params[kBase];
  NodeBounds b;
  b.support = support;
  b.weight = weight;
  b.weight_lipschitz = sum_weight_lipschitz;
  // f is a convex combination of the children's f and the base (see blend.hpp); its gradient is
  // Σ ∇α_i (f_i − f)/W + Σ α_i ∇f_i / W with W ≥ T, hence the bound below.
  b.elevation = elevation.hull(Interval::point(base));
  if (weight.lo >= threshold) b.elevation = elevation;  // the background never shows here
  b.elevation_lipschitz =
      max_elevation_lipschitz + sum_weight_lipschitz * b.elevation.width() / threshold;
  return b;
}

const NodeType& blend_node_type() {
  static const NodeType type{
      .id = 16,
      .name = "blend",
      .category = NodeCategory::blend,
      .min_children = 1,
      .max_children = 0xffff,
      .summary =
          "weighted average of any number of children, fading to a base level where "
          "their weights vanish",
      .parse = parse_blend,
      .kernels = {},
      .example_json = R"({"type": "blend", "threshold": 0.5, "base": 0, "children": [
 {"type": "disc", "center": [-800, 0], "radius": 1500, "elevation": 200,
  "noise": {"kind": "fbm", "amplitude": 80, "wavelength": 600, "seed": 1}},
 {"type": "disc", "center": [800, 0], "radius": 1500, "elevation": 350,
  "noise": {"kind": "fbm", "amplitude": 120, "wavelength": 900, "seed": 2}}]})",
      .loop_iterations = no_loops,
  };
  return type;
}

}  // namespace terrain
