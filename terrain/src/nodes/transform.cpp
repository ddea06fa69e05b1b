#include "nodes/transform.hpp"

#include <cmath>
#include <numbers>

#include "field_reader.hpp"
#include "terrain/simd.hpp"

namespace terrain {
namespace {

float spectral_norm(float a, float b, float c, float d) {
  // Largest singular value of [[a, b], [c, d]].
  const float s1 = a * a + b * b + c * c + d * d;
  const float det = a * d - b * c;
  const float disc = std::sqrt(std::max(0.0f, s1 * s1 - 4.0f * det * det));
  return std::sqrt((s1 + disc) * 0.5f) * 1.000001f;  // rounding margin: this is a bound
}

Result<NodeParams> parse_transform(FieldReader& reader, ParseContext&) {
  NodeParams out;
  const Vec2 translate = reader.vec2("translate", Vec2{0, 0}, {-1e7, 1e7});
  const double rotate = reader.number("rotate", 0.0, {-360.0, 360.0});
  Vec2 scale{1, 1};
  constexpr NumberRule kScaleRule{1e-4, 1e4};
  if (const nlohmann::json* s = reader.raw("scale"); s != nullptr && s->is_number()) {
    const double v = s->get<double>();
    reader.declare_number(pointer_join(reader.pointer(), "scale"), kScaleRule);
    if (!within_as_float(v, kScaleRule)) reader.fail("must be from 0.0001 to 10000", "scale");
    scale = {static_cast<float>(v), static_cast<float>(v)};
  } else if (s != nullptr) {
    reader.vec2("scale", std::nullopt, kScaleRule);
    if (reader.ok()) {
      scale = {static_cast<float>((*s)[0].get<double>()),
               static_cast<float>((*s)[1].get<double>())};
    }
  }
  reader.canonical()["scale"] = nlohmann::json::array({scale.x, scale.y});
  const double zs = reader.number("elevation_scale", 1.0, {-1e3, 1e3});
  const double zo = reader.number("elevation_offset", 0.0, {-1e5, 1e5});
  if (!reader.ok()) return reader.error();

  const double angle = rotate * std::numbers::pi / 180.0;
  const double c = std::cos(angle), s = std::sin(angle);
  AffineParams p{};
  // Forward p = T + R S q.
  p.forward[0] = static_cast<float>(c * scale.x);
  p.forward[1] = static_cast<float>(-s * scale.y);
  p.forward[2] = static_cast<float>(s * scale.x);
  p.forward[3] = static_cast<float>(c * scale.y);
  p.forward[4] = translate.x;
  p.forward[5] = translate.y;
  // Inverse q = S⁻¹ Rᵀ (p − T).
  const double a00 = c / scale.x, a01 = s / scale.x, a10 = -s / scale.y, a11 = c / scale.y;
  p.inverse[0] = static_cast<float>(a00);
  p.inverse[1] = static_cast<float>(a01);
  p.inverse[2] = static_cast<float>(a10);
  p.inverse[3] = static_cast<float>(a11);
  p.inverse[4] = static_cast<float>(-(a00 * translate.x + a01 * translate.y));
  p.inverse[5] = static_cast<float>(-(a10 * translate.x + a11 * translate.y));
  p.elevation_scale = static_cast<float>(zs);
  p.elevation_offset = static_cast<float>(zo);
  p.inverse_norm = spectral_norm(p.inverse[0], p.inverse[1], p.inverse[2], p.inverse[3]);
  p.pack(out.pool);
  out.canonical = reader.canonical();
  return out;
}

// The matrices are read into locals first: the loops' outputs could alias `params` as far as the
// compiler knows, which would keep it from vectorising them.
TERRAIN_SIMD_CLONES void transform_points(const float* params, const PointBlock& in,
                                          PointBlock& out, WarpJacobian& jacobian) {
  const float a[6] = {params[0], params[1], params[2], params[3], params[4], params[5]};  // inverse
  out.count = in.count;
  out.spacing = in.spacing * params[14];
  for (int i = 0; i < in.count; ++i) {
    out.x[i] = a[0] * in.x[i] + a[1] * in.y[i] + a[4];
    out.y[i] = a[2] * in.x[i] + a[3] * in.y[i] + a[5];
  }
  (void)jacobian;  // constant: warp_field reads it from the parameters
  out.recompute_box();
}

TERRAIN_SIMD_CLONES void transform_field(const float* params, int count, const WarpJacobian&,
                                         FieldBlock& field) {
  const float a[4] = {params[0], params[1], params[2], params[3]};
  const float zs = params[12];
  const float zo = params[13];
  for (int i = 0; i < count; ++i) {
    const float fx = field.fx[i], fy = field.fy[i];
    const float ax = field.ax[i], ay = field.ay[i];
    field.fx[i] = zs * (a[0] * fx + a[2] * fy);
    field.fy[i] = zs * (a[1] * fx + a[3] * fy);
    field.ax[i] = a[0] * ax + a[2] * ay;
    field.ay[i] = a[1] * ax + a[3] * ay;
    field.f[i] = zs * field.f[i] + zo;
  }
}

Box2 map_box(const float* m, const Box2& box) {
  if (box.lo.x == -std::numeric_limits<float>::infinity()) return box;  // everywhere stays so
  Box2 out;
  const Vec2 corners[4] = {box.lo, {box.hi.x, box.lo.y}, box.hi, {box.lo.x, box.hi.y}};
  for (const Vec2& c : corners) {
    out = out.with({m[0] * c.x + m[1] * c.y + m[4], m[2] * c.x + m[3] * c.y + m[5]});
  }
  return out;
}

float transform_spacing(const float* params, float spacing) {
  return spacing * params[14];
}

Box2 transform_box(const float* params, const BoundsQuery& query) {
  return map_box(params, query.box);
}

NodeBounds transform_bounds(const float* params, const BoundsQuery&, const NodeBounds& child) {
  const AffineParams p = AffineParams::unpack(params);
  NodeBounds out = child;
  out.support = child.support.empty() ? child.support : map_box(p.forward, child.support);
  const float lo = p.elevation_scale * child.elevation.lo + p.elevation_offset;
  const float hi = p.elevation_scale * child.elevation.hi + p.elevation_offset;
  out.elevation =
      child.elevation.empty() ? child.elevation : Interval{std::min(lo, hi), std::max(lo, hi)};
  out.elevation_lipschitz =
      std::abs(p.elevation_scale) * p.inverse_norm * child.elevation_lipschitz;
  out.weight_lipschitz = p.inverse_norm * child.weight_lipschitz;
  return out;
}

}  // namespace

AffineParams AffineParams::unpack(const float* pool) {
  AffineParams p{};
  std::copy(pool, pool + 6, p.inverse);
  std::copy(pool + 6, pool + 12, p.forward);
  p.elevation_scale = pool[12];
  p.elevation_offset = pool[13];
  p.inverse_norm = pool[14];
  return p;
}

void AffineParams::pack(std::vector<float>& pool) const {
  pool.insert(pool.end(), inverse, inverse + 6);
  pool.insert(pool.end(), forward, forward + 6);
  pool.push_back(elevation_scale);
  pool.push_back(elevation_offset);
  pool.push_back(inverse_norm);
}

AffineParams compose(const AffineParams& outer, const AffineParams& inner) {
  // Child of inner: q2 = Ai (Ao p + bo) + bi; elevation zo_s (zi_s f + zi_o) + zo_o.
  auto mul = [](const float* x, const float* y, float* out) {
    out[0] = x[0] * y[0] + x[1] * y[2];
    out[1] = x[0] * y[1] + x[1] * y[3];
    out[2] = x[2] * y[0] + x[3] * y[2];
    out[3] = x[2] * y[1] + x[3] * y[3];
    out[4] = x[0] * y[4] + x[1] * y[5] + x[4];
    out[5] = x[2] * y[4] + x[3] * y[5] + x[5];
  };
  AffineParams out{};
  mul(inner.inverse, outer.inverse, out.inverse);
  mul(outer.forward, inner.forward, out.forward);
  out.elevation_scale = outer.elevation_scale * inner.elevation_scale;
  out.elevation_offset = outer.elevation_scale * inner.elevation_offset + outer.elevation_offset;
  out.inverse_norm = spectral_norm(out.inverse[0], out.inverse[1], out.inverse[2], out.inverse[3]);
  return out;
}

const NodeType& transform_node_type() {
  static const NodeType type{
      .id = 32,
      .name = "transform",
      .category = NodeCategory::warp,
      .min_children = 1,
      .max_children = 1,
      .summary =
          "places its child: translate, rotate (degrees), scale; elevation_scale and "
          "elevation_offset change its heights",
      .parse = parse_transform,
      .kernels = {.warp_points = transform_points,
                  .warp_field = transform_field,
                  .warp_box = transform_box,
                  .warp_bounds = transform_bounds,
                  .warp_spacing = transform_spacing},
      .example_json = R"({"type": "transform", "translate": [1500, -500], "rotate": 30,
 "scale": 1.5, "elevation_scale": 1.2, "elevation_offset": 0, "children": [
 {"type": "disc", "center": [0, 0], "radius": 1000, "elevation": 300,
  "noise": {"kind": "ridged", "amplitude": 250, "wavelength": 700, "seed": 11}}]})",
      .loop_iterations = no_loops,
      .shader = {.enter = "$q = transform_point($at, $p); $t = transform_spacing($at, $s);",
                 .leave = "transform_field($at, $f)"},
  };
  return type;
}

}  // namespace terrain
