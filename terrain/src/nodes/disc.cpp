#include "nodes/disc.hpp"

#include <algorithm>
#include <cmath>

#include "field_reader.hpp"
#include "nodes/fractal_params.hpp"

namespace terrain {
namespace {

// Pool layout: centre x, centre y, radius, elevation, then the fractal (kFractalFloats).
constexpr int kCenterX = 0, kCenterY = 1, kRadius = 2, kElevation = 3, kFractal = 4;

Result<NodeParams> parse_disc(FieldReader& reader, ParseContext& context) {
  NodeParams out;
  const Vec2 center = reader.vec2("center", std::nullopt);
  const double radius = reader.number("radius", std::nullopt, {0.0, 1e7, true});
  const double elevation = reader.number("elevation", 0.0, {-1e5, 1e5});
  FieldReader noise_reader = reader.nested("noise");
  const noise::FractalParams fractal = read_fractal(noise_reader, context, "none");
  reader.adopt("noise", noise_reader);
  if (!reader.ok()) return reader.error();
  out.pool = {center.x, center.y, static_cast<float>(radius), static_cast<float>(elevation)};
  pack_fractal(fractal, out.pool);
  out.canonical = reader.canonical();
  return out;
}

void disc_leaf(const float* params, const PointBlock& points, FieldBlock& out) {
  const Vec2 c{params[kCenterX], params[kCenterY]};
  const float radius = params[kRadius];
  const noise::FractalParams fractal = unpack_fractal(params + kFractal);
  const int n = points.count;
  alignas(64) float lx[kBlockSize];
  alignas(64) float ly[kBlockSize];
  for (int i = 0; i < n; ++i) {
    lx[i] = points.x[i] - c.x;
    ly[i] = points.y[i] - c.y;
  }
  for (int i = 0; i < n; ++i) {
    const float d = std::sqrt(lx[i] * lx[i] + ly[i] * ly[i]);
    float g = 0.0f;
    float dg = 0.0f;
    Falloff::eval(d, radius, g, dg);
    const float inv = d > 0.0f ? dg / d : 0.0f;
    out.a[i] = g;
    out.ax[i] = inv * lx[i];
    out.ay[i] = inv * ly[i];
  }
  if (fractal.amplitude == 0.0f) {
    for (int i = 0; i < n; ++i) {
      out.f[i] = params[kElevation];
      out.fx[i] = 0.0f;
      out.fy[i] = 0.0f;
    }
    return;
  }
  const float octaves = noise::visible_octaves(fractal, points.spacing);
  if (fractal.kind != noise::Fractal::warped) {
    noise::fractal2(fractal, lx, ly, static_cast<std::size_t>(n), octaves, out.f, out.fx, out.fy);
  } else {
    // The warped fractal's slope grows with the distance from its origin, so it is evaluated on
    // the disc and extended radially outside it: f stays Lipschitz on the whole plane.
    alignas(64) float scale[kBlockSize];
    for (int i = 0; i < n; ++i) {
      const float d = std::sqrt(lx[i] * lx[i] + ly[i] * ly[i]);
      scale[i] = d > radius ? radius / d : 1.0f;
      lx[i] *= scale[i];
      ly[i] *= scale[i];
    }
    noise::fractal2(fractal, lx, ly, static_cast<std::size_t>(n), octaves, out.f, out.fx, out.fy);
    for (int i = 0; i < n; ++i) {
      if (scale[i] < 1.0f) {
        // Gradient through the radial projection q = r·u: J = (r/|l|)(I − u uᵀ), symmetric.
        const float ux = lx[i] / radius;
        const float uy = ly[i] / radius;
        const float radial = out.fx[i] * ux + out.fy[i] * uy;
        out.fx[i] = scale[i] * (out.fx[i] - radial * ux);
        out.fy[i] = scale[i] * (out.fy[i] - radial * uy);
      }
    }
  }
  for (int i = 0; i < n; ++i) out.f[i] += params[kElevation];
}

// Only points inside the disc get noise: elsewhere α = 0 and the parent ignores f.
void disc_leaf_where_weighted(const float* params, const PointBlock& points, FieldBlock& out) {
  const Vec2 c{params[kCenterX], params[kCenterY]};
  const float radius = params[kRadius];
  PointBlock inside;
  int map[kBlockSize];
  inside.count = 0;
  inside.spacing = points.spacing;
  for (int i = 0; i < points.count; ++i) {
    const float dx = points.x[i] - c.x, dy = points.y[i] - c.y;
    if (dx * dx + dy * dy < radius * radius) {
      inside.x[inside.count] = points.x[i];
      inside.y[inside.count] = points.y[i];
      map[inside.count++] = i;
    }
    out.f[i] = params[kElevation];
    out.a[i] = out.fx[i] = out.fy[i] = out.ax[i] = out.ay[i] = 0.0f;
  }
  if (inside.count == 0) return;
  if (inside.count == points.count) {
    disc_leaf(params, points, out);
    return;
  }
  FieldBlock packed;
  disc_leaf(params, inside, packed);
  for (int k = 0; k < inside.count; ++k) {
    const int i = map[k];
    out.f[i] = packed.f[k];
    out.a[i] = packed.a[k];
    out.fx[i] = packed.fx[k];
    out.fy[i] = packed.fy[k];
    out.ax[i] = packed.ax[k];
    out.ay[i] = packed.ay[k];
  }
}

NodeBounds disc_bounds(const float* params, const BoundsQuery& query) {
  const Vec2 c{params[kCenterX], params[kCenterY]};
  const float radius = params[kRadius];
  const noise::FractalParams fractal = unpack_fractal(params + kFractal);
  NodeBounds b;
  b.support = Box2::around(c, radius);
  const bool touches = query.box.intersects(b.support);
  b.weight = touches ? Falloff::range(query.box.distance_range(c), radius) : Interval{0, 0};
  b.weight_lipschitz = touches ? Falloff::lipschitz(radius) : 0.0f;
  if (fractal.amplitude == 0.0f) {
    b.elevation = Interval::point(params[kElevation]);
    return b;
  }
  const float octaves = noise::visible_octaves(fractal, query.spacing);
  const Interval range = noise::fractal_range(fractal, octaves);
  b.elevation = {range.lo + params[kElevation], range.hi + params[kElevation]};
  b.elevation_lipschitz = noise::fractal_lipschitz(fractal, octaves, radius);
  return b;
}

}  // namespace

const NodeType& disc_node_type() {
  static const NodeType type{
      .id = 1,
      .name = "disc",
      .category = NodeCategory::primitive,
      .min_children = 0,
      .max_children = 0,
      .summary =
          "circular feature: plateau (no noise), hills (fbm), mountains (ridged), or "
          "multifractal terrain; octaves fade in with the level of detail",
      .parse = parse_disc,
      .kernels = {.leaf = disc_leaf,
                  .leaf_bounds = disc_bounds,
                  .leaf_where_weighted = disc_leaf_where_weighted},
      .example_json = R"({"type": "disc", "center": [0, 0], "radius": 2000, "elevation": 300,
 "noise": {"kind": "ridged", "amplitude": 400, "wavelength": 1500, "octaves": 8, "seed": 7}})",
  };
  return type;
}

}  // namespace terrain
