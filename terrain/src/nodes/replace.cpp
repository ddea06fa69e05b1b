#include "nodes/replace.hpp"

#include <array>

#include "field_reader.hpp"
#include "nodes/binary_common.hpp"

namespace terrain {
namespace {

Result<NodeParams> parse_replace(FieldReader& reader, ParseContext&) {
  static constexpr std::array<std::string_view, 2> kModes{"keep", "progressive"};
  NodeParams out;
  const std::string mode = reader.choice("weight", "keep", kModes);
  if (!reader.ok()) return reader.error();
  out.pool = {mode == "progressive" ? 1.0f : 0.0f};
  out.canonical = reader.canonical();
  return out;
}

// `out` may alias `a`: each point's inputs are read before its outputs are written.
template <bool kProgressive>
TERRAIN_SIMD_INLINE void replace_points(int count, const FieldBlock& a, const FieldBlock& b,
                                        FieldBlock& out) {
  for (int i = 0; i < count; ++i) {
    float w, wx, wy;
    clamped_weight(b, i, w, wx, wy);
    const float diff = b.f[i] - a.f[i];
    const float fx = a.fx[i] + w * (b.fx[i] - a.fx[i]) + wx * diff;
    const float fy = a.fy[i] + w * (b.fy[i] - a.fy[i]) + wy * diff;
    const float f = a.f[i] + w * diff;
    float alpha = a.a[i], alpha_x = a.ax[i], alpha_y = a.ay[i];
    if constexpr (kProgressive) {
      alpha = (1.0f - w) * a.a[i] + w * w;
      alpha_x = (1.0f - w) * a.ax[i] - wx * a.a[i] + 2.0f * w * wx;
      alpha_y = (1.0f - w) * a.ay[i] - wy * a.a[i] + 2.0f * w * wy;
    }
    out.f[i] = f;
    out.fx[i] = fx;
    out.fy[i] = fy;
    out.a[i] = alpha;
    out.ax[i] = alpha_x;
    out.ay[i] = alpha_y;
  }
}

TERRAIN_SIMD_CLONES void replace_combine(const float* params, const PointBlock& points,
                                         const FieldBlock& a, const FieldBlock& b,
                                         FieldBlock& out) {
  if (params[0] != 0.0f) {
    replace_points<true>(points.count, a, b, out);
  } else {
    replace_points<false>(points.count, a, b, out);
  }
}

NodeBounds replace_bounds(const float* params, const BoundsQuery&, const NodeBounds& a,
                          const NodeBounds& b) {
  const bool progressive = params[0] != 0.0f;
  NodeBounds out = a;
  if (progressive) out.support = a.support.united(b.support);
  if (has_no_weight(b)) return out;
  const float w_max = std::min(b.weight.hi, 1.0f);
  out.elevation = a.elevation.hull(b.elevation);
  // ∇f = (1−w)∇f_A + w∇f_B + ∇w (f_B − f_A), with w in [w_lo, w_max]: the first two terms are
  // linear in w, so their bound is largest at one end of that range.
  const float w_min = std::clamp(b.weight.lo, 0.0f, w_max);
  auto mixed = [&](float w) {
    return (1.0f - w) * a.elevation_lipschitz + w * b.elevation_lipschitz;
  };
  const float children_slope = std::min(std::max(a.elevation_lipschitz, b.elevation_lipschitz),
                                        std::max(mixed(w_min), mixed(w_max)) * 1.00001f);
  out.elevation_lipschitz =
      children_slope + b.weight_lipschitz * max_difference(a.elevation, b.elevation);
  if (progressive) {
    out.weight = {0.0f, std::max(a.weight.hi, w_max)};
    out.weight_lipschitz = a.weight_lipschitz + b.weight_lipschitz * (a.weight.hi + 2.0f * w_max);
  }
  return out;
}

}  // namespace

const NodeType& replace_node_type() {
  static const NodeType type{
      .id = 17,
      .name = "replace",
      .category = NodeCategory::binary,
      .min_children = 2,
      .max_children = 2,
      .second_child_acts_by_weight = true,
      .summary = "the second child replaces the first where it has weight (lakes, roads, craters)",
      .parse = parse_replace,
      .kernels = {.combine = replace_combine, .combine_bounds = replace_bounds},
      .example_json = R"({"type": "replace", "weight": "keep", "children": [
 {"type": "disc", "center": [0, 0], "radius": 3000, "elevation": 200,
  "noise": {"kind": "fbm", "amplitude": 100, "wavelength": 1200, "seed": 3}},
 {"type": "disc", "center": [300, 200], "radius": 800, "elevation": 120}]})",
      .loop_iterations = no_loops,
      .shader = {.call = "replace_combine($at, $a, $b)"},
  };
  return type;
}

}  // namespace terrain
