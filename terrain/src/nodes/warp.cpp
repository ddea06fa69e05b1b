#include "nodes/warp.hpp"

#include <cmath>
#include <limits>

#include "field_reader.hpp"
#include "nodes/fractal_params.hpp"
#include "terrain/simd.hpp"

namespace terrain {
namespace {

// Pool: fractal for the x displacement; the y displacement uses the same with seed + 1.
noise::FractalParams component(const float* params, std::uint32_t axis) {
  noise::FractalParams p = unpack_fractal(params);
  p.seed = noise::hash(p.seed, axis);
  return p;
}

float displacement_bound(const noise::FractalParams& p, float octaves) {
  const Interval r = noise::fractal_range(p, octaves);
  return std::max(std::abs(r.lo), std::abs(r.hi));
}

// Bounds of one displacement component over the query box at its levels of detail (the octaves
// fractal2_at_spacing evaluates there): its own slope and range there when the box is finite (a
// box small beside the noise's wavelength moves and stretches little), else the global ones.
noise::RegionBounds component_bounds(const noise::FractalParams& p, const BoundsQuery& query) {
  const Interval octaves{noise::visible_octaves(p, query.coarsest()),
                         noise::visible_octaves(p, query.spacing)};
  const Box2& box = query.box;
  if (!box.is_finite()) {
    return noise::fractal_bounds_near(p, octaves, {}, std::numeric_limits<float>::infinity());
  }
  const float rounding =
      2e-7f * (std::abs(box.lo.x) + std::abs(box.hi.x) + std::abs(box.lo.y) + std::abs(box.hi.y));
  return noise::fractal_bounds_near(p, octaves, box.center(),
                                    0.5f * length(box.size()) * 1.000001f + rounding);
}

Result<NodeParams> parse_warp(FieldReader& reader, ParseContext& context) {
  NodeParams out;
  FieldReader noise_reader = reader.nested("noise");
  noise::FractalParams fractal = read_fractal(noise_reader, context, "fbm");
  reader.adopt("noise", noise_reader);
  if (!reader.ok()) return reader.error();
  if (fractal.kind == noise::Fractal::warped) {
    reader.fail("a displacement cannot itself be a warped fractal", "noise");
    return reader.error();
  }
  const float lipschitz = noise::fractal_lipschitz(fractal, static_cast<float>(fractal.octaves), 0);
  if (lipschitz * std::sqrt(2.0f) >= 1.0f) {
    reader.fail("amplitude is too large for the wavelength: the displacement's slope bound " +
                    std::to_string(lipschitz) +
                    " must stay below 0.707 so the warp is invertible (lower the amplitude or "
                    "raise the wavelength)",
                "noise");
    return reader.error();
  }
  pack_fractal(fractal, out.pool);
  out.canonical = reader.canonical();
  return out;
}

// q = p + d(p) and ∂q/∂p = I + ∂d/∂p, from the displacement and its derivatives.
TERRAIN_SIMD_CLONES void displace(const PointBlock& in, const float* dx, const float* dy,
                                  PointBlock& out, WarpJacobian& j) {
  out.count = in.count;
  out.spacing = in.spacing;
  for (int i = 0; i < in.count; ++i) {
    out.x[i] = in.x[i] + dx[i];
    out.y[i] = in.y[i] + dy[i];
    j.xx[i] += 1.0f;
    j.yy[i] += 1.0f;
  }
}

void warp_points(const float* params, const PointBlock& in, PointBlock& out, WarpJacobian& j) {
  const noise::FractalParams px = component(params, 1);
  const noise::FractalParams py = component(params, 2);
  // The components differ only in their seeds, so they share the octave count of the spacing.
  const auto n = static_cast<std::size_t>(in.count);
  alignas(64) float dx[kBlockSize];
  alignas(64) float dy[kBlockSize];
  noise::fractal2_at_spacing(px, in.spacing, in.x, in.y, n, dx, j.xx, j.xy);
  noise::fractal2_at_spacing(py, in.spacing, in.x, in.y, n, dy, j.yx, j.yy);
  displace(in, dx, dy, out, j);
  out.recompute_box();
}

TERRAIN_SIMD_CLONES void warp_field(const float*, int count, const WarpJacobian& j,
                                    FieldBlock& field) {
  for (int i = 0; i < count; ++i) {
    const float fx = field.fx[i], fy = field.fy[i], ax = field.ax[i], ay = field.ay[i];
    field.fx[i] = j.xx[i] * fx + j.yx[i] * fy;
    field.fy[i] = j.xy[i] * fx + j.yy[i] * fy;
    field.ax[i] = j.xx[i] * ax + j.yx[i] * ay;
    field.ay[i] = j.xy[i] * ax + j.yy[i] * ay;
  }
}

// The child sees q = p + d(p): the box moved by the displacement's range over it.
Box2 warp_box(const float* params, const BoundsQuery& query) {
  const Box2& box = query.box;
  if (box.empty()) return box;
  const noise::RegionBounds dx = component_bounds(component(params, 1), query);
  const noise::RegionBounds dy = component_bounds(component(params, 2), query);
  if (!box.is_finite()) {
    const float reach = std::max({std::abs(dx.value.lo), std::abs(dx.value.hi),
                                  std::abs(dy.value.lo), std::abs(dy.value.hi)});
    return box.expanded(reach);
  }
  // Rounded outwards by the float addition p + d.
  const Box2 moved{{box.lo.x + dx.value.lo, box.lo.y + dy.value.lo},
                   {box.hi.x + dx.value.hi, box.hi.y + dy.value.hi}};
  return moved.expanded(1e-6f * (1.0f + std::max({std::abs(moved.lo.x), std::abs(moved.hi.x),
                                                  std::abs(moved.lo.y), std::abs(moved.hi.y)})));
}

// ‖∂q/∂p‖ = ‖I + ∇d‖ ≤ 1 + ‖∇d‖_F ≤ 1 + √(L_x² + L_y²), with each component's slope over the
// parent's query box.
NodeBounds warp_bounds(const float* params, const BoundsQuery& query, const NodeBounds& child) {
  const noise::FractalParams p = component(params, 1);
  const float octaves = static_cast<float>(p.octaves);
  NodeBounds out = child;
  out.support = child.support.empty() ? child.support
                                      : child.support.expanded(displacement_bound(p, octaves));
  const noise::RegionBounds bx = component_bounds(p, query);
  const noise::RegionBounds by = component_bounds(component(params, 2), query);
  const double lx = bx.lipschitz, ly = by.lipschitz;
  // Or about the centre: ‖I + ∇d(p)‖ ≤ ‖I + ∇d(c)‖ + ‖∇d(p) − ∇d(c)‖_F, the first the exact
  // largest singular value (the stretch a box small beside the wavelength really sees).
  const double a = 1.0 + bx.gradient_at_centre.x, b = bx.gradient_at_centre.y;
  const double c = by.gradient_at_centre.x, d = 1.0 + by.gradient_at_centre.y;
  const double frobenius = a * a + b * b + c * c + d * d, determinant = a * d - b * c;
  const double largest = std::sqrt(
      0.5 * (frobenius +
             std::sqrt(std::max(0.0, frobenius * frobenius - 4.0 * determinant * determinant))));
  const double spread =
      std::hypot(static_cast<double>(bx.gradient_spread), static_cast<double>(by.gradient_spread));
  const double stretch_bound =
      std::min(1.0 + std::sqrt(lx * lx + ly * ly), largest + spread) * (1.0 + 1e-6);
  const auto stretch = static_cast<float>(stretch_bound);
  out.elevation_lipschitz = child.elevation_lipschitz * stretch;
  out.weight_lipschitz = child.weight_lipschitz * stretch;
  return out;
}

}  // namespace

namespace {
// Two fractals (the displacement's x and y), each an octave loop.
std::size_t warp_loop_iterations(std::span<const float>) {
  return 2 * kShaderOctaveLoops;
}
}  // namespace

const NodeType& warp_node_type() {
  static const NodeType type{
      .id = 33,
      .name = "warp",
      .category = NodeCategory::warp,
      .min_children = 1,
      .max_children = 1,
      .summary = "bends its child with a smooth noise displacement (amplitude in metres)",
      .parse = parse_warp,
      .kernels = {.warp_points = warp_points,
                  .warp_field = warp_field,
                  .warp_box = warp_box,
                  .warp_bounds = warp_bounds},
      .example_json = R"({"type": "warp", "noise": {"kind": "fbm", "amplitude": 40,
 "wavelength": 1500, "octaves": 3, "seed": 4}, "children": [
 {"type": "disc", "center": [0, 0], "radius": 1200, "elevation": 250}]})",
      .loop_iterations = warp_loop_iterations,
      .shader = {.enter = "$q = warp_point($at, $p, $s, $j); $t = $s;",
                 .leave = "warp_field($j, $f)",
                 .fractal_offset = 0,
                 .heavy = true},
  };
  return type;
}

}  // namespace terrain
