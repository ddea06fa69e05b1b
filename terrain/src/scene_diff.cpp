#include "terrain/scene_diff.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <unordered_map>
#include <utility>

#include "nodes/blend.hpp"
#include "terrain/evaluate.hpp"

namespace terrain {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

bool finite(const Box2& b) {
  return std::isfinite(b.lo.x) && std::isfinite(b.lo.y) && std::isfinite(b.hi.x) &&
         std::isfinite(b.hi.y);
}

// Box2's united/intersected treat an empty box as numbers; these keep "empty" meaning nothing.
Box2 unite(const Box2& a, const Box2& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return a.united(b);
}
Box2 intersect(const Box2& a, const Box2& b) {
  const Box2 c = a.intersected(b);
  return c.empty() ? Box2{} : c;
}

// Room for float rounding between a box and the points evaluated in it: sample positions rounded
// from double, affine chains the compiler concatenates (other rounding than node by node), and
// bounds computed with other operations than the kernels. 1e-5 relative is ~100 float ulps.
Box2 padded(const Box2& b) {
  if (b.empty() || !finite(b)) return b;
  const float m =
      std::max({std::abs(b.lo.x), std::abs(b.lo.y), std::abs(b.hi.x), std::abs(b.hi.y)});
  return b.expanded(1e-5f * m + 1e-4f);
}

bool same_bits(float a, float b) {
  return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
}
bool same_box(const Box2& a, const Box2& b) {
  return same_bits(a.lo.x, b.lo.x) && same_bits(a.lo.y, b.lo.y) && same_bits(a.hi.x, b.hi.x) &&
         same_bits(a.hi.y, b.hi.y);
}
// The kernels read nothing but the pool, so equal pools (bit for bit) mean equal behaviour.
bool same_pool(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

std::uint64_t mix(std::uint64_t h, std::uint64_t v) {  // splitmix64's finaliser over h ^ v
  std::uint64_t z = h ^ (v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2));
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

float inner_spacing(const Node& warp, float spacing) {
  const NodeKernels& k = warp.type->kernels;
  return k.warp_spacing != nullptr ? k.warp_spacing(warp.params.pool.data(), spacing) : spacing;
}

// One pair of corresponding nodes whose subtrees differ.
struct Slot {
  std::size_t diff = 0;
  bool by_weight = false;  ///< the parent ignores this child wherever its weight is zero
};
struct Diff {
  const Node* before = nullptr;  ///< null: added
  const Node* after = nullptr;   ///< null: removed
  /// Own type or parameters differ (or the node was added or removed): f and α may differ
  /// anywhere. Otherwise only through `slots`, the children that differ.
  bool whole = false;
  std::vector<Slot> slots;
  Box2 reach;  ///< in the node's output frame: where its f or α may differ
};

}  // namespace

struct SceneChange::Data {
  std::shared_ptr<const Scene> before, after;
  std::shared_ptr<const TileSource> before_source, after_source;
  bool everything = false;
  std::array<bool, 16> global{};  ///< per TileFormat
  std::vector<Diff> diffs;        ///< children before parents
  std::optional<std::size_t> terrain, water;
  std::unordered_map<const Node*, Box2> supports;  ///< global support of every node of both trees
  Box2 box;                                        ///< every sample that may differ
  std::optional<GeoFrame> frame;                   ///< set unless everything

  const Box2& support(const Node* node) const { return supports.at(node); }

  // May f, α or their gradients of diff `index` differ at a point of q (its output frame) when
  // sampled at `spacing`?
  bool differs(std::size_t index, const Box2& q, float spacing) const {
    const Diff& d = diffs[index];
    if (d.whole) return true;
    if (!q.intersects(d.reach)) return false;
    const Node& node = *d.before;
    if (node.type->category == NodeCategory::warp) {
      const Box2 inner = padded(node.type->kernels.warp_box(node.params.pool.data(), {q, spacing}));
      return differs(d.slots.front().diff, inner, inner_spacing(node, spacing));
    }
    for (const Slot& slot : d.slots) {
      if (!differs(slot.diff, q, spacing)) continue;
      if (!slot.by_weight) return true;
      const Diff& child = diffs[slot.diff];
      if (may_weigh(child.before, q, spacing) || may_weigh(child.after, q, spacing)) return true;
    }
    return false;
  }

  // May the node's weight be positive somewhere in q? (A blend's weight is the sum of its
  // children's, a warp's its child's; other nodes ask their bounds.)
  bool may_weigh(const Node* node, const Box2& q, float spacing) const {
    if (node == nullptr || !q.intersects(support(node))) return false;
    const float* params = node->params.pool.data();
    const NodeKernels& k = node->type->kernels;
    switch (node->type->category) {
      case NodeCategory::blend:
        return std::any_of(node->children.begin(), node->children.end(),
                           [&](const NodePtr& c) { return may_weigh(c.get(), q, spacing); });
      case NodeCategory::warp:
        return may_weigh(node->children.front().get(), padded(k.warp_box(params, {q, spacing})),
                         inner_spacing(*node, spacing));
      case NodeCategory::primitive:
        return k.leaf_bounds(params, {q, spacing}).weight.hi > 0.0f;
      case NodeCategory::binary:
        break;
    }
    return tree_bounds(*node, {q, spacing}).weight.hi > 0.0f;
  }

  bool region_may_change(TileScheme scheme, const TileAddress& node, int z, TileFormat format,
                         const ProductOptions& options, bool refine) const;

  // May the water layer be wet (weight ≥ 0.5) somewhere in q? Slack for the bound's rounding.
  bool may_be_wet(const Node* water_root, const Box2& q, float spacing) const {
    if (water_root == nullptr || !q.intersects(support(water_root))) return false;
    return tree_bounds(*water_root, {q, spacing}).weight.hi >= 0.5f - 1e-4f;
  }
};

namespace {

// Builds the diff of two trees. Nodes of the two versions are distinct objects (two parses), so
// identity is decided by content: type, parameter pool and children, recursively.
class DiffBuilder {
 public:
  explicit DiffBuilder(SceneChange::Data& data) : data_(data) {}

  std::optional<std::size_t> build(const Node* a, const Node* b) {
    if (a == b) return std::nullopt;
    if (a != nullptr && b != nullptr && same(*a, *b)) return std::nullopt;
    if (a == nullptr || b == nullptr || a->type != b->type ||
        !same_pool(a->params.pool, b->params.pool) ||
        (a->type->category != NodeCategory::blend && a->children.size() != b->children.size())) {
      return whole(a, b);
    }
    Diff d;
    d.before = a;
    d.after = b;
    switch (a->type->category) {
      case NodeCategory::blend:
        match_blend_children(*a, *b, d.slots);
        break;
      case NodeCategory::binary:
        for (std::size_t i = 0; i < a->children.size(); ++i) {
          if (auto c = build(a->children[i].get(), b->children[i].get())) {
            d.slots.push_back({*c, i == 1 && a->type->second_child_acts_by_weight});
          }
        }
        break;
      case NodeCategory::warp:
        if (auto c = build(a->children.front().get(), b->children.front().get())) {
          d.slots.push_back({*c, false});
        }
        break;
      case NodeCategory::primitive:
        assert(false && "equal primitives were found the same");
        return whole(a, b);
    }
    if (d.slots.empty()) return std::nullopt;
    return push(std::move(d));
  }

  // Global bounds of every node of a tree (what tree_bounds(node, {}) gives, memoised).
  const NodeBounds& global_bounds(const Node& n) {
    if (auto it = bounds_.find(&n); it != bounds_.end()) return it->second;
    const float* params = n.params.pool.data();
    const NodeKernels& k = n.type->kernels;
    NodeBounds b;
    switch (n.type->category) {
      case NodeCategory::primitive:
        b = k.leaf_bounds(params, {});
        break;
      case NodeCategory::blend: {
        BlendBoundsAccumulator acc;
        for (const NodePtr& c : n.children) acc.add(global_bounds(*c));
        b = acc.finish(params);
        break;
      }
      case NodeCategory::binary: {
        const NodeBounds first = global_bounds(*n.children[0]);
        b = k.combine_bounds(params, {}, first, global_bounds(*n.children[1]));
        break;
      }
      case NodeCategory::warp: {
        // tree_bounds asks the child over the warped whole plane, which is the whole plane again
        // for every warp there is; the general case is kept for safety.
        const Node& child = *n.children.front();
        const NodeBounds& child_global = global_bounds(child);
        const BoundsQuery inner{k.warp_box(params, {}), inner_spacing(n, 0.0f)};
        const bool plane = same_box(inner.box, Box2::everywhere()) && inner.spacing == 0.0f;
        b = k.warp_bounds(params, {}, plane ? child_global : tree_bounds(child, inner));
        break;
      }
    }
    return bounds_.emplace(&n, b).first->second;
  }

  std::unordered_map<const Node*, NodeBounds>& bounds() { return bounds_; }

 private:
  std::size_t whole(const Node* a, const Node* b) {
    Diff d;
    d.before = a;
    d.after = b;
    d.whole = true;
    return push(std::move(d));
  }

  Box2 support_of(const Node* n) { return n == nullptr ? Box2{} : global_bounds(*n).support; }

  std::size_t push(Diff d) {
    if (d.whole) {
      d.reach = Box2::everywhere();
    } else if (d.before->type->category == NodeCategory::warp) {
      const Box2 inner = data_.diffs[d.slots.front().diff].reach;
      if (!inner.empty()) {
        if (!finite(inner)) {
          d.reach = Box2::everywhere();
        } else {
          // The child frame's box seen from the parent: what the node's bounds do to a support.
          NodeBounds child;
          child.support = inner;
          d.reach = padded(
              d.before->type->kernels.warp_bounds(d.before->params.pool.data(), {}, child).support);
          if (!finite(d.reach)) d.reach = Box2::everywhere();
        }
      }
    } else {
      for (const Slot& slot : d.slots) {
        const Diff& c = data_.diffs[slot.diff];
        Box2 r = c.reach;
        if (slot.by_weight) r = intersect(r, unite(support_of(c.before), support_of(c.after)));
        d.reach = unite(d.reach, r);
      }
    }
    data_.diffs.push_back(std::move(d));
    return data_.diffs.size() - 1;
  }

  std::uint64_t hash(const Node& n) {
    if (auto it = hashes_.find(&n); it != hashes_.end()) return it->second;
    std::uint64_t h = mix(n.type->id, n.params.pool.size());
    for (float v : n.params.pool) h = mix(h, std::bit_cast<std::uint32_t>(v));
    h = mix(h, n.children.size());
    for (const NodePtr& c : n.children) h = mix(h, hash(*c));
    hashes_.emplace(&n, h);
    return h;
  }

  bool same(const Node& a, const Node& b) { return hash(a) == hash(b) && equal(a, b); }

  bool equal(const Node& a, const Node& b) {
    if (&a == &b) return true;
    if (a.type != b.type || a.children.size() != b.children.size() ||
        !same_pool(a.params.pool, b.params.pool)) {
      return false;
    }
    for (std::size_t i = 0; i < a.children.size(); ++i) {
      if (!equal(*a.children[i], *b.children[i])) return false;
    }
    return true;
  }

  // Pairs of identical children, in order in both lists (a common subsequence: longest when the
  // lists are small enough, else greedy).
  std::vector<std::pair<std::size_t, std::size_t>> common_children(const std::vector<NodePtr>& a,
                                                                   const std::vector<NodePtr>& b) {
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    std::size_t head = 0;
    while (head < a.size() && head < b.size() && same(*a[head], *b[head])) {
      pairs.emplace_back(head, head);
      ++head;
    }
    std::size_t tail = 0;
    while (tail < a.size() - head && tail < b.size() - head &&
           same(*a[a.size() - 1 - tail], *b[b.size() - 1 - tail])) {
      ++tail;
    }
    const std::size_t n = a.size() - head - tail, m = b.size() - head - tail;
    if (n > 0 && m > 0) {
      if (n * m <= 1'000'000) {
        // lcs[i][j]: longest common subsequence of a[head + i ..] and b[head + j ..].
        std::vector<std::uint32_t> lcs((n + 1) * (m + 1), 0);
        const auto at = [&](std::size_t i, std::size_t j) -> std::uint32_t& {
          return lcs[i * (m + 1) + j];
        };
        for (std::size_t i = n; i-- > 0;) {
          for (std::size_t j = m; j-- > 0;) {
            at(i, j) = same(*a[head + i], *b[head + j]) ? at(i + 1, j + 1) + 1
                                                        : std::max(at(i + 1, j), at(i, j + 1));
          }
        }
        for (std::size_t i = 0, j = 0; i < n && j < m;) {
          if (same(*a[head + i], *b[head + j])) {
            pairs.emplace_back(head + i++, head + j++);
          } else if (at(i + 1, j) >= at(i, j + 1)) {
            ++i;
          } else {
            ++j;
          }
        }
      } else {
        std::unordered_map<std::uint64_t, std::vector<std::size_t>> positions;
        for (std::size_t j = 0; j < m; ++j) positions[hash(*b[head + j])].push_back(head + j);
        std::size_t next = head;
        for (std::size_t i = head; i < head + n; ++i) {
          auto it = positions.find(hash(*a[i]));
          if (it == positions.end()) continue;
          for (auto p = std::lower_bound(it->second.begin(), it->second.end(), next);
               p != it->second.end(); ++p) {
            if (equal(*a[i], *b[*p])) {
              pairs.emplace_back(i, *p);
              next = *p + 1;
              break;
            }
          }
        }
      }
    }
    for (std::size_t t = tail; t-- > 0;) pairs.emplace_back(a.size() - 1 - t, b.size() - 1 - t);
    return pairs;
  }

  // A blend accumulates its children in the order of blend_order_key (ties in declaration
  // order), a key of each child's own support: children kept identical, in the same relative
  // order, are summed in the same order in both versions. Between them, runs of changed children
  // are paired by position when the runs have the same length, and a pair differs only where its
  // own diff says — provided its place in the order relative to every other kept child stays;
  // else, as any unpaired child, it counts as removed and added: it differs wherever it weighs.
  void match_blend_children(const Node& a, const Node& b, std::vector<Slot>& slots) {
    struct Kept {
      std::size_t before = 0, after = 0;  // indices in a's and b's children
      std::uint64_t key_before = 0, key_after = 0;
      bool paired = false;  // changed, to be compared recursively
    };
    std::vector<Kept> kept;
    const auto key = [](const Node& n) { return blend_order_key(tree_bounds(n, {}).support); };
    const auto removed_and_added = [&](const Node* o, const Node* n) {
      if (o != nullptr) slots.push_back({whole(o, nullptr), true});
      if (n != nullptr) slots.push_back({whole(nullptr, n), true});
    };
    const auto gap = [&](std::size_t i0, std::size_t i1, std::size_t j0, std::size_t j1) {
      if (i1 - i0 == j1 - j0) {
        for (std::size_t k = 0; k < i1 - i0; ++k) {
          const Node& o = *a.children[i0 + k];
          const Node& n = *b.children[j0 + k];
          kept.push_back({i0 + k, j0 + k, key(o), key(n), true});
        }
        return;
      }
      for (std::size_t i = i0; i < i1; ++i) removed_and_added(a.children[i].get(), nullptr);
      for (std::size_t j = j0; j < j1; ++j) removed_and_added(nullptr, b.children[j].get());
    };
    std::size_t i = 0, j = 0;
    for (const auto& [ai, bj] : common_children(a.children, b.children)) {
      gap(i, ai, j, bj);
      const std::uint64_t k = key(*a.children[ai]);
      kept.push_back({ai, bj, k, k, false});
      i = ai + 1;
      j = bj + 1;
    }
    gap(i, a.children.size(), j, b.children.size());
    // Kept children keep their declaration order, so only a changed key can reorder a pair.
    const auto reordered = [&](const Kept& p) {
      if (p.key_before == p.key_after) return false;
      return std::any_of(kept.begin(), kept.end(), [&](const Kept& q) {
        if (&q == &p) return false;
        const bool first_before =
            p.key_before != q.key_before ? p.key_before < q.key_before : p.before < q.before;
        const bool first_after =
            p.key_after != q.key_after ? p.key_after < q.key_after : p.after < q.after;
        return first_before != first_after;
      });
    };
    for (const Kept& p : kept) {
      if (!p.paired) continue;
      const Node* o = a.children[p.before].get();
      const Node* n = b.children[p.after].get();
      if (reordered(p)) {
        removed_and_added(o, n);
      } else if (auto c = build(o, n)) {
        slots.push_back({*c, true});
      }
    }
  }

  SceneChange::Data& data_;
  std::unordered_map<const Node*, std::uint64_t> hashes_;
  std::unordered_map<const Node*, NodeBounds> bounds_;
};

void collect_bounds(DiffBuilder& builder, const Node* root) {
  if (root != nullptr) builder.global_bounds(*root);
}

bool same_georeference(const Georeference& a, const Georeference& b) {
  return a.latitude == b.latitude && a.longitude == b.longitude && a.heading == b.heading;
}
bool same_square(const TileBounds& a, const TileBounds& b) {
  return a.west == b.west && a.south == b.south && a.east == b.east && a.north == b.north;
}

std::size_t format_index(TileFormat format) {
  return static_cast<std::size_t>(format);
}

// A box of doubles as floats: rounding is monotonic, so float samples of points in the box lie in
// the rounded box.
Box2 to_float_box(double west, double south, double east, double north) {
  return {{static_cast<float>(west), static_cast<float>(south)},
          {static_cast<float>(east), static_cast<float>(north)}};
}

// Samples of one zoom level and layout, by global index: column c lies at
// world.west + (c + offset)·step, row r (counted from the north) at world.north − (r +
// offset)·step, as HeightTile::sample_crs_x/y place them (a tile's columns are x·cells + 0 ..
// x·cells + width − 1).
struct Grid {
  TileScheme scheme = TileScheme::local;
  int z = 0;
  std::int64_t cells = 0;
  std::int64_t width = 0;  ///< samples per tile side, border included
  double offset = 0.0;
  TileBounds world;
  double step_x = 0.0, step_y = 0.0;
  float spacing = 0.0f;  ///< the level of detail the samples are evaluated at
};

Grid grid_for(const TileSource& source, const TileRequest& request) {
  Grid g;
  g.scheme = request.scheme;
  g.z = request.address.z;
  g.cells = request.cells;
  g.width = tile_layout_for(request).width;
  g.offset = request.layout == SampleLayout::cell_centres ? 0.5 - request.border : 0.0;
  g.world = world_bounds(source, g.scheme);
  g.step_x =
      (g.world.east - g.world.west) / static_cast<double>(columns_at(g.scheme, g.z) * g.cells);
  g.step_y =
      (g.world.north - g.world.south) / static_cast<double>(rows_at(g.scheme, g.z) * g.cells);
  g.spacing = static_cast<float>(ground_spacing(source, g.scheme, g.z, request.cells));
  return g;
}

// An inclusive range of global sample columns and rows (rows counted from the north).
struct SampleRange {
  std::int64_t x0 = 0, x1 = -1, y0 = 0, y1 = -1;
};

// The samples of every tile of the grid's zoom under `node` (a tile of that zoom or coarser).
SampleRange samples_under(const Grid& g, const TileAddress& node) {
  const int k = g.z - node.z;
  const std::int64_t north_row =
      g.scheme == TileScheme::geographic ? rows_at(g.scheme, node.z) - 1 - node.y : node.y;
  return {(node.x << k) * g.cells, (((node.x + 1) << k) - 1) * g.cells + g.width - 1,
          (north_row << k) * g.cells, (((north_row + 1) << k) - 1) * g.cells + g.width - 1};
}

// Cosine of the angle at the centre of a sphere between the frame's origin and a point.
double cos_angle_from_origin(const GeoFrame& frame, double lat, double lon) {
  const double lat0 = frame.georeference().latitude * kDegree;
  return std::sin(lat0) * std::sin(lat * kDegree) +
         std::cos(lat0) * std::cos(lat * kDegree) *
             std::cos((lon - frame.georeference().longitude) * kDegree);
}

// Whether every point of a longitude/latitude rectangle lies more than 61.5° from the origin
// (on a sphere; the frame's 60° limit on the ellipsoid differs by well under the margin), so
// that the frame maps none of them. cos θ = sin φ₀ sin φ + cos φ₀ cos φ cos Δλ is at most
// A cos(φ − ψ) with Δλ the smallest longitude difference, A = |(sin φ₀, cos φ₀ cos Δλ)| and ψ
// its angle; maximise that over the rectangle's latitudes.
bool surely_unmapped(const GeoFrame& frame, double lon0, double lon1, double lat0, double lat1) {
  const double a = lon0 - frame.georeference().longitude, b = lon1 - frame.georeference().longitude;
  double nearest = 0.0;  // degrees of longitude from the origin's meridian to the rectangle
  if (std::ceil(a / 360.0) * 360.0 > b) {
    const auto wrapped = [](double d) { return std::abs(d - 360.0 * std::round(d / 360.0)); };
    nearest = std::min(wrapped(a), wrapped(b));
  }
  const double phi0 = frame.georeference().latitude * kDegree;
  const double s = std::sin(phi0), c = std::cos(phi0) * std::cos(nearest * kDegree);
  const double psi = std::atan2(s, c);
  const double lo = lat0 * kDegree, hi = lat1 * kDegree;
  const double best =
      psi >= lo && psi <= hi ? 1.0 : std::max(std::cos(lo - psi), std::cos(hi - psi));
  return std::hypot(s, c) * best < std::cos(61.5 * kDegree);
}

// The scene-plane box of a longitude/latitude rectangle's mapped points. The frame is an
// orthographic projection of the ellipsoid, so it never lengthens a distance (1-Lipschitz). On
// the near side of the globe (within 80° here) it is one to one, so the image of the rectangle is
// bounded by the image of its outline, and a point of the outline lies within half a segment's
// ground length of one of the samples taken along it. Elsewhere every point lies within the
// rectangle's ground diameter of any sample.
Box2 geographic_footprint(const GeoFrame& frame, double lon0, double lon1, double lat0,
                          double lat1) {
  if (surely_unmapped(frame, lon0, lon1, lat0, lat1)) return {};  // every sample at base level
  constexpr int kSteps = 32;
  constexpr double kRadius = 1.01 * 6378137.0;  // above every radius of curvature of WGS84
  double lo_x = 1e300, lo_y = 1e300, hi_x = -1e300, hi_y = -1e300;
  bool near_side = true;
  for (int edge = 0; edge < 4; ++edge) {
    for (int i = 0; i <= kSteps; ++i) {
      const double t = static_cast<double>(i) / kSteps;
      const double lon = edge < 2 ? lon0 + t * (lon1 - lon0) : (edge == 2 ? lon0 : lon1);
      const double lat = edge < 2 ? (edge == 0 ? lat0 : lat1) : lat0 + t * (lat1 - lat0);
      double x = 0.0, y = 0.0;
      frame.to_scene(lat, lon, x, y);  // the projection, whether or not the frame maps it
      lo_x = std::min(lo_x, x), hi_x = std::max(hi_x, x);
      lo_y = std::min(lo_y, y), hi_y = std::max(hi_y, y);
      near_side = near_side && cos_angle_from_origin(frame, lat, lon) > std::cos(80.0 * kDegree);
    }
  }
  const double dlat = (lat1 - lat0) * kDegree;
  const double dlon = (lon1 - lon0) * kDegree;
  const double parallel = std::max(std::cos(lat0 * kDegree), std::cos(lat1 * kDegree));
  const double reach = near_side ? 0.5 * kRadius * std::max(dlat, dlon * parallel) / kSteps
                                 : kRadius * (dlat + dlon);
  return padded(to_float_box(lo_x - reach, lo_y - reach, hi_x + reach, hi_y + reach));
}

// The scene-plane box of the samples in `r`.
Box2 footprint(const Grid& g, const GeoFrame& frame, const SampleRange& r) {
  const double west = g.world.west + (static_cast<double>(r.x0) + g.offset) * g.step_x;
  const double east = g.world.west + (static_cast<double>(r.x1) + g.offset) * g.step_x;
  const double north = g.world.north - (static_cast<double>(r.y0) + g.offset) * g.step_y;
  const double south = g.world.north - (static_cast<double>(r.y1) + g.offset) * g.step_y;
  if (g.scheme == TileScheme::local) return padded(to_float_box(west, south, east, north));

  // The tile sampler's own conversions (tile.hpp), so that the footprint is where it samples.
  const bool mercator = g.scheme == TileScheme::webmercator;
  const double lon0 = mercator ? web_mercator_longitude(west) : west;
  const double lon1 = mercator ? web_mercator_longitude(east) : east;
  const auto latitude = [&](double y) {
    const double lat = mercator ? web_mercator_latitude(y) : y;
    return std::clamp(lat, -90.0, 90.0);  // border rows beyond a pole sit on it
  };
  return geographic_footprint(frame, lon0, lon1, latitude(south), latitude(north));
}

// Whether `may_differ` holds for the footprint of some part of `r`: a box that holds for is split
// in four along sample lines (the gaps between samples drop out) until its parts hold 2×2
// samples or fewer, so the answer follows the samples rather than the tile's box.
template <class Predicate>
bool some_samples_may_differ(const Grid& g, const GeoFrame& frame, const SampleRange& r,
                             const Predicate& may_differ) {
  if (!may_differ(footprint(g, frame, r), g.spacing)) return false;
  const std::int64_t w = r.x1 - r.x0 + 1, h = r.y1 - r.y0 + 1;
  if (w <= 2 && h <= 2) return true;
  const std::int64_t xm = w > 2 ? r.x0 + w / 2 : r.x1 + 1;
  const std::int64_t ym = h > 2 ? r.y0 + h / 2 : r.y1 + 1;
  const SampleRange parts[4] = {{r.x0, xm - 1, r.y0, ym - 1},
                                {xm, r.x1, r.y0, ym - 1},
                                {r.x0, xm - 1, ym, r.y1},
                                {xm, r.x1, ym, r.y1}};
  for (const SampleRange& part : parts) {
    if (part.x0 <= part.x1 && part.y0 <= part.y1 &&
        some_samples_may_differ(g, frame, part, may_differ)) {
      return true;
    }
  }
  return false;
}

}  // namespace

SceneChange SceneChange::between(std::shared_ptr<const Scene> before,
                                 std::shared_ptr<const TileSource> before_source,
                                 std::shared_ptr<const Scene> after,
                                 std::shared_ptr<const TileSource> after_source) {
  assert(before && before_source && after && after_source);
  auto data = std::make_shared<Data>();
  data->before = std::move(before);
  data->after = std::move(after);
  data->before_source = std::move(before_source);
  data->after_source = std::move(after_source);
  const Scene& a = *data->before;
  const Scene& b = *data->after;
  const TileSource& sa = *data->before_source;
  const TileSource& sb = *data->after_source;

  // Scene-wide inputs of every tile: noise seeds (the scene seed is mixed into each), the base
  // level (blend defaults, unmapped samples), the local scheme's square (from the extent, or the
  // root's support), and the georeference (geographic sample positions, spacings, TIFF tags).
  data->everything = a.seed != b.seed || !same_bits(sa.base_elevation, sb.base_elevation) ||
                     !same_square(sa.local_square, sb.local_square) ||
                     !same_georeference(sa.georeference, sb.georeference);
  if (data->everything) return SceneChange(std::move(data));

  // Constants that ProductMaker derives from the elevation range and the square, as it uses them.
  const ProductConstants ca = ProductMaker(sa).constants();
  const ProductConstants cb = ProductMaker(sb).constants();
  data->global[format_index(TileFormat::gray16)] =
      ca.gray16.offset != cb.gray16.offset || ca.gray16.scale != cb.gray16.scale;
  data->global[format_index(TileFormat::quantized_mesh)] =
      ca.edge_quantum != cb.edge_quantum ||
      !std::equal(std::begin(ca.max_useful_zoom), std::end(ca.max_useful_zoom),
                  std::begin(cb.max_useful_zoom));
  const bool positions = ca.position_quantum != cb.position_quantum;
  data->global[format_index(TileFormat::glb)] = positions;
  data->global[format_index(TileFormat::draco)] = positions;
  // Colour tiles measure heights against the relief and take the scene's material.
  const bool colours =
      !same_bits(ca.relief.lo, cb.relief.lo) || !same_bits(ca.relief.hi, cb.relief.hi) ||
      !same_bits(ca.shore_band, cb.shore_band) || !same_material(ca.material, cb.material);
  data->global[format_index(TileFormat::color_png)] = colours;
  data->global[format_index(TileFormat::color_jpeg)] = colours;

  DiffBuilder builder(*data);
  for (const Node* root : {a.root.get(), b.root.get(), a.water.get(), b.water.get()}) {
    collect_bounds(builder, root);
  }
  data->terrain = builder.build(a.root.get(), b.root.get());
  data->water = builder.build(a.water.get(), b.water.get());
  for (const auto& [node, bounds] : builder.bounds()) data->supports.emplace(node, bounds.support);

  const Box2 terrain_reach = data->terrain ? data->diffs[*data->terrain].reach : Box2{};
  if (!terrain_reach.empty() && !finite(terrain_reach)) {
    data->everything = true;  // the root's elevation may change without bound
    return SceneChange(std::move(data));
  }
  // The quantized-mesh water mask changes only where the water is (weight ≥ 0.5 in either
  // version) and the water or the terrain below it changes.
  Box2 water_reach = data->water ? data->diffs[*data->water].reach : Box2{};
  water_reach = intersect(unite(water_reach, terrain_reach),
                          unite(a.water ? data->support(a.water.get()) : Box2{},
                                b.water ? data->support(b.water.get()) : Box2{}));
  if (!water_reach.empty() && !finite(water_reach)) {
    data->global[format_index(TileFormat::quantized_mesh)] = true;
    water_reach = Box2{};
  }
  data->box = unite(terrain_reach, water_reach);
  data->frame.emplace(sa.georeference);
  return SceneChange(std::move(data));
}

bool SceneChange::everything() const {
  return data_->everything;
}

bool SceneChange::format_global(TileFormat format) const {
  return data_->everything || data_->global[format_index(format)];
}

bool SceneChange::unchanged() const {
  if (data_->everything || !data_->box.empty()) return false;
  return std::none_of(data_->global.begin(), data_->global.end(), [](bool g) { return g; });
}

std::optional<Box2> SceneChange::box() const {
  if (data_->everything || data_->box.empty()) return std::nullopt;
  return data_->box;
}

// May a sample of the tiles of zoom z under `node` differ in `format`? `refine`: follow the
// samples (for the tile itself) rather than answer for the whole footprint (for its ancestors).
bool SceneChange::Data::region_may_change(TileScheme scheme, const TileAddress& node, int z,
                                          TileFormat format, const ProductOptions& options,
                                          bool refine) const {
  if (everything || global[format_index(format)]) return true;
  if (box.empty()) return false;
  const TileSource& source = *before_source;
  const auto check = [&](const Grid& g, const auto& may_differ) {
    const SampleRange r = samples_under(g, node);
    return refine ? some_samples_may_differ(g, *frame, r, may_differ)
                  : may_differ(footprint(g, *frame, r), g.spacing);
  };
  const auto terrain_differs = [&](const Box2& q, float spacing) {
    return q.intersects(box) && terrain && differs(*terrain, q, spacing);
  };
  const Grid samples =
      grid_for(source, ProductMaker::request_for(scheme, {z, 0, 0}, format, options));
  if (check(samples, terrain_differs)) return true;
  const Node* water_before = before->water.get();
  const Node* water_after = after->water.get();
  if (format != TileFormat::quantized_mesh || !options.watermask ||
      (water_before == nullptr && water_after == nullptr)) {
    return false;
  }
  // The water mask: terrain and water on a 256×256 cell-centred grid (TileGenerator::water_mask);
  // a sample's wetness can change only where the water is (weight ≥ 0.5 in either version).
  const auto mask_differs = [&](const Box2& q, float spacing) {
    if (!q.intersects(box)) return false;
    const bool changes =
        (terrain && differs(*terrain, q, spacing)) || (water && differs(*water, q, spacing));
    return changes && (may_be_wet(water_before, q, spacing) || may_be_wet(water_after, q, spacing));
  };
  return check(grid_for(source, {scheme, {z, 0, 0}, SampleLayout::cell_centres, 256, 0}),
               mask_differs);
}

namespace {

// What ProductMaker::make refuses before any work.
bool valid_request(TileScheme scheme, const TileAddress& address, TileFormat format,
                   const ProductOptions& options) {
  if (!validate_request(ProductMaker::request_for(scheme, address, format, options))) return false;
  return format != TileFormat::quantized_mesh || scheme == TileScheme::geographic;
}

}  // namespace

bool SceneChange::tile_may_change(TileScheme scheme, const TileAddress& address, TileFormat format,
                                  const ProductOptions& options) const {
  if (!valid_request(scheme, address, format, options)) return true;
  // The same path as changed_tiles' descent, so that both answer alike.
  for (int z = 0; z < address.z; ++z) {
    const TileAddress ancestor{z, address.x >> (address.z - z), address.y >> (address.z - z)};
    if (!data_->region_may_change(scheme, ancestor, address.z, format, options, false)) {
      return false;
    }
  }
  return data_->region_may_change(scheme, address, address.z, format, options, true);
}

std::vector<TileAddress> SceneChange::changed_tiles(TileScheme scheme, int z, TileFormat format,
                                                    const ProductOptions& options,
                                                    std::size_t limit, bool* truncated) const {
  std::vector<TileAddress> out;
  bool cut = false;
  if (truncated != nullptr) *truncated = false;
  if (!valid_request(scheme, {z, 0, 0}, format, options) || unchanged()) return out;
  // Depth-first from zoom 0; a subtree is entered only when its footprint may change.
  const auto descend = [&](const auto& self, const TileAddress& node) -> void {
    if (cut || !data_->region_may_change(scheme, node, z, format, options, node.z == z)) return;
    if (node.z == z) {
      if (out.size() >= limit) {
        cut = true;
      } else {
        out.push_back(node);
      }
      return;
    }
    for (std::int64_t dy = 0; dy < 2; ++dy) {
      for (std::int64_t dx = 0; dx < 2; ++dx) {
        self(self, {node.z + 1, 2 * node.x + dx, 2 * node.y + dy});
      }
    }
  };
  for (std::int64_t x = 0; x < columns_at(scheme, 0); ++x) descend(descend, {0, x, 0});
  if (truncated != nullptr) *truncated = cut;
  return out;
}

}  // namespace terrain
