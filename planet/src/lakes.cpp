#include "lakes.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <tuple>
#include <vector>

namespace planet {
namespace {

// The lakes' order, apart from every other stream of the planet's seed.
constexpr std::uint64_t kLakeSalt = 0x6c616b6573ULL;

// A leaf triangle's side: the edge from v[side] to v[side + 1].
struct Side {
  std::int32_t tri;
  int side;
};

struct Candidate {
  std::uint64_t key;  // the seeded order
  Side side;          // a river edge, seen from the triangle with the smaller index
};

class LakePlacer {
 public:
  explicit LakePlacer(BaseMesh& mesh)
      : mesh_(mesh), h_(mesh.hierarchy), def_(mesh.rules.def), taken_(h_.vertices.size(), 0) {
    neighbours_.resize(h_.vertices.size());
    incident_.resize(h_.vertices.size());
    for (std::int32_t t : mesh_.leaves) {
      const Tri& tri = h_.tris[static_cast<std::size_t>(t)];
      for (std::size_t k = 0; k < 3; ++k) {
        neighbours_[tri.v[k]].push_back(tri.v[(k + 1) % 3]);
        neighbours_[tri.v[(k + 1) % 3]].push_back(tri.v[k]);
        incident_[tri.v[k]].push_back(t);
      }
    }
    for (auto& list : neighbours_) {
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
    }
  }

  void run() {
    std::vector<Candidate> candidates;
    for (std::int32_t t : mesh_.leaves) {
      const Tri& tri = h_.tris[static_cast<std::size_t>(t)];
      for (int k = 0; k < 3; ++k) {
        if (tri.edge[static_cast<std::size_t>(k)] != EdgeType::river ||
            tri.nb[static_cast<std::size_t>(k)] < t) {
          continue;
        }
        const Vertex& a = vertex(tri.v[static_cast<std::size_t>(k)]);
        const Vertex& b = vertex(tri.v[static_cast<std::size_t>((k + 1) % 3)]);
        candidates.push_back({mix64(def_.seed ^ kLakeSalt ^ mix64(a.seed + b.seed)), {t, k}});
      }
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
      return std::tie(x.key, x.side.tri, x.side.side) < std::tie(y.key, y.side.tri, y.side.side);
    });
    for (const Candidate& c : candidates) {
      if (mesh_.stats.lakes >= def_.lakes) break;
      try_lake(c.side);
    }
  }

 private:
  Vertex& vertex(std::uint32_t v) { return h_.vertices[v]; }
  Tri& tri(std::int32_t t) { return h_.tris[static_cast<std::size_t>(t)]; }

  // The side of triangle `t` that runs from u to v, or −1.
  int side_from(std::int32_t t, std::uint32_t u, std::uint32_t v) {
    const Tri& x = tri(t);
    for (int k = 0; k < 3; ++k) {
      if (x.v[static_cast<std::size_t>(k)] == u && x.v[static_cast<std::size_t>((k + 1) % 3)] == v)
        return k;
    }
    return -1;
  }

  // Sets the edge type of side s on both triangles that share it.
  void set_edge(Side s, EdgeType type) {
    Tri& t = tri(s.tri);
    const auto k = static_cast<std::size_t>(s.side);
    t.edge[k] = type;
    const std::int32_t across = t.nb[k];
    const int back = side_from(across, t.v[(k + 1) % 3], t.v[k]);
    tri(across).edge[static_cast<std::size_t>(back)] = type;
  }

  // The river edge leaving c towards its lowest river neighbour, if any.
  bool outflow_of(std::uint32_t c, std::uint32_t& down, Side& side) {
    bool found = false;
    for (std::int32_t t : incident_[c]) {
      const Tri& x = tri(t);
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t u = x.v[static_cast<std::size_t>(k)];
        const std::uint32_t v = x.v[static_cast<std::size_t>((k + 1) % 3)];
        if (x.edge[static_cast<std::size_t>(k)] != EdgeType::river || (u != c && v != c)) continue;
        const std::uint32_t other = u == c ? v : u;
        if (vertex(other).water < vertex(c).water &&
            (!found || vertex(other).water < vertex(down).water)) {
          down = other;
          side = {t, k};
          found = true;
        }
      }
    }
    return found;
  }

  void try_lake(Side river) {
    Tri& t = tri(river.tri);
    const auto k = static_cast<std::size_t>(river.side);
    const std::int32_t n = t.nb[k];
    const std::uint32_t a = t.v[k], b = t.v[(k + 1) % 3], x = t.v[(k + 2) % 3];
    const int back = side_from(n, b, a);
    const std::uint32_t y = tri(n).v[static_cast<std::size_t>((back + 2) % 3)];
    const std::array<std::uint32_t, 4> lake = {a, b, x, y};
    // A river edge inland between two dry apexes, apart from every other lake.
    if (t.face != FaceType::land || tri(n).face != FaceType::land) return;
    for (std::uint32_t v : {a, b}) {
      if (vertex(v).flags != (kLand | kRiver)) return;
    }
    for (std::uint32_t v : {x, y}) {  // dry land or an inland river
      if (vertex(v).flags != kLand && vertex(v).flags != (kLand | kRiver)) return;
    }
    for (std::uint32_t v : lake) {
      if (taken_[v] != 0) return;
    }
    // No larger than two triangles of average size: the base mesh's triangles vary several-fold.
    const auto area_of = [&](const Tri& f) {
      return spherical_area(vertex(f.v[0]).p, vertex(f.v[1]).p, vertex(f.v[2]).p);
    };
    if (area_of(t) + area_of(tri(n)) > 2.0 * kFourPi / static_cast<double>(mesh_.leaves.size()))
      return;
    if (vertex(a).water == vertex(b).water) return;
    const std::uint32_t c = vertex(a).water < vertex(b).water ? a : b;  // the outlet
    const std::uint32_t r = c == a ? b : a;
    std::uint32_t down = 0;
    Side outflow{};
    if (!outflow_of(c, down, outflow)) return;
    const bool closed = mesh_.rules.dryness(vertex(c).p) >= 1.0 - def_.aridity;
    // The neighbours outside the lake but an open lake's outflow: the rim, which must stand
    // above the lake, and the rivers that will end in it (those that flowed past an apex turn
    // into it), none draining more than the outlet, whose area the lake takes.
    const float area = vertex(c).drainage_area;
    double rim = std::numeric_limits<double>::infinity();
    for (std::uint32_t v : lake) {
      for (std::uint32_t q : neighbours_[v]) {
        if (std::find(lake.begin(), lake.end(), q) != lake.end() || (!closed && q == down))
          continue;
        if ((vertex(q).flags & kRiver) != 0 && vertex(q).drainage_area > area) return;
        rim = std::min(rim, outflow_level(vertex(q)));
      }
    }
    // Open: filled to the outlet's water, which the rim must hold. Closed: below the rim by the
    // riverbed edge height, so that the rules keep every split around it above the water.
    const double level =
        closed ? std::min(vertex(c).water, rim - def_.riverbed_edge_height) : vertex(c).water;
    if (!(rim > level)) return;
    for (std::uint32_t v : {r, x, y}) {
      if (outflow_level(vertex(v)) < level) return;  // a lake only lowers where water leaves
    }

    t.face = FaceType::lake;
    tri(n).face = FaceType::lake;
    set_edge(river, EdgeType::lake);
    for (Side s : {Side{river.tri, static_cast<int>((k + 1) % 3)},
                   Side{river.tri, static_cast<int>((k + 2) % 3)}, Side{n, (back + 1) % 3},
                   Side{n, (back + 2) % 3}}) {
      set_edge(s, EdgeType::shore);
    }
    if (closed) set_edge(outflow, EdgeType::land);
    for (std::uint32_t v : lake) {
      Vertex& w = vertex(v);
      w.flags = static_cast<std::uint8_t>(w.flags | kLake);
      w.detail = 0.0f;
      w.water = level;
      w.drainage_area = area;
      // The open lake's outlet keeps its river's bed; every other lake vertex is shore.
      if (closed || v != c) w.ground = level;
      if ((w.flags & kRiver) == 0) w.tangent = {0.0f, 0.0f, 0.0f};
    }
    for (std::uint32_t v : lake) {
      taken_[v] = 1;
      for (std::uint32_t q : neighbours_[v]) taken_[q] = 1;
    }
    ++mesh_.stats.lakes;
    if (closed) ++mesh_.stats.closed_lakes;
  }

  BaseMesh& mesh_;
  Hierarchy& h_;
  const PlanetDefinition& def_;
  std::vector<std::uint8_t> taken_;  // a lake's vertices and their neighbours
  std::vector<std::vector<std::uint32_t>> neighbours_;
  std::vector<std::vector<std::int32_t>> incident_;  // the leaves around each vertex
};

}  // namespace

void place_lakes(BaseMesh& mesh) {
  if (mesh.rules.def.lakes == 0) return;
  LakePlacer(mesh).run();
}

}  // namespace planet
