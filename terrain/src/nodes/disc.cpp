#include "nodes/disc.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "field_reader.hpp"
#include "nodes/fractal_params.hpp"
#include "terrain/simd.hpp"

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

// Offsets from the centre, and whether each point is strictly inside the disc (d² < r²).
// Returns the number of points inside.
TERRAIN_SIMD_CLONES int disc_offsets(Vec2 c, float radius, int n, const float* x, const float* y,
                                     float* lx, float* ly, std::uint32_t* inside) {
  const float r2 = radius * radius;
  int count = 0;
  for (int i = 0; i < n; ++i) {
    lx[i] = x[i] - c.x;
    ly[i] = y[i] - c.y;
    const bool in = lx[i] * lx[i] + ly[i] * ly[i] < r2;
    inside[i] = simd::mask_of(in);
    count += static_cast<int>(in);
  }
  return count;
}

// Wyvill's fall-off of the distance to the centre, and its gradient.
TERRAIN_SIMD_CLONES void disc_weights(float radius, int n, const float* lx, const float* ly,
                                      FieldBlock& out) {
  for (int i = 0; i < n; ++i) {
    const float d = std::sqrt(lx[i] * lx[i] + ly[i] * ly[i]);
    float g, dg;
    Falloff::eval(d, radius, g, dg);
    const float inv = simd::select(simd::mask_of(d > 0.0f), dg / d, 0.0f);
    out.a[i] = g;
    out.ax[i] = inv * lx[i];
    out.ay[i] = inv * ly[i];
  }
}

// Points outside get f = c_z, zero weight and zero gradients whichever path their block took (the
// noise computed there by the dense path is dropped), so a point's field never depends on its
// block.
TERRAIN_SIMD_CLONES void disc_outside_to_plateau(float elevation, int n,
                                                 const std::uint32_t* inside, FieldBlock& out) {
  for (int i = 0; i < n; ++i) {
    const std::uint32_t m = inside[i];
    out.f[i] = simd::select(m, out.f[i], elevation);
    out.a[i] = simd::select(m, out.a[i], 0.0f);
    out.fx[i] = simd::select(m, out.fx[i], 0.0f);
    out.fy[i] = simd::select(m, out.fy[i], 0.0f);
    out.ax[i] = simd::select(m, out.ax[i], 0.0f);
    out.ay[i] = simd::select(m, out.ay[i], 0.0f);
  }
}

// Elevation c_z + noise at the offsets (lx, ly) (which the warped kind may project onto the rim).
void disc_elevation(const float* params, float spacing, int n, float* lx, float* ly, float* f,
                    float* fx, float* fy) {
  const float radius = params[kRadius];
  // Locals, not reads through `params`, which the compiler must assume the outputs may alias.
  const float elevation = params[kElevation];
  const noise::FractalParams fractal = unpack_fractal(params + kFractal);
  if (fractal.amplitude == 0.0f) {
    for (int i = 0; i < n; ++i) {
      f[i] = elevation;
      fx[i] = 0.0f;
      fy[i] = 0.0f;
    }
    return;
  }
  const auto count = static_cast<std::size_t>(n);
  if (fractal.kind != noise::Fractal::warped) {
    noise::fractal2_at_spacing(fractal, spacing, lx, ly, count, f, fx, fy);
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
    noise::fractal2_at_spacing(fractal, spacing, lx, ly, count, f, fx, fy);
    for (int i = 0; i < n; ++i) {
      if (scale[i] < 1.0f) {
        // Gradient through the radial projection q = r·u: J = (r/|l|)(I − u uᵀ), symmetric.
        const float ux = lx[i] / radius;
        const float uy = ly[i] / radius;
        const float radial = fx[i] * ux + fy[i] * uy;
        fx[i] = scale[i] * (fx[i] - radial * ux);
        fy[i] = scale[i] * (fy[i] - radial * uy);
      }
    }
  }
  for (int i = 0; i < n; ++i) f[i] += elevation;
}

void disc_leaf(const float* params, const PointBlock& points, FieldBlock& out) {
  const int n = points.count;
  alignas(64) float lx[kBlockSize];
  alignas(64) float ly[kBlockSize];
  alignas(64) std::uint32_t inside[kBlockSize];
  disc_offsets({params[kCenterX], params[kCenterY]}, params[kRadius], n, points.x, points.y, lx, ly,
               inside);
  disc_weights(params[kRadius], n, lx, ly, out);
  disc_elevation(params, points.spacing, n, lx, ly, out.f, out.fx, out.fy);
}

// Only points inside the disc need noise: elsewhere α = 0 and the parent ignores f.
bool disc_leaf_where_weighted(const float* params, const PointBlock& points, FieldBlock& out) {
  const int n = points.count;
  alignas(64) float lx[kBlockSize];
  alignas(64) float ly[kBlockSize];
  alignas(64) std::uint32_t inside[kBlockSize];
  const int count = disc_offsets({params[kCenterX], params[kCenterY]}, params[kRadius], n, points.x,
                                 points.y, lx, ly, inside);
  if (count == 0) return false;
  disc_weights(params[kRadius], n, lx, ly, out);
  // The noise kernels run over vectors of 8 or 16 points: evaluating the outside points of a vector
  // costs nothing more, so the inside points are packed only when that saves whole groups of 8.
  if ((count + 7) / 8 == (n + 7) / 8) {
    disc_elevation(params, points.spacing, n, lx, ly, out.f, out.fx, out.fy);
  } else {
    alignas(64) float px[kBlockSize];
    alignas(64) float py[kBlockSize];
    alignas(64) float pf[kBlockSize];
    alignas(64) float pfx[kBlockSize];
    alignas(64) float pfy[kBlockSize];
    int index[kBlockSize];
    int k = 0;
    for (int i = 0; i < n; ++i) {
      index[k] = i;
      k += static_cast<int>(inside[i] & 1u);
    }
    for (k = 0; k < count; ++k) {
      px[k] = lx[index[k]];
      py[k] = ly[index[k]];
    }
    disc_elevation(params, points.spacing, count, px, py, pf, pfx, pfy);
    for (k = 0; k < count; ++k) {
      out.f[index[k]] = pf[k];
      out.fx[index[k]] = pfx[k];
      out.fy[index[k]] = pfy[k];
    }
  }
  if (count < n) disc_outside_to_plateau(params[kElevation], n, inside, out);
  return true;
}

NodeBounds disc_bounds(const float* params, const BoundsQuery& query) {
  const Vec2 c{params[kCenterX], params[kCenterY]};
  const float radius = params[kRadius];
  const noise::FractalParams fractal = unpack_fractal(params + kFractal);
  NodeBounds b;
  b.support = Box2::around(c, radius);
  const bool touches = query.box.intersects(b.support);
  const Interval distance = query.box.distance_range(c);
  b.weight = touches ? Falloff::range(distance, radius) : Interval{0, 0};
  b.weight_lipschitz = touches ? Falloff::lipschitz(distance, radius) : 0.0f;
  if (fractal.amplitude == 0.0f) {
    b.elevation = Interval::point(params[kElevation]);
    return b;
  }
  // The octave counts of the spacings asked for (fewer at coarser ones).
  const Interval octaves{noise::visible_octaves(fractal, query.coarsest()),
                         noise::visible_octaves(fractal, query.spacing)};
  noise::RegionBounds noise_bounds;
  if (fractal.kind == noise::Fractal::warped) {
    noise_bounds =
        noise::RegionBounds::of_slope(noise::fractal_range(fractal, octaves.hi),
                                      noise::fractal_lipschitz(fractal, octaves.hi, radius));
  } else {
    // Over a box, each octave's own slope there (the noise is evaluated at offsets from c); over
    // an unbounded one, the global bounds at every octave count asked for.
    const Box2& q = query.box;
    const bool finite = q.is_finite();
    // The half diagonal, widened by the rounding of the offsets (the box's and the kernel's).
    const float rounding = finite
                               ? 2e-7f * (std::abs(q.lo.x) + std::abs(q.hi.x) + std::abs(q.lo.y) +
                                          std::abs(q.hi.y) + std::abs(c.x) + std::abs(c.y))
                               : 0.0f;
    const float reach = finite ? 0.5f * length(q.size()) * 1.000001f + rounding
                               : std::numeric_limits<float>::infinity();
    noise_bounds =
        noise::fractal_bounds_near(fractal, octaves, finite ? q.center() - c : Vec2{}, reach);
  }
  b.elevation = {noise_bounds.value.lo + params[kElevation],
                 noise_bounds.value.hi + params[kElevation]};
  b.elevation_lipschitz = noise_bounds.lipschitz;
  return b;
}

// Only the noise depends on the spacing, through its visible octave count.
bool disc_varies_with_spacing(const float* params, float fine, float coarse) {
  const noise::FractalParams fractal = unpack_fractal(params + kFractal);
  return fractal.amplitude != 0.0f &&
         noise::visible_octaves(fractal, fine) != noise::visible_octaves(fractal, coarse);
}

}  // namespace

namespace {
// The noise's octave loop.
std::size_t disc_loop_iterations(std::span<const float>) {
  return kShaderOctaveLoops;
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
                  .leaf_where_weighted = disc_leaf_where_weighted,
                  .varies_with_spacing = disc_varies_with_spacing},
      .example_json = R"({"type": "disc", "center": [0, 0], "radius": 2000, "elevation": 300,
 "noise": {"kind": "ridged", "amplitude": 400, "wavelength": 1500, "octaves": 8, "seed": 7}})",
      .loop_iterations = disc_loop_iterations,
      .shader = {.call = "disc_leaf($at, $p, $s)", .fractal_offset = kFractal, .heavy = true},
  };
  return type;
}

}  // namespace terrain
