// Curve skeletons for curve primitives (Génevaux et al. 2015, §4.1): chains of segments and
// quadratic/cubic Bézier pieces, flattened once into a polyline with arc length s and elevation z
// per vertex. Evaluation (nearest point, signed distance, s, z and their gradients) reads only a
// flat float block, visits chunks of 16 segments behind bounding boxes, and ports to GLSL.
// See docs/geometry.md §2 for definitions, regions and the packed layout.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "terrain/math.hpp"
#include "terrain/result.hpp"

namespace terrain {

/// A control point of a curve piece: position (x, y) and elevation z of the curve itself.
struct CurvePoint {
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
};

/// One piece of a curve: 2 points (segment), 3 (quadratic Bézier) or 4 (cubic Bézier). The first
/// point of a piece must equal the last point of the previous one.
struct CurvePiece {
  std::vector<CurvePoint> points;
};

struct PolylineOptions {
  /// Maximum distance (metres, horizontal and vertical) between a Bézier piece and its flattening.
  float tolerance = 0.02f;
};

/// A vertex of the flattened polyline: position, elevation and arc length from the start.
struct PolylineVertex {
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
  float s = 0.0f;
};

/// Nearest-point query result. Gradients are with respect to the query point p.
struct PolylineSample {
  bool found = false;            ///< false: farther than the cut-off (distances = cut-off, rest 0)
  float distance = 0.0f;         ///< |p − q|
  float signed_distance = 0.0f;  ///< positive on the left of the direction of travel
  float s = 0.0f;                ///< arc length at q
  float z = 0.0f;                ///< curve elevation at q
  float dz_ds = 0.0f;            ///< slope of z along the curve; 0 in vertex and end regions
  Vec2 q;                        ///< nearest point
  Vec2 grad_d;                   ///< ∇ signed_distance (unit; 0 exactly at a vertex or end)
  Vec2 grad_s;                   ///< ∇s: the segment tangent in a slab, 0 in vertex/end regions
  Vec2 grad_z;                   ///< ∇z = dz/ds · ∇s
  int segment = -1;              ///< index of the nearest segment
  int vertex = -1;  ///< −1 when q is inside a segment, else the vertex q sits on (0..segments)
};

/// A flattened curve skeleton with arc length and elevation per vertex.
class Polyline {
 public:
  static constexpr int kMaxVertices = 4096;
  static constexpr int kChunkSegments = 16;

  /// Validates and flattens the pieces (see CurvePiece); errors point at "/pieces/i/…" or
  /// "/tolerance".
  static Result<Polyline> build(std::span<const CurvePiece> pieces,
                                const PolylineOptions& options = {});

  std::span<const PolylineVertex> vertices() const { return vertices_; }
  int segment_count() const { return static_cast<int>(vertices_.size()) - 1; }
  int chunk_count() const { return (segment_count() + kChunkSegments - 1) / kChunkSegments; }
  /// Total arc length (horizontal).
  float length() const { return vertices_.back().s; }
  /// Bounding box of the vertices.
  Box2 bounds() const { return bounds_; }
  /// Range of the curve elevation z (exact: z is linear between vertices).
  Interval z_range() const { return z_range_; }
  /// max |dz/ds| over all segments: the Lipschitz constant of z along the curve, and of z(p)
  /// over the plane wherever the nearest point moves continuously.
  float max_dz_ds() const { return max_dz_ds_; }
  /// Largest turning angle between consecutive segments (radians, 0..π); bounds the jump of s
  /// across inner bisectors (docs/geometry.md §2.5).
  float max_turn_angle() const { return max_turn_; }

  /// Nearest-point query with chunk culling; points farther than `cutoff` return found = false.
  PolylineSample nearest(Vec2 p, float cutoff = std::numeric_limits<float>::infinity()) const;
  /// Same query visiting every segment (reference for tests).
  PolylineSample nearest_brute_force(Vec2 p) const;

  /// Floats appended by pack(): 2 + 4·(segments + 1) + 4·chunks.
  std::size_t packed_size() const { return packed_.size(); }
  /// Appends [segments, chunks, vertices (x, y, z, s)…, chunk boxes (lo.x, lo.y, hi.x, hi.y)…].
  void pack(std::vector<float>& pool) const;

 private:
  Polyline() = default;

  std::vector<PolylineVertex> vertices_;
  std::vector<float> packed_;
  Box2 bounds_;
  Interval z_range_;
  float max_dz_ds_ = 0.0f;
  float max_turn_ = 0.0f;
};

/// Nearest-point query on a packed polyline (the block written by Polyline::pack). Chunks whose
/// box is farther than the best distance so far or than `cutoff` are skipped.
/// The loop iterations a shader's walk over a packed polyline runs at most: its chunks, its
/// segments and a few more (0 counts where `packed` is too short to hold them).
std::size_t polyline_loop_iterations(std::span<const float> packed);

PolylineSample polyline_eval(const float* packed, Vec2 p,
                             float cutoff = std::numeric_limits<float>::infinity());
/// The chunks (in increasing order) that can hold the nearest segment of any point of `box`:
/// evaluating a block of points against only these gives the same answers as polyline_eval.
/// Returns the count, or −1 when more than `capacity` would be needed.
/// With a finite `cutoff`, chunks farther than it from the box are left out too (and the count
/// may be 0: no point of the box is within the cut-off).
int polyline_candidates(const float* packed, const Box2& box, std::uint16_t* out, int capacity,
                        float cutoff = std::numeric_limits<float>::infinity());
/// Nearest-point query visiting only the given chunks (from polyline_candidates).
PolylineSample polyline_eval_candidates(const float* packed, Vec2 p, const std::uint16_t* chunks,
                                        int count,
                                        float cutoff = std::numeric_limits<float>::infinity());
/// Same query without chunk culling.
PolylineSample polyline_eval_brute_force(const float* packed, Vec2 p);

/// The nearest segment (−1: none), its squared distance and the parameter h of the nearest point
/// on it for each of n points, among the segments of `chunks` (as from polyline_candidates for a
/// box holding the points): the choice polyline_eval_candidates makes, bit for bit. Segments are
/// visited once for all points, so the loop over points vectorises.
void polyline_nearest_block(const float* packed, const std::uint16_t* chunks, int count,
                            const float* x, const float* y, int n, std::int32_t* segment, float* d2,
                            float* h);
/// The query's result for a point whose nearest segment polyline_nearest_block found.
PolylineSample polyline_sample(const float* packed, Vec2 p, std::int32_t segment, float d2, float h,
                               float cutoff = std::numeric_limits<float>::infinity());

}  // namespace terrain
