#include "nodes/curve.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "nodes/profile_spec.hpp"
#include "nodes/skeleton_spec.hpp"
#include "nodes/stored_bounds.hpp"
#include "terrain/polyline.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

// Pool layout (offsets relative to the node's first float):
//   0 falloff (fall-off width beyond the core), 1 length, 2 profile count P, 3 polyline offset, 4
//   λ_f, 5 z_lo, 6 z_hi, 7 c_lo, 8 c_hi, then P × (at, profile offset), then the polyline block and
//   the profile blocks.
constexpr int kFalloff = 0, kLength = 1, kProfiles = 2, kPolyline = 3, kLipschitz = 4, kZLo = 5,
              kZHi = 6, kCLo = 7, kCHi = 8, kCore = 9, kTable = 10;

constexpr std::array<std::string_view, 5> kCurvePresets{"stream", "river", "meander", "road",
                                                        "custom"};

std::uint32_t as_count(float v) {
  return static_cast<std::uint32_t>(v);
}

Result<NodeParams> parse_curve(FieldReader& reader, ParseContext&) {
  Result<Polyline> polyline = read_skeleton(reader);
  if (!polyline) return polyline.error();

  // Profiles along the curve, at increasing fractions of its length.
  const nlohmann::json* raw_profiles = reader.raw("profiles");
  if (raw_profiles == nullptr || !raw_profiles->is_array() || raw_profiles->empty() ||
      raw_profiles->size() > 32) {
    reader.fail("must be an array of 1 to 32 profiles", "profiles");
    return reader.error();
  }
  std::vector<Profile> profiles;
  std::vector<float> ats;
  nlohmann::json canonical_profiles = nlohmann::json::array();
  for (std::size_t i = 0; i < raw_profiles->size(); ++i) {
    FieldReader pr((*raw_profiles)[i], pointer_join(reader.pointer() + "/profiles", i));
    const double at =
        pr.number("at",
                  raw_profiles->size() == 1
                      ? 0.0
                      : static_cast<double>(i) / static_cast<double>(raw_profiles->size() - 1),
                  {0.0, 1.0});
    if (pr.ok() && !ats.empty() && !(static_cast<float>(at) > ats.back())) {
      pr.fail("must increase from one profile to the next", "at");
    }
    std::optional<Profile> profile = read_profile(pr, kCurvePresets);
    pr.reject_unknown();
    if (!pr.ok()) return pr.error();
    profiles.push_back(*profile);
    ats.push_back(static_cast<float>(at));
    canonical_profiles.push_back(pr.canonical());
  }
  reader.canonical()["profiles"] = std::move(canonical_profiles);

  float reach = 0.0f;
  for (const Profile& p : profiles) reach = std::max(reach, p.half_extent());
  // Roads keep full weight over their width, so the replace operator levels the carriageway;
  // channels fade from the centre line.
  double default_core = 0.0;
  for (std::size_t i = 0; i < raw_profiles->size(); ++i) {
    const nlohmann::json& p = (*raw_profiles)[i];
    if (p.value("preset", "") == "road") {
      default_core = std::max(default_core, 0.5 * p.value("width", 12.0));
    }
  }
  const double core = reader.number("core", default_core, {0.0, 1e6});
  const double falloff = reader.number("falloff", core + 1.5 * reach + 1.0, {0.01, 1e6});
  if (reader.ok() && !(falloff > core)) reader.fail("must be larger than core", "falloff");
  if (!reader.ok()) return reader.error();

  // Lipschitz bound: z along the curve, the profile slope across it, and the change between
  // neighbouring profiles along it (t is a smoothstep of s: dt/ds ≤ 1.5 / span).
  float across = 0.0f;
  for (const Profile& p : profiles) across = std::max(across, p.max_slope());
  float along = 0.0f;
  Interval c_range = profiles[0].range();
  for (std::size_t k = 0; k + 1 < profiles.size(); ++k) {
    const Interval diff = profile_difference(profiles[k], profiles[k + 1]);
    const float span = (ats[k + 1] - ats[k]) * polyline->length();
    along = std::max(along,
                     std::max(std::abs(diff.lo), std::abs(diff.hi)) * 1.5f / std::max(span, 1e-6f));
    c_range = c_range.hull(profiles[k + 1].range());
  }
  NodeParams out;
  std::vector<float>& pool = out.pool;
  pool = {static_cast<float>(falloff - core),
          polyline->length(),
          static_cast<float>(profiles.size()),
          0.0f,
          (polyline->max_dz_ds() + along) + across,
          polyline->z_range().lo,
          polyline->z_range().hi,
          c_range.lo,
          c_range.hi,
          static_cast<float>(core)};
  const std::size_t table = pool.size();
  pool.resize(table + 2 * profiles.size());
  pool[kPolyline] = static_cast<float>(pool.size());
  polyline->pack(pool);
  for (std::size_t k = 0; k < profiles.size(); ++k) {
    pool[table + 2 * k] = ats[k];
    pool[table + 2 * k + 1] = static_cast<float>(pool.size());
    profiles[k].pack(pool);
  }
  out.canonical = reader.canonical();
  return out;
}

// `cutoff`: points farther from the skeleton get α = 0 and an arbitrary f (only for parents that
// ignore f where α = 0); infinity evaluates every point exactly. Returns false, writing nothing,
// when no point of the block is within the cut-off.
bool curve_field(const float* params, const PointBlock& points, FieldBlock& out, float cutoff) {
  const float falloff = params[kFalloff];
  const float length = params[kLength];
  const std::uint32_t count = as_count(params[kProfiles]);
  const float* polyline = params + as_count(params[kPolyline]);
  const float* table = params + kTable;
  // Chunks that can be nearest for some point of the block: found once, used by every point.
  std::uint16_t candidates[256];
  const int candidate_count = polyline_candidates(polyline, points.box, candidates, 256, cutoff);
  if (candidate_count == 0) return false;
  // The nearest segment of every point, found for the whole block at once.
  std::int32_t nearest[kBlockSize];
  float nearest_d2[kBlockSize];
  float nearest_h[kBlockSize];
  if (candidate_count > 0) {
    polyline_nearest_block(polyline, candidates, candidate_count, points.x, points.y, points.count,
                           nearest, nearest_d2, nearest_h);
  }
  for (int i = 0; i < points.count; ++i) {
    const Vec2 p{points.x[i], points.y[i]};
    const PolylineSample q =
        candidate_count > 0
            ? polyline_sample(polyline, p, nearest[i], nearest_d2[i], nearest_h[i], cutoff)
            : polyline_eval(polyline, p, cutoff);
    if (!q.found) {
      out.f[i] = out.fx[i] = out.fy[i] = out.a[i] = out.ax[i] = out.ay[i] = 0.0f;
      continue;
    }
    // Profile pair around the fraction u = s / L, interpolated with a C1 smoothstep.
    const float u = length > 0.0f ? q.s / length : 0.0f;
    std::uint32_t k = 0;
    while (k + 2 < count && table[2 * (k + 1)] <= u) ++k;
    float value, slope, dvalue_ds = 0.0f;
    if (count == 1 || u <= table[0]) {
      const ProfileSample c = profile_eval(params + as_count(table[1]), q.signed_distance);
      value = c.value;
      slope = c.slope;
    } else {
      const std::uint32_t k1 = std::min(k + 1, count - 1);
      const float a0 = table[2 * k], a1 = table[2 * k1];
      const float x = a1 > a0 ? std::clamp((u - a0) / (a1 - a0), 0.0f, 1.0f) : 1.0f;
      const float t = x * x * (3.0f - 2.0f * x);
      const float dt_dx = (x > 0.0f && x < 1.0f) ? 6.0f * x * (1.0f - x) : 0.0f;
      const ProfileBlendSample c =
          profile_blend_eval(params + as_count(table[2 * k + 1]),
                             params + as_count(table[2 * k1 + 1]), q.signed_distance, t);
      value = c.value;
      slope = c.slope;
      dvalue_ds = a1 > a0 ? c.dt * dt_dx / ((a1 - a0) * length) : 0.0f;
    }
    out.f[i] = q.z + value;
    out.fx[i] = q.grad_z.x + slope * q.grad_d.x + dvalue_ds * q.grad_s.x;
    out.fy[i] = q.grad_z.y + slope * q.grad_d.y + dvalue_ds * q.grad_s.y;
    float g, dg;
    Falloff::eval(std::max(0.0f, q.distance - params[kCore]), falloff, g, dg);
    // ∇|d| = sign(d)·∇d.
    const float sign = q.signed_distance < 0.0f ? -1.0f : 1.0f;
    out.a[i] = g;
    out.ax[i] = dg * sign * q.grad_d.x;
    out.ay[i] = dg * sign * q.grad_d.y;
  }
  return true;
}

void curve_leaf(const float* params, const PointBlock& points, FieldBlock& out) {
  // No chunk is a candidate only for a degenerate box: every point is then "not found", zero.
  if (!curve_field(params, points, out, std::numeric_limits<float>::infinity())) {
    out.clear(points.count);
  }
}

bool curve_leaf_where_weighted(const float* params, const PointBlock& points, FieldBlock& out) {
  // Beyond core + fall-off the weight is zero.
  return curve_field(params, points, out, (params[kCore] + params[kFalloff]) * 1.001f);
}

NodeBounds curve_bounds(const float* params, const BoundsQuery& query) {
  const float falloff = params[kFalloff];
  const float* polyline = params + as_count(params[kPolyline]);
  // The polyline block stores its chunk boxes after the vertices; its overall box is their union.
  const auto segments = as_count(polyline[0]);
  const auto chunks = as_count(polyline[1]);
  const float* boxes = polyline + 2 + 4 * (segments + 1);
  Box2 skeleton;
  for (std::uint32_t c = 0; c < chunks; ++c) {
    skeleton =
        skeleton.united({{boxes[4 * c], boxes[4 * c + 1]}, {boxes[4 * c + 2], boxes[4 * c + 3]}});
  }
  return stored_bounds(skeleton.expanded(falloff + params[kCore]),
                       {params[kZLo] + params[kCLo], params[kZHi] + params[kCHi]},
                       params[kLipschitz], Falloff::lipschitz(falloff), query);
}

// α = g(e) with e = max(0, |d| − core), 1-Lipschitz: within `radius` of a point where α is known,
// e lies within `radius` of the distances that give that weight.
float curve_weight_lipschitz_near(const float* params, float weight, float radius) {
  const float falloff = params[kFalloff];
  const Interval e = Falloff::distances_of(weight, falloff);
  return Falloff::lipschitz({std::max(0.0f, e.lo - radius), e.hi + radius}, falloff);
}

}  // namespace

namespace {
// The polyline's chunks and segments, a search per profile and one over the profile table.
std::size_t curve_loop_iterations(std::span<const float> params) {
  const std::size_t polyline = pool_count(params, kPolyline);
  const std::span<const float> packed =
      polyline < params.size() ? params.subspan(polyline) : std::span<const float>{};
  return polyline_loop_iterations(packed) + 3 * kShaderSearchLoops + pool_count(params, kProfiles);
}
}  // namespace

const NodeType& curve_node_type() {
  static const NodeType type{
      .id = 2,
      .name = "curve",
      .category = NodeCategory::primitive,
      .min_children = 0,
      .max_children = 0,
      .summary = "a river or road along segments and Bézier pieces with cross-section profiles",
      .parse = parse_curve,
      .kernels = {.leaf = curve_leaf,
                  .leaf_bounds = curve_bounds,
                  .leaf_where_weighted = curve_leaf_where_weighted,
                  .weight_lipschitz_near = curve_weight_lipschitz_near,
                  .varies_with_spacing = never_varies_with_spacing},
      .example_json = R"({"type": "curve", "falloff": 120,
 "pieces": [[[-1500, -200, 110], [-500, 300, 100], [0, -100, 95]],
            [[0, -100, 95], [600, -500, 90], [900, 400, 88], [1500, 100, 80]]],
 "profiles": [{"at": 0, "preset": "stream", "width": 8, "depth": 2},
              {"at": 1, "preset": "meander", "width": 40, "depth": 5, "bank_width": 30, "asymmetry": 0.6}]})",
      .loop_iterations = curve_loop_iterations,
      .shader = {.call = "curve_leaf_field($at, $p, $w)", .heavy = true},
  };
  return type;
}

}  // namespace terrain
