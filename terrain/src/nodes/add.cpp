#include "nodes/add.hpp"

#include <array>

#include "field_reader.hpp"
#include "nodes/binary_common.hpp"

namespace terrain {
namespace {

Result<NodeParams> parse_add(FieldReader& reader, ParseContext&) {
  static constexpr std::array<std::string_view, 2> kModes{"keep", "sum"};
  NodeParams out;
  const std::string mode = reader.choice("weight", "keep", kModes);
  if (!reader.ok()) return reader.error();
  out.pool = {mode == "sum" ? 1.0f : 0.0f};
  out.canonical = reader.canonical();
  return out;
}

void add_combine(const float* params, const PointBlock& points, const FieldBlock& a,
                 const FieldBlock& b, FieldBlock& out) {
  const bool sum = params[0] != 0.0f;
  for (int i = 0; i < points.count; ++i) {
    float w, wx, wy;
    clamped_weight(b, i, w, wx, wy);
    const float f = a.f[i] + w * b.f[i];
    const float fx = a.fx[i] + w * b.fx[i] + wx * b.f[i];
    const float fy = a.fy[i] + w * b.fy[i] + wy * b.f[i];
    float alpha = a.a[i], alpha_x = a.ax[i], alpha_y = a.ay[i];
    if (sum) {
      alpha += w * w;
      alpha_x += 2.0f * w * wx;
      alpha_y += 2.0f * w * wy;
    }
    out.f[i] = f;
    out.fx[i] = fx;
    out.fy[i] = fy;
    out.a[i] = alpha;
    out.ax[i] = alpha_x;
    out.ay[i] = alpha_y;
  }
}

NodeBounds add_bounds(const float* params, const BoundsQuery&, const NodeBounds& a,
                      const NodeBounds& b) {
  const bool sum = params[0] != 0.0f;
  NodeBounds out = a;
  if (sum) out.support = a.support.united(b.support);
  if (has_no_weight(b)) return out;
  const float w_max = std::min(b.weight.hi, 1.0f);
  const float b_abs = std::max(std::abs(b.elevation.lo), std::abs(b.elevation.hi));
  out.elevation = {a.elevation.lo + std::min(0.0f, w_max * b.elevation.lo),
                   a.elevation.hi + std::max(0.0f, w_max * b.elevation.hi)};
  out.elevation_lipschitz =
      a.elevation_lipschitz + w_max * b.elevation_lipschitz + b.weight_lipschitz * b_abs;
  if (sum) {
    out.weight = {a.weight.lo, a.weight.hi + w_max * w_max};
    out.weight_lipschitz = a.weight_lipschitz + 2.0f * w_max * b.weight_lipschitz;
  }
  return out;
}

}  // namespace

const NodeType& add_node_type() {
  static const NodeType type{
      .id = 18,
      .name = "add",
      .category = NodeCategory::binary,
      .min_children = 2,
      .max_children = 2,
      .second_child_acts_by_weight = true,
      .summary =
          "adds the second child's elevation, scaled by its weight, to the first (dunes, "
          "details)",
      .parse = parse_add,
      .kernels = {.combine = add_combine, .combine_bounds = add_bounds},
      .example_json = R"({"type": "add", "weight": "keep", "children": [
 {"type": "disc", "center": [0, 0], "radius": 3000, "elevation": 100},
 {"type": "disc", "center": [0, 0], "radius": 1500, "elevation": 0,
  "noise": {"kind": "ridged", "amplitude": 15, "wavelength": 120, "octaves": 4, "seed": 5}}]})",
      .loop_iterations = no_loops,
      .shader = {.call = "add_combine($at, $a, $b)"},
  };
  return type;
}

}  // namespace terrain
