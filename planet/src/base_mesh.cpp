#include "planet/base_mesh.hpp"

#include "terrain/scene.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <numbers>
#include <queue>
#include <thread>
#include <unordered_map>

#include "gradient_noise.hpp"
#include "lakes.hpp"
#include "planet/geodesy.hpp"

namespace planet {

bool near_cone_point(const Vec3d& p) {
  static const double nearest = std::cos(kConePointSea);
  return std::abs(p[0]) > nearest || std::abs(p[1]) > nearest;
}

bool touches_cone_point(const Hierarchy& h, const Tri& t) {
  return std::any_of(t.v.begin(), t.v.end(),
                     [&](std::uint32_t v) { return near_cone_point(h.vertices[v].p); });
}

namespace {

// Low-frequency field that shapes the continents: growth prefers faces where it is high.
double shape_field(const Vec3d& p, std::uint32_t seed) {
  double sum = 0.0, amplitude = 1.0, frequency = 1.5;
  for (int octave = 0; octave < 4; ++octave) {
    sum += amplitude * detail::gradient3(p[0] * frequency, p[1] * frequency, p[2] * frequency,
                                         seed + static_cast<std::uint32_t>(octave));
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return sum;
}

std::array<float, 3> tangent_towards(const Vec3d& p, const Vec3d& direction) {
  const Vec3d t = sub(direction, scale(p, dot(direction, p)));
  const double n = std::sqrt(dot(t, t));
  if (!(n > 0.0)) return {0.0f, 0.0f, 0.0f};
  return {static_cast<float>(t[0] / n), static_cast<float>(t[1] / n), static_cast<float>(t[2] / n)};
}

Vec3d unit_or_zero(const Vec3d& v) {
  const double n = std::sqrt(dot(v, v));
  return n > 0.0 ? scale(v, 1.0 / n) : Vec3d{0, 0, 0};
}

// The drainage relief model (planet.md "Relief models"): a base river stands this share of the
// highest belt or plateau uplift on its way from the sea above its least-slope profile; of this
// many random river edges the one whose new vertex would stand lowest grows first; and a land
// vertex beside the coast drains straight to it where joining the river it was drawn for would
// stand it this many metres higher.
constexpr double kRiverUpliftShare = 0.6;
constexpr int kLowlandFirstDraws = 32;
constexpr double kPerchedRiver = 300.0;

struct Edge {
  std::uint32_t u, v;
  std::int32_t face[2];  // tri indices
  int side[2];           // edge index within each tri
};

// §4.1 and §4.2 on the level-B mesh.
class Classifier {
 public:
  Classifier(BaseMesh& mesh, const std::vector<std::int32_t>& faces, const ContinentMap* map)
      : mesh_(mesh),
        h_(mesh.hierarchy),
        def_(mesh.rules.def),
        faces_(faces),
        map_(map),
        random_(mix64(def_.seed ^ 0x636f6e74696e656eULL)) {}

  void run() {
    index();
    if (map_ != nullptr) {
      continents_from_map();
    } else {
      grow_continents();
    }
    label_edges();
    grow_rivers();
    assign_altitudes();
  }

 private:
  Vertex& vertex(std::uint32_t v) { return h_.vertices[v]; }
  Tri& tri(std::int32_t t) { return h_.tris[static_cast<std::size_t>(t)]; }

  void index() {
    const std::size_t nv = h_.vertices.size();
    face_of_.assign(h_.tris.size(), -1);
    for (std::size_t f = 0; f < faces_.size(); ++f) {
      face_of_[static_cast<std::size_t>(faces_[f])] = static_cast<std::int32_t>(f);
    }
    incident_.assign(nv, {});
    neighbours_.assign(nv, {});
    std::unordered_map<std::uint64_t, std::size_t> seen;
    for (std::size_t f = 0; f < faces_.size(); ++f) {
      const Tri& t = tri(faces_[f]);
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t u = t.v[static_cast<std::size_t>(k)];
        const std::uint32_t v = t.v[static_cast<std::size_t>((k + 1) % 3)];
        incident_[u].push_back(static_cast<std::int32_t>(f));
        const std::uint64_t key =
            (static_cast<std::uint64_t>(std::min(u, v)) << 32) | std::max(u, v);
        auto [it, inserted] = seen.emplace(key, edges_.size());
        if (inserted) {
          edges_.push_back({u, v, {faces_[f], -1}, {k, -1}});
          neighbours_[u].push_back({v, static_cast<std::uint32_t>(it->second)});
          neighbours_[v].push_back({u, static_cast<std::uint32_t>(it->second)});
        } else {
          edges_[it->second].face[1] = faces_[f];
          edges_[it->second].side[1] = k;
        }
      }
    }
    area_.resize(faces_.size());
    sea_only_.resize(faces_.size());
    for (std::size_t f = 0; f < faces_.size(); ++f) {
      const Tri& t = tri(faces_[f]);
      area_[f] = spherical_area(vertex(t.v[0]).p, vertex(t.v[1]).p, vertex(t.v[2]).p);
      sea_only_[f] = touches_cone_point(h_, t);
    }
  }

  std::int32_t face_across(std::size_t f, int k) {
    return face_of_[static_cast<std::size_t>(tri(faces_[f]).nb[static_cast<std::size_t>(k)])];
  }

  // §4.1: a face joins continent i when at most one of its vertices is pure sea and the others
  // already belong to i, so two continents always stay an edge apart.
  bool can_add(std::size_t f, int i) {
    if (sea_only_[f]) return false;
    int sea = 0;
    for (std::uint32_t v : tri(faces_[f]).v) {
      if (owner_[v] < 0) {
        ++sea;
      } else if (owner_[v] != i) {
        return false;
      }
    }
    return sea <= 1;
  }

  void add_face(std::size_t f, int i) {
    land_[f] = true;
    land_area_ += area_[f];
    for (std::uint32_t v : tri(faces_[f]).v) owner_[v] = i;
    for (int k = 0; k < 3; ++k) {
      const std::int32_t g = face_across(f, k);
      if (!land_[static_cast<std::size_t>(g)]) frontier_[static_cast<std::size_t>(i)].push_back(g);
    }
  }

  bool seed_continent() {
    for (int attempt = 0; attempt < 4096; ++attempt) {
      const std::size_t f = random_.below(static_cast<std::uint32_t>(faces_.size()));
      if (land_[f] || sea_only_[f]) continue;
      bool free = true;  // every vertex pure sea: the new continent touches no other
      for (std::uint32_t v : tri(faces_[f]).v) free = free && owner_[v] < 0;
      if (!free) continue;
      const int i = static_cast<int>(frontier_.size());
      frontier_.emplace_back();
      weight_.push_back(0.5 + random_.uniform());
      add_face(f, i);
      return true;
    }
    return false;
  }

  void grow_continents() {
    owner_.assign(h_.vertices.size(), -1);
    land_.assign(faces_.size(), false);
    const double target = def_.land_fraction * kFourPi;
    const auto field_seed = static_cast<std::uint32_t>(mix64(def_.seed ^ 0x7368617065ULL));
    for (int i = 0; i < def_.continents; ++i) {
      if (!seed_continent()) break;
    }
    while (land_area_ < target) {
      double total = 0.0;
      for (std::size_t i = 0; i < frontier_.size(); ++i) {
        if (!frontier_[i].empty()) total += weight_[i];
      }
      if (total == 0.0) {  // every continent is blocked: start an island
        if (!seed_continent()) break;
        continue;
      }
      double pick = random_.uniform() * total;
      std::size_t i = 0;
      for (; i < frontier_.size(); ++i) {
        if (frontier_[i].empty()) continue;
        if (pick < weight_[i]) break;
        pick -= weight_[i];
      }
      if (i == frontier_.size()) i = frontier_.size() - 1;
      while (frontier_[i].empty()) --i;
      auto& list = frontier_[i];
      // Of three random frontier faces, the one where the shape field is highest: continents
      // follow the field's ridges instead of growing as round blobs.
      std::size_t best = random_.below(static_cast<std::uint32_t>(list.size()));
      double best_value = -1e9;
      for (int k = 0; k < 3; ++k) {
        const std::size_t j = random_.below(static_cast<std::uint32_t>(list.size()));
        const Tri& t = tri(faces_[static_cast<std::size_t>(list[j])]);
        const Vec3d c = normalize(add(add(vertex(t.v[0]).p, vertex(t.v[1]).p), vertex(t.v[2]).p));
        const double value = shape_field(c, field_seed);
        if (value > best_value) best_value = value, best = j;
      }
      const auto f = static_cast<std::size_t>(list[best]);
      list[best] = list.back();
      list.pop_back();
      if (!land_[f] && can_add(f, static_cast<int>(i))) add_face(f, static_cast<int>(i));
    }
    mesh_.stats.land_fraction = land_area_ / kFourPi;
    mesh_.stats.continents = static_cast<int>(frontier_.size());
  }

  // The paper's alternative to growing continents: the face types come from a bitmap. A face is
  // land where the map, sampled at the face's centre, is land; continents are the connected land
  // components (faces sharing an edge), numbered in face order. Unlike grown continents, two
  // components may touch at a vertex; such a vertex has sea faces around it too, so it is coast,
  // and everything after this step only asks whether a vertex touches land, never whose it is.
  void continents_from_map() {
    owner_.assign(h_.vertices.size(), -1);
    land_.assign(faces_.size(), false);
    // The centre's direction read as geographic coordinates the way tiles and samples read
    // them (geodetic latitude on an ellipsoid), so the map lines up with the products.
    const Geodesy geodesy(def_.radius, def_.flattening);
    for (std::size_t f = 0; f < faces_.size(); ++f) {
      const Tri& t = tri(faces_[f]);
      const Vec3d c = normalize(add(add(vertex(t.v[0]).p, vertex(t.v[1]).p), vertex(t.v[2]).p));
      double latitude = 0.0, longitude = 0.0;
      geodesy.direction_to_geographic(c, latitude, longitude);
      land_[f] = map_->land(latitude, longitude) && !sea_only_[f];
    }
    std::vector<int> component(faces_.size(), -1);
    std::vector<std::size_t> stack;
    int count = 0;
    for (std::size_t start = 0; start < faces_.size(); ++start) {
      if (!land_[start] || component[start] >= 0) continue;
      component[start] = count;
      stack.push_back(start);
      while (!stack.empty()) {
        const std::size_t f = stack.back();
        stack.pop_back();
        land_area_ += area_[f];
        for (std::uint32_t v : tri(faces_[f]).v) {
          if (owner_[v] < 0) owner_[v] = count;
        }
        for (int k = 0; k < 3; ++k) {
          const auto g = static_cast<std::size_t>(face_across(f, k));
          if (land_[g] && component[g] < 0) {
            component[g] = count;
            stack.push_back(g);
          }
        }
      }
      ++count;
    }
    mesh_.stats.land_fraction = land_area_ / kFourPi;
    mesh_.stats.continents = count;
  }

  void label_edges() {
    for (std::size_t f = 0; f < faces_.size(); ++f) {
      Tri& t = tri(faces_[f]);
      t.face = land_[f] ? FaceType::land : FaceType::sea;
      for (int k = 0; k < 3; ++k) {
        const bool other = land_[static_cast<std::size_t>(face_across(f, k))];
        t.edge[static_cast<std::size_t>(k)] = land_[f] && other     ? EdgeType::land
                                              : !land_[f] && !other ? EdgeType::sea
                                                                    : EdgeType::coast;
      }
    }
    const std::size_t nv = h_.vertices.size();
    kind_.assign(nv, kSea);
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (owner_[v] < 0) continue;
      bool all_land = true;
      for (std::int32_t f : incident_[v]) all_land = all_land && land_[static_cast<std::size_t>(f)];
      kind_[v] = all_land ? kLand : kCoast;
    }
  }

  void set_edge(std::uint32_t e, EdgeType type) {
    for (int s = 0; s < 2; ++s) {
      tri(edges_[e].face[s]).edge[static_cast<std::size_t>(edges_[e].side[s])] = type;
    }
  }

  void link(std::uint32_t v, std::uint32_t u, std::uint32_t edge) {
    down_[v] = static_cast<std::int32_t>(u);
    ++inflow_[u];
    if (def_.relief_model == ReliefModel::drainage) {
      path_lift_[v] = std::max(path_lift_[u], kRiverUpliftShare * uplift_[v]);
      profile_[v] = profile_[u] + headwater_rise(u, v);
    }
    in_network_[v] = in_network_[u] = true;
    set_edge(edge, EdgeType::river);
    for (auto [x, e] : neighbours_[v]) {
      if (kind_[x] == kLand && !in_network_[x]) candidates_.push_back({v, x});
    }
  }

  // The drainage model's rise of a headwater along the edge from u to v, at its least slope.
  double headwater_rise(std::uint32_t u, std::uint32_t v) const {
    return headwater_slope_ * mesh_.rules.radius * angle(h_.vertices[u].p, h_.vertices[v].p);
  }

  // The drainage model's estimate, while the network grows, of the level a land vertex v would
  // stand at if it drained to u (a network vertex, or a coast vertex as a new mouth): the
  // highest lift on its way from the sea and its profile at a headwater's least slope
  // (assign_altitudes makes the levels themselves).
  double level_through(std::uint32_t u, std::uint32_t v) const {
    return std::max(path_lift_[u], kRiverUpliftShare * uplift_[v]) + profile_[u] +
           headwater_rise(u, v);
  }

  // The next river edge to grow, at random. The drainage relief model draws a few and grows
  // the one whose new vertex would stand lowest, so rivers fill the lowlands first and climb
  // into the belts and plateaus from every side: their crests become divides, and little land
  // drains to a river that crossed a belt (assign_altitudes lifts such a river to the belt's
  // crest).
  std::size_t pick_candidate() {
    const auto draw = [&] { return random_.below(static_cast<std::uint32_t>(candidates_.size())); };
    std::size_t best = draw();
    if (def_.relief_model != ReliefModel::drainage) return best;
    double lowest = level_through(candidates_[best].first, candidates_[best].second);
    for (int k = 1; k < kLowlandFirstDraws; ++k) {
      const std::size_t j = draw();
      const double level = level_through(candidates_[j].first, candidates_[j].second);
      if (level < lowest) lowest = level, best = j;
    }
    return best;
  }

  // §4.2: mouths from continental vertices next to a free coast vertex, in seeded order; then
  // river edges from the network to continental vertices in seeded order, avoiding a third
  // river into one vertex where another edge will do.
  void grow_rivers() {
    const std::size_t nv = h_.vertices.size();
    down_.assign(nv, -1);
    inflow_.assign(nv, 0);
    in_network_.assign(nv, false);
    mouth_.assign(nv, false);
    uplift_.assign(nv, 0.0);
    path_lift_.assign(nv, 0.0);
    profile_.assign(nv, 0.0);
    if (def_.relief_model == ReliefModel::drainage) {
      for (std::uint32_t v = 0; v < nv; ++v) uplift_[v] = mesh_.rules.region(vertex(v).p).uplift;
      // A headwater drains one vertex's share of the sphere (assign_altitudes).
      const double share =
          kFourPi * mesh_.rules.radius * mesh_.rules.radius / static_cast<double>(nv);
      headwater_slope_ =
          def_.min_river_slope *
          std::min(1.0, std::pow(share / def_.river_slope_area, -def_.river_concavity));
    }
    std::vector<std::uint32_t> order(nv);
    for (std::uint32_t v = 0; v < nv; ++v) order[v] = v;
    for (std::size_t i = nv; i > 1; --i) {
      std::swap(order[i - 1], order[random_.below(static_cast<std::uint32_t>(i))]);
    }
    for (int pass = 0; pass < 2; ++pass) {
      for (std::uint32_t v : order) {
        if (kind_[v] != kLand || in_network_[v]) continue;
        for (auto [u, e] : neighbours_[v]) {
          if (kind_[u] != kCoast || (pass == 0 && mouth_[u])) continue;
          // Keep mouths apart along the coast on the first pass: one river per stretch.
          bool crowded = false;
          for (auto [w, e2] : neighbours_[u]) crowded = crowded || (pass == 0 && mouth_[w]);
          if (crowded) continue;
          mouth_[u] = true;
          link(v, u, e);
          break;
        }
      }
      while (!candidates_.empty()) {
        const std::size_t j = pick_candidate();
        auto [r, v] = candidates_[j];
        candidates_[j] = candidates_.back();
        candidates_.pop_back();
        if (in_network_[v]) continue;
        std::uint32_t target = r;
        if (inflow_[r] >= 2) {
          for (auto [x, e] : neighbours_[v]) {
            if (kind_[x] == kLand && in_network_[x] && inflow_[x] < 2) {
              target = x;
              break;
            }
          }
        }
        std::uint32_t edge = 0;
        for (auto [x, e] : neighbours_[v]) {
          if (x == target) edge = e;
        }
        if (def_.relief_model == ReliefModel::drainage) {
          // A river that reached v the long way round would stand above the land beside the
          // coast, which hangs from the coast (refine.cpp), on a wall: v drains to the coast.
          const double through_target = level_through(target, v);
          for (auto [u, e] : neighbours_[v]) {
            if (kind_[u] == kCoast && through_target - level_through(u, v) > kPerchedRiver) {
              target = u, edge = e;
              mouth_[u] = true;
              break;
            }
          }
        }
        link(v, target, edge);
      }
    }
  }

  void assign_altitudes() {
    const std::size_t nv = h_.vertices.size();
    const double radius = mesh_.rules.radius;
    // Mouths first, then upstream in breadth-first order (children by vertex index).
    std::vector<std::vector<std::uint32_t>> upstream(nv);
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (down_[v] >= 0) upstream[static_cast<std::size_t>(down_[v])].push_back(v);
    }
    std::vector<std::uint32_t> bfs;
    std::vector<double> distance(nv, 0.0), longest(nv, 0.0);
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (down_[v] < 0 && in_network_[v]) bfs.push_back(v);
    }
    for (std::size_t i = 0; i < bfs.size(); ++i) {
      const std::uint32_t u = bfs[i];
      for (std::uint32_t v : upstream[u]) {
        distance[v] = distance[u] + radius * angle(vertex(u).p, vertex(v).p);
        bfs.push_back(v);
      }
    }
    // Drainage areas: each vertex drains its share of the sphere (the base level's vertices
    // are spread evenly) and everything upstream.
    const double share = kFourPi * radius * radius / static_cast<double>(nv);
    std::vector<double> area(nv, 0.0);
    // Flint's law shares the rise out: each edge's part of the way up to the farthest spring
    // upstream weighs its length times A^−θ (θ = river_concavity), so edges that drain more rise
    // less. `weighted[v]` sums that weight from v's edge up to that spring; the donor with the
    // longest way up (the first in visit order on a tie) passes its sum down.
    const double theta = def_.river_concavity;
    const auto flint_weight = [&](double drainage) { return std::pow(drainage, -theta); };
    std::vector<double> weighted(nv, 0.0), weighted_above(nv, 0.0);
    for (std::size_t i = bfs.size(); i-- > 0;) {
      const std::uint32_t v = bfs[i];
      longest[v] = std::max(longest[v], distance[v]);
      area[v] += share;
      if (down_[v] >= 0) {
        const auto u = static_cast<std::size_t>(down_[v]);
        weighted[v] = (distance[v] - distance[u]) * flint_weight(area[v]) + weighted_above[v];
        if (longest[v] > longest[u]) weighted_above[u] = weighted[v];
        longest[u] = std::max(longest[u], longest[v]);
        area[u] += area[v];
      }
    }
    double largest = 0.0;
    for (std::uint32_t v : bfs) largest = std::max(largest, area[v]);
    mesh_.stats.largest_drainage_area = largest;
    // Hydraulic geometry (Leopold and Maddock): depth ∝ Q^0.4 with the discharge Q ∝ drainage
    // area, river_depth at the largest river's mouth; a spring is dry (water = ground).
    const auto depth_for = [&](std::uint32_t v) {
      if (upstream[v].empty()) return 0.0;
      return def_.river_depth * std::pow(area[v] / largest, 0.4);
    };
    const double sea = def_.sea_level;
    const double top = sea + def_.max_river_altitude;
    // A spring's target altitude grows with its river's length (§4.2), reaching a_max_river
    // for a river a quarter meridian long.
    const double full_length = radius * std::numbers::pi / 2.0;
    std::vector<double> least_profile(nv, 0.0);
    for (std::uint32_t v : bfs) {
      Vertex& x = vertex(v);
      if (down_[v] < 0) {  // a mouth (a coast vertex), or an endorheic sink
        x.water = sea;
        x.ground = kind_[v] == kCoast ? sea - std::max(depth_for(v), 1.0) : sea;
        if (kind_[v] != kCoast) ++mesh_.stats.endorheic;
        ++mesh_.stats.mouths;
        continue;
      }
      const auto u = static_cast<std::uint32_t>(down_[v]);
      const Vertex& y = vertex(u);
      const double le = distance[v] - distance[u];
      const double target = sea + def_.max_river_altitude * std::min(1.0, longest[v] / full_length);
      // Eq. 3/4: rise by this edge's share of what is left up to the spring (by length, or by
      // Flint's weights) times a random factor, at least the least river slope, and never above
      // a_max_river. The least slope falls below s_r where the river drains more than
      // river_slope_area.
      // weighted[v] holds this edge's own weight, so it is positive and the share at most 1.
      const double share_here = le * flint_weight(area[v]) / weighted[v];
      const double least =
          def_.min_river_slope * std::min(1.0, std::pow(area[v] / def_.river_slope_area, -theta));
      if (def_.relief_model == ReliefModel::drainage) {
        // The drainage relief model hangs its land a few hundred metres at most above the
        // lowest of its neighbours, so its rivers climb at their least slope, not towards a far
        // spring: such a river would stand on a wall above land that hangs from a lower river
        // nearby (planet.md "Relief models"). Only the belts and plateaus lift them: a river
        // stands the highest lift on its way from the sea (link) above its least-slope profile,
        // so it climbs where the uplift grows upstream and keeps a crest's level behind it.
        least_profile[v] = least_profile[u] + le * least;
        x.water =
            std::max(std::min(sea + least_profile[v] + path_lift_[v], top), y.water + le * least);
      } else {
        const double towards_spring =
            2.0 * random_.uniform() * (target - y.water) * share_here / le;
        x.water = std::max(std::min(y.water + le * std::max(least, towards_spring), top),
                           y.water + le * least);
      }
      x.ground = x.water - depth_for(v);
      mesh_.stats.longest_river = std::max(mesh_.stats.longest_river, longest[v]);
    }
    // Tangents (downstream), flags and detail weights.
    for (std::uint32_t v = 0; v < nv; ++v) {
      Vertex& x = vertex(v);
      x.detail = 0.0f;
      if (kind_[v] == kSea) continue;
      if (!in_network_[v] && kind_[v] == kLand) {  // no way to the sea: an endorheic basin
        x.flags = kLand | kRiver;
        x.ground = x.water = sea + def_.riverbed_edge_height;
        ++mesh_.stats.endorheic;
        continue;
      }
      if (!in_network_[v]) {  // a coast vertex without a river
        x.flags = kCoast;
        x.ground = x.water = sea;
        continue;
      }
      x.flags =
          static_cast<std::uint8_t>(kind_[v] == kCoast ? (kCoast | kRiver) : (kLand | kRiver));
      x.drainage_area = static_cast<float>(area[v]);
      if (kind_[v] == kLand) ++mesh_.stats.river_vertices;
      Vec3d direction{0, 0, 0};
      if (down_[v] >= 0) {
        direction = unit_or_zero(sub(vertex(static_cast<std::uint32_t>(down_[v])).p, x.p));
      }
      std::int32_t main = -1;
      for (std::uint32_t w : upstream[v]) {
        if (main < 0 || longest[w] > longest[static_cast<std::size_t>(main)]) {
          main = static_cast<std::int32_t>(w);
        }
      }
      if (main >= 0) {
        direction =
            add(direction, unit_or_zero(sub(x.p, vertex(static_cast<std::uint32_t>(main)).p)));
      }
      x.tangent = tangent_towards(x.p, direction);
    }
    // Sea floor: deeper with the distance from the coast (along sea edges).
    const std::vector<double> offshore = distances_over(
        [&](std::uint32_t v) { return kind_[v] != kSea; }, [](std::uint32_t) { return true; });
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (kind_[v] != kSea) continue;
      Vertex& x = vertex(v);
      const double d = offshore[v] * radius;
      x.drainage_area = static_cast<float>(d);  // the distance to the coast (refine.cpp: shelves)
      const double depth = 150.0 + (def_.sea_depth - 150.0) * (1.0 - std::exp(-d / 4.0e5)) *
                                       (0.75 + 0.25 * random_.uniform());
      x.flags = kSea;
      x.water = sea;
      x.ground = sea - std::min(depth, def_.sea_depth);
    }
    // Land: the distance from the coast along land edges (coastal plains follow it).
    const std::vector<double> inland =
        distances_over([&](std::uint32_t v) { return kind_[v] == kCoast; },
                       [&](std::uint32_t v) { return kind_[v] != kSea; });
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (kind_[v] == kSea) continue;
      vertex(v).coast_hm =  // infinite where no coast is reachable
          static_cast<std::uint16_t>(std::min(65535.0, std::round(inland[v] * radius / 100.0)));
    }
    mesh_.downstream = down_;
  }

  // Shortest great-circle paths (radians) along the level's edges from the vertices `from`
  // accepts, through those `through` accepts (Dijkstra; ties by vertex index, so the same bits
  // every run). The level's edges vary in length by more than a factor of two (long ones meet
  // at the octahedron's vertices), so hop counts would not do.
  template <class From, class Through>
  std::vector<double> distances_over(From from, Through through) {
    const std::size_t nv = kind_.size();
    std::vector<double> distance(nv, std::numeric_limits<double>::infinity());
    using Entry = std::pair<double, std::uint32_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (from(v)) distance[v] = 0.0, open.push({0.0, v});
    }
    while (!open.empty()) {
      const auto [d, v] = open.top();
      open.pop();
      if (d > distance[v]) continue;
      for (auto [w, e] : neighbours_[v]) {
        const double through_v = d + angle(vertex(v).p, vertex(w).p);
        if (through(w) && through_v < distance[w])
          distance[w] = through_v, open.push({through_v, w});
      }
    }
    return distance;
  }

  BaseMesh& mesh_;
  Hierarchy& h_;
  const PlanetDefinition& def_;
  const std::vector<std::int32_t>& faces_;
  const ContinentMap* map_;
  Random random_;
  std::vector<std::int32_t> face_of_;
  std::vector<std::vector<std::int32_t>> incident_;
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> neighbours_;  // (vertex, edge)
  std::vector<Edge> edges_;
  std::vector<double> area_;
  std::vector<bool> sea_only_;  ///< beside a cone point (kConePointSea)
  std::vector<int> owner_;
  std::vector<bool> land_;
  double land_area_ = 0.0;
  std::vector<std::vector<std::int32_t>> frontier_;
  std::vector<double> weight_;
  std::vector<std::uint8_t> kind_;
  std::vector<std::int32_t> down_;
  std::vector<int> inflow_;
  std::vector<bool> in_network_, mouth_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> candidates_;
  // The drainage model's: the belts' and plateaus' uplift at each vertex; the highest lift on a
  // network vertex's way from the sea and its profile at the headwaters' least slope.
  std::vector<double> uplift_, path_lift_, profile_;
  double headwater_slope_ = 0.0;
};

}  // namespace

std::unique_ptr<BaseMesh> build_base_mesh(const PlanetDefinition& definition,
                                          const BuildOptions& options, const ContinentMap* map) {
  auto mesh = std::make_unique<BaseMesh>(definition);
  Hierarchy& h = mesh->hierarchy;
  h.make_octahedron(definition.seed);
  std::vector<std::int32_t> level_tris;
  for (std::int32_t t = 0; t < 8; ++t) level_tris.push_back(t);
  const int threads = std::max(1, options.threads);
  for (int level = 0; level < mesh->rules.mesh_level; ++level) {
    // The neighbours' parents are all split: this only links partners.
    for (std::int32_t t : level_tris) h.ensure_partner(t);
    if (level == mesh->rules.base_level) {
      mesh->river_faces = level_tris;
      Classifier(*mesh, level_tris, map).run();
    }
    std::vector<std::int32_t> diamonds;
    for (std::int32_t t : level_tris) {
      if (h.tris[static_cast<std::size_t>(t)].nb[0] > t) diamonds.push_back(t);
    }
    // Each split is a pure function of its diamond: compute them in parallel, link in order.
    std::vector<SplitResult> splits(diamonds.size());
    auto work = [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) splits[i] = h.compute_split(diamonds[i]);
    };
    if (threads == 1 || diamonds.size() < 256) {
      work(0, diamonds.size());
    } else {
      std::vector<std::thread> pool;
      const std::size_t chunk = (diamonds.size() + static_cast<std::size_t>(threads) - 1) /
                                static_cast<std::size_t>(threads);
      for (std::size_t begin = 0; begin < diamonds.size(); begin += chunk) {
        pool.emplace_back(work, begin, std::min(diamonds.size(), begin + chunk));
      }
      for (std::thread& t : pool) t.join();
    }
    for (std::size_t i = 0; i < diamonds.size(); ++i) h.apply_split(diamonds[i], splits[i]);
    std::vector<std::int32_t> next;
    next.reserve(level_tris.size() * 2);
    for (std::int32_t t : level_tris) {
      next.push_back(h.tris[static_cast<std::size_t>(t)].child[0]);
      next.push_back(h.tris[static_cast<std::size_t>(t)].child[1]);
    }
    level_tris = std::move(next);
  }
  for (std::int32_t t : level_tris) h.ensure_partner(t);
  mesh->leaves = std::move(level_tris);
  place_lakes(*mesh);
  mesh->stats.river_faces = static_cast<int>(mesh->river_faces.size());
  mesh->stats.mesh_faces = static_cast<int>(mesh->leaves.size());
  return mesh;
}

std::string BaseMesh::hash() const {
  std::string bytes;  // every field in a fixed order, hashed at once
  auto feed = [&](const void* data, std::size_t size) {
    bytes.append(static_cast<const char*>(data), size);
  };
  for (const Vertex& v : hierarchy.vertices) {
    feed(v.p.data(), sizeof(double) * 3);
    feed(&v.seed, sizeof v.seed);
    feed(&v.ground, sizeof v.ground);
    feed(&v.water, sizeof v.water);
    feed(v.tangent.data(), sizeof(float) * 3);
    feed(&v.flags, 1);
    feed(&v.coast_hm, sizeof v.coast_hm);
    feed(&v.detail, sizeof v.detail);
    feed(&v.drainage_area, sizeof v.drainage_area);
  }
  for (const Tri& t : hierarchy.tris) {
    feed(t.v.data(), sizeof(std::uint32_t) * 3);
    feed(t.nb.data(), sizeof(std::int32_t) * 3);
    feed(t.child.data(), sizeof(std::int32_t) * 2);
    feed(t.edge.data(), 3);
    feed(&t.face, 1);
  }
  return terrain::sha256_hex(bytes);
}

}  // namespace planet
