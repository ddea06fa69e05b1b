// Curve skeleton flattening and nearest-point evaluation. Construction runs in double and stores
// floats; the evaluator uses only the packed floats, plain loops and no recursion so it can be
// transcribed to GLSL line by line. See docs/geometry.md §2.
#include "terrain/polyline.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "terrain/node.hpp"
#include "terrain/simd.hpp"

namespace terrain {
namespace {

constexpr float kFloatInf = std::numeric_limits<float>::infinity();

std::string num(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

struct P3 {
  double x = 0.0, y = 0.0, z = 0.0;
};
P3 operator+(P3 a, P3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
P3 operator-(P3 a, P3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
P3 operator*(double s, P3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
double norm(P3 a) {
  return std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
}
P3 to_p3(const CurvePoint& c) {
  return {c.x, c.y, c.z};
}

/// Bernstein form of a degree-1..3 Bézier at t.
P3 bezier(const std::vector<P3>& c, double t) {
  const double u = 1.0 - t;
  switch (c.size()) {
    case 2:
      return u * c[0] + t * c[1];
    case 3:
      return (u * u) * c[0] + (2.0 * u * t) * c[1] + (t * t) * c[2];
    default:
      return (u * u * u) * c[0] + (3.0 * u * u * t) * c[1] + (3.0 * u * t * t) * c[2] +
             (t * t * t) * c[3];
  }
}

/// Segments needed so that the chord error of a uniform parameter split is ≤ tol (Wang's bound:
/// |B(t) − chord| ≤ max|B''| · Δt² / 8, in 3D so both horizontal and vertical errors are bounded).
double segments_needed(const std::vector<P3>& c, double tol) {
  double m = 0.0;
  if (c.size() == 3) m = 2.0 * norm(c[0] - 2.0 * c[1] + c[2]);
  if (c.size() == 4)
    m = 6.0 * std::max(norm(c[0] - 2.0 * c[1] + c[2]), norm(c[1] - 2.0 * c[2] + c[3]));
  return std::max(1.0, std::ceil(std::sqrt(m / (8.0 * tol))));
}

// Squared distance from (px, py) to the segment from (ax, ay) along (ex, ey), with ee = e·e, and
// the parameter h = clamp(w·e / e·e, 0, 1) of its nearest point, clamped as std::clamp does (NaN
// stays NaN, and its distance is never the nearest). Branch-free: the searches' loops vectorise.
TERRAIN_SIMD_INLINE float segment_distance2(float px, float py, float ax, float ay, float ex,
                                            float ey, float ee, float& h) {
  const float wx = px - ax, wy = py - ay;
  const float t = (wx * ex + wy * ey) / ee;
  h = simd::select(simd::mask_of(t < 0.0f), 0.0f, simd::select(simd::mask_of(1.0f < t), 1.0f, t));
  const float rx = wx - ex * h, ry = wy - ey * h;
  return rx * rx + ry * ry;
}

// Distance to each segment of a chunk (a loop that vectorises; the scan for the nearest stays in
// order).
TERRAIN_SIMD_CLONES void chunk_distances(const float* vtx, int first, int count, Vec2 p, float* d2,
                                         float* hs) {
  for (int k = 0; k < count; ++k) {
    const int i = first + k;
    const float ax = vtx[4 * i], ay = vtx[4 * i + 1];
    const float ex = vtx[4 * i + 4] - ax, ey = vtx[4 * i + 5] - ay;
    d2[k] = segment_distance2(p.x, p.y, ax, ay, ex, ey, ex * ex + ey * ey, hs[k]);
  }
}

PolylineSample sample_nearest(const float* vtx, int segments, Vec2 p, float cutoff, int best,
                              float best2, float best_h);

PolylineSample eval_impl(const float* packed, Vec2 p, float cutoff, bool cull,
                         const std::uint16_t* candidates = nullptr, int candidate_count = 0) {
  const int segments = static_cast<int>(packed[0]);
  const int chunks = static_cast<int>(packed[1]);
  const float* vtx = packed + 2;                // (x, y, z, s) per vertex
  const float* box = vtx + 4 * (segments + 1);  // (lo.x, lo.y, hi.x, hi.y) per chunk
  const float limit2 = cutoff * cutoff;

  // Closest segment; strict '<' keeps the first of equal candidates, so culling cannot change the
  // answer (a culled chunk holds no strictly closer point).
  float best2 = kFloatInf;
  int best = -1;
  float best_h = 0.0f;
  const int visits = candidates != nullptr ? candidate_count : chunks;
  for (int visit = 0; visit < visits; ++visit) {
    const int c = candidates != nullptr ? candidates[visit] : visit;
    if (cull) {
      const float* b = box + 4 * c;
      const float dx = std::max(std::max(b[0] - p.x, 0.0f), p.x - b[2]);
      const float dy = std::max(std::max(b[1] - p.y, 0.0f), p.y - b[3]);
      if (dx * dx + dy * dy > std::min(best2, limit2)) continue;
    }
    const int first = c * Polyline::kChunkSegments;
    const int count = std::min(Polyline::kChunkSegments, segments - first);
    float d2[Polyline::kChunkSegments];
    float hs[Polyline::kChunkSegments];
    chunk_distances(vtx, first, count, p, d2, hs);
    for (int k = 0; k < count; ++k) {
      if (d2[k] < best2) {
        best2 = d2[k];
        best = first + k;
        best_h = hs[k];
      }
    }
  }

  return sample_nearest(vtx, segments, p, cutoff, best, best2, best_h);
}

// The sample for nearest segment `best` (−1: none) at squared distance best2 and parameter best_h.
PolylineSample sample_nearest(const float* vtx, int segments, Vec2 p, float cutoff, int best,
                              float best2, float best_h) {
  PolylineSample out;
  if (best < 0 || best2 > cutoff * cutoff) {
    out.distance = cutoff;
    out.signed_distance = cutoff;
    return out;
  }
  out.found = true;
  out.segment = best;
  const float* va = vtx + 4 * best;
  const float* vb = va + 4;
  const Vec2 a{va[0], va[1]};
  const Vec2 e = Vec2{vb[0], vb[1]} - a;
  const float ee = dot(e, e);
  if (best_h > 0.0f && best_h < 1.0f) {
    // Inside the slab of segment `best`: the signed distance is the linear function
    // dot(p − a, n), so it and its gradient n are computed directly, not from p − q.
    const float len = std::sqrt(ee);
    const Vec2 t = e * (1.0f / len);
    const Vec2 n{-t.y, t.x};
    const float sd = dot(p - a, n);
    out.q = a + e * best_h;
    out.signed_distance = sd;
    out.distance = std::abs(sd);
    out.grad_d = n;
    out.s = va[3] + best_h * (vb[3] - va[3]);
    out.z = va[2] + best_h * (vb[2] - va[2]);
    out.dz_ds = (vb[2] - va[2]) / len;
    // Exact gradients of the formulas above: ∇h = e / |e|².
    out.grad_s = e * ((vb[3] - va[3]) / ee);
    out.grad_z = e * ((vb[2] - va[2]) / ee);
    return out;
  }
  // In the wedge of a vertex or the cap of an end: q is the vertex, s and z are constant.
  const int v = best_h <= 0.0f ? best : best + 1;
  out.vertex = v;
  const float* vq = vtx + 4 * v;
  out.q = Vec2{vq[0], vq[1]};
  out.s = vq[3];
  out.z = vq[2];
  // Side test against the bisector of the normals of the two segments meeting at v (the same
  // segment twice at an end); a hairpin (normals cancel) falls back to the incoming normal.
  const int i0 = std::max(v - 1, 0);
  const int i1 = std::min(v, segments - 1);
  const Vec2 e0 = Vec2{vtx[4 * i0 + 4], vtx[4 * i0 + 5]} - Vec2{vtx[4 * i0], vtx[4 * i0 + 1]};
  const Vec2 e1 = Vec2{vtx[4 * i1 + 4], vtx[4 * i1 + 5]} - Vec2{vtx[4 * i1], vtx[4 * i1 + 1]};
  const Vec2 n0 = Vec2{-e0.y, e0.x} * (1.0f / length(e0));
  const Vec2 n1 = Vec2{-e1.y, e1.x} * (1.0f / length(e1));
  Vec2 bisector = n0 + n1;
  if (dot(bisector, bisector) < 1e-12f) bisector = n0;
  const Vec2 w = p - out.q;
  const float d = length(w);
  const float sign = dot(w, bisector) >= 0.0f ? 1.0f : -1.0f;
  out.distance = d;
  out.signed_distance = sign * d;
  out.grad_d = d > 0.0f ? w * (sign / d) : Vec2{};
  return out;
}

}  // namespace

Result<Polyline> Polyline::build(std::span<const CurvePiece> pieces,
                                 const PolylineOptions& options) {
  const double tol = options.tolerance;
  if (!(options.tolerance > 0.0f) || !std::isfinite(options.tolerance))
    return Error{"the chord tolerance must be positive and finite, got " + num(tol), "/tolerance"};
  if (pieces.empty()) return Error{"a curve needs at least one piece", "/pieces"};

  // Validate every piece and its connection to the previous one before flattening anything.
  double scale = 1.0;  // magnitude of the coordinates, for relative tolerances
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    const auto& pts = pieces[i].points;
    const std::string where = "/pieces/" + std::to_string(i);
    if (pts.size() < 2 || pts.size() > 4)
      return Error{"piece " + std::to_string(i) +
                       " must have 2 (segment), 3 (quadratic) or 4 (cubic) points, got " +
                       std::to_string(pts.size()),
                   where + "/points"};
    for (std::size_t k = 0; k < pts.size(); ++k) {
      if (!std::isfinite(pts[k].x) || !std::isfinite(pts[k].y) || !std::isfinite(pts[k].z))
        return Error{"piece " + std::to_string(i) + " point " + std::to_string(k) +
                         " is not finite (NaN or infinity)",
                     where + "/points/" + std::to_string(k)};
      scale = std::max({scale, std::abs(static_cast<double>(pts[k].x)),
                        std::abs(static_cast<double>(pts[k].y))});
    }
  }
  const double merge = 1e-6 * scale;  // horizontal distance below which vertices coincide
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    const auto& pts = pieces[i].points;
    const std::string where = "/pieces/" + std::to_string(i);
    double extent = 0.0;
    for (const CurvePoint& c : pts)
      extent = std::max(extent, std::hypot(static_cast<double>(c.x) - pts[0].x,
                                           static_cast<double>(c.y) - pts[0].y));
    if (extent <= merge)
      return Error{"piece " + std::to_string(i) +
                       " has zero horizontal length (all its points coincide in x, y)",
                   where + "/points"};
    if (i == 0) continue;
    const CurvePoint& prev = pieces[i - 1].points.back();
    const CurvePoint& first = pts.front();
    const double local =
        std::max({1.0, std::abs(static_cast<double>(prev.x)), std::abs(static_cast<double>(prev.y)),
                  std::abs(static_cast<double>(prev.z)), std::abs(static_cast<double>(first.x)),
                  std::abs(static_cast<double>(first.y)), std::abs(static_cast<double>(first.z))});
    const double gap = std::max({std::abs(static_cast<double>(prev.x) - first.x),
                                 std::abs(static_cast<double>(prev.y) - first.y),
                                 std::abs(static_cast<double>(prev.z) - first.z)});
    if (gap > 1e-6 * local)
      return Error{"piece " + std::to_string(i) + " starts at (" + num(first.x) + ", " +
                       num(first.y) + ", " + num(first.z) + ") but piece " + std::to_string(i - 1) +
                       " ends at (" + num(prev.x) + ", " + num(prev.y) + ", " + num(prev.z) +
                       "); consecutive pieces must share "
                       "their endpoint",
                   where + "/points/0"};
  }

  // Count before allocating: a tiny tolerance must fail cleanly, not exhaust memory.
  std::vector<int> splits(pieces.size());
  double total = 1.0;
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    std::vector<P3> c;
    for (const CurvePoint& q : pieces[i].points) c.push_back(to_p3(q));
    const double n = segments_needed(c, tol);
    total += n;
    if (total > kMaxVertices)
      return Error{"flattening needs more than " + std::to_string(kMaxVertices) +
                       " vertices at tolerance " + num(tol) + " m (reached at piece " +
                       std::to_string(i) + "); raise the tolerance or use fewer, flatter pieces",
                   "/pieces"};
    splits[i] = static_cast<int>(n);
  }

  Polyline out;
  std::vector<PolylineVertex>& v = out.vertices_;
  const CurvePoint& start = pieces[0].points[0];
  v.push_back({start.x, start.y, start.z, 0.0f});
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    std::vector<P3> c;
    for (const CurvePoint& q : pieces[i].points) c.push_back(to_p3(q));
    c[0] = P3{v.back().x, v.back().y, v.back().z};  // snap to the shared endpoint
    for (int k = 1; k <= splits[i]; ++k) {
      const P3 b = bezier(c, static_cast<double>(k) / splits[i]);
      const PolylineVertex next{static_cast<float>(b.x), static_cast<float>(b.y),
                                static_cast<float>(b.z), 0.0f};
      if (std::hypot(static_cast<double>(next.x) - v.back().x,
                     static_cast<double>(next.y) - v.back().y) <= merge)
        continue;  // a cusp or a near-zero step: keep the segments well defined
      v.push_back(next);
    }
  }
  if (v.size() < 2) return Error{"the curve has zero horizontal length", "/pieces"};

  // Arc length, bounds, slopes and turning angles, in double from the stored floats.
  double s = 0.0, max_slope = 0.0, max_turn = 0.0;
  Box2 bounds;
  Interval zr;
  for (std::size_t k = 0; k < v.size(); ++k) {
    bounds = bounds.with(Vec2{v[k].x, v[k].y});
    zr = zr.hull(Interval::point(v[k].z));
    if (k == 0) continue;
    const double ex = static_cast<double>(v[k].x) - v[k - 1].x;
    const double ey = static_cast<double>(v[k].y) - v[k - 1].y;
    const double len = std::hypot(ex, ey);
    s += len;
    v[k].s = static_cast<float>(s);
    max_slope = std::max(max_slope, std::abs(static_cast<double>(v[k].z) - v[k - 1].z) / len);
    if (k + 1 < v.size()) {
      const double fx = static_cast<double>(v[k + 1].x) - v[k].x;
      const double fy = static_cast<double>(v[k + 1].y) - v[k].y;
      max_turn = std::max(max_turn, std::atan2(std::abs(ex * fy - ey * fx), ex * fx + ey * fy));
    }
  }
  out.bounds_ = bounds;
  out.z_range_ = zr;
  out.max_dz_ds_ = std::nextafter(static_cast<float>(max_slope), kFloatInf);
  out.max_turn_ = static_cast<float>(max_turn);

  // Packed form. Chunk boxes are padded by a few float ulps of the coordinates so rounding in
  // the box test can never cull a segment that the segment test would pick.
  const int segments = out.segment_count();
  const int chunks = out.chunk_count();
  const float pad = static_cast<float>(1e-6 * scale);
  std::vector<float>& pk = out.packed_;
  pk.reserve(2 + 4 * v.size() + 4 * static_cast<std::size_t>(chunks));
  pk.push_back(static_cast<float>(segments));
  pk.push_back(static_cast<float>(chunks));
  for (const PolylineVertex& q : v) pk.insert(pk.end(), {q.x, q.y, q.z, q.s});
  for (int c = 0; c < chunks; ++c) {
    Box2 b;
    const int last = std::min((c + 1) * kChunkSegments, segments);
    for (int k = c * kChunkSegments; k <= last; ++k)
      b = b.with(Vec2{v[static_cast<std::size_t>(k)].x, v[static_cast<std::size_t>(k)].y});
    b = b.expanded(pad);
    pk.insert(pk.end(), {b.lo.x, b.lo.y, b.hi.x, b.hi.y});
  }
  return out;
}

PolylineSample Polyline::nearest(Vec2 p, float cutoff) const {
  return polyline_eval(packed_.data(), p, cutoff);
}

PolylineSample Polyline::nearest_brute_force(Vec2 p) const {
  return polyline_eval_brute_force(packed_.data(), p);
}

void Polyline::pack(std::vector<float>& pool) const {
  pool.insert(pool.end(), packed_.begin(), packed_.end());
}

std::size_t polyline_loop_iterations(std::span<const float> packed) {
  constexpr std::size_t kFixedSteps = 8;
  return pool_count(packed, 0) + pool_count(packed, 1) + kFixedSteps;
}

PolylineSample polyline_eval(const float* packed, Vec2 p, float cutoff) {
  return eval_impl(packed, p, cutoff, true);
}

int polyline_candidates(const float* packed, const Box2& box, std::uint16_t* out, int capacity,
                        float cutoff) {
  const int segments = static_cast<int>(packed[0]);
  const int chunks = static_cast<int>(packed[1]);
  const float* vtx = packed + 2;
  const float* boxes = vtx + 4 * (segments + 1);
  // Every point of `box` lies within `reach` of the first vertex of some chunk, so its nearest
  // segment is in a chunk whose box is no farther than that from `box`.
  float reach2 = cutoff * cutoff;
  for (int c = 0; c < chunks; ++c) {
    const float* v = vtx + 4 * (c * Polyline::kChunkSegments);
    const float dx = std::max(std::abs(v[0] - box.lo.x), std::abs(v[0] - box.hi.x));
    const float dy = std::max(std::abs(v[1] - box.lo.y), std::abs(v[1] - box.hi.y));
    reach2 = std::min(reach2, dx * dx + dy * dy);
  }
  int count = 0;
  for (int c = 0; c < chunks; ++c) {
    const float* b = boxes + 4 * c;
    const float dx = std::max({b[0] - box.hi.x, 0.0f, box.lo.x - b[2]});
    const float dy = std::max({b[1] - box.hi.y, 0.0f, box.lo.y - b[3]});
    if (dx * dx + dy * dy > reach2 * 1.0001f) continue;
    if (count == capacity) return -1;
    out[count++] = static_cast<std::uint16_t>(c);
  }
  return count;
}

PolylineSample polyline_eval_candidates(const float* packed, Vec2 p, const std::uint16_t* chunks,
                                        int count, float cutoff) {
  return eval_impl(packed, p, cutoff, true, chunks, count);
}

TERRAIN_SIMD_CLONES void polyline_nearest_block(const float* packed, const std::uint16_t* chunks,
                                                int count, const float* x, const float* y, int n,
                                                std::int32_t* segment, float* d2, float* h) {
  const int segments = static_cast<int>(packed[0]);
  const float* vtx = packed + 2;
  for (int k = 0; k < n; ++k) {
    segment[k] = -1;
    d2[k] = kFloatInf;
    h[k] = 0.0f;
  }
  // Segments in the order eval_impl visits them, each against every point (a loop that
  // vectorises); strict '<' keeps the first of equal distances, as there. (eval_impl also skips
  // chunks that cannot hold a closer point, which never changes its answer.)
  for (int c = 0; c < count; ++c) {
    const int first = chunks[c] * Polyline::kChunkSegments;
    const int last = std::min(first + Polyline::kChunkSegments, segments);
    for (int i = first; i < last; ++i) {
      const float ax = vtx[4 * i], ay = vtx[4 * i + 1];
      const float ex = vtx[4 * i + 4] - ax, ey = vtx[4 * i + 5] - ay;
      const float ee = ex * ex + ey * ey;
      for (int k = 0; k < n; ++k) {
        float hk;
        const float dk = segment_distance2(x[k], y[k], ax, ay, ex, ey, ee, hk);
        const std::uint32_t closer = simd::mask_of(dk < d2[k]);
        d2[k] = simd::select(closer, dk, d2[k]);
        h[k] = simd::select(closer, hk, h[k]);
        segment[k] = static_cast<std::int32_t>((static_cast<std::uint32_t>(i) & closer) |
                                               (static_cast<std::uint32_t>(segment[k]) & ~closer));
      }
    }
  }
}

PolylineSample polyline_sample(const float* packed, Vec2 p, std::int32_t segment, float d2, float h,
                               float cutoff) {
  return sample_nearest(packed + 2, static_cast<int>(packed[0]), p, cutoff, segment, d2, h);
}

PolylineSample polyline_eval_brute_force(const float* packed, Vec2 p) {
  return eval_impl(packed, p, kFloatInf, false);
}

}  // namespace terrain
