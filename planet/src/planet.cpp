#include "planet/planet.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>

#include "detail_batch.hpp"
#include "drain_floors.hpp"
#include "gradient_noise.hpp"
#include "planet/smooth_surface.hpp"
#include "warp.hpp"

namespace planet {

std::string_view surface_name(SurfaceType type) {
  switch (type) {
    case SurfaceType::sea:
      return "sea";
    case SurfaceType::coast:
      return "coast";
    case SurfaceType::land:
      return "land";
    case SurfaceType::river:
      return "river";
    case SurfaceType::lake:
      return "lake";
  }
  return "land";
}

Planet::Planet(const PlanetDefinition& definition, const BuildOptions& options,
               const ContinentMap* map)
    : base_(build_base_mesh(definition, options, map)),
      geodesy_(definition.radius, definition.flattening),
      id_(planet_id(definition)) {
  const PlanetDefinition& d = definition;
  detail_gain_ = std::pow(d.detail.lacunarity, -d.detail.hurst);
  detail_seed_ = static_cast<std::uint32_t>(mix64(d.seed ^ 0x64657461696cULL));
  // The mesh displaces its vertices with the same spectrum down to finest_edge; the noise only
  // carries it further, so it starts at the first octave shorter than that edge.
  first_detail_amplitude_ = d.detail.amplitude;
  first_detail_frequency_ = d.radius / d.detail.wavelength;
  for (double wavelength = d.detail.wavelength;
       wavelength >= d.finest_edge && first_detail_octave_ < detail::kMaxOctaves;
       wavelength /= d.detail.lacunarity) {
    ++first_detail_octave_;
    first_detail_amplitude_ *= detail_gain_;
    first_detail_frequency_ *= d.detail.lacunarity;
  }
  // Every octave's amplitude summed, or the noise's own octaves at the largest ruggedness (the
  // detail's weight) if that is more: by default the first, since the noise carries only the
  // octaves shorter than finest_edge, about a tenth of a metre. Summed up to the last octave
  // any sum takes, not as a geometric series: a Hurst exponent as small as the definition
  // accepts (5e-324) makes the gain 1, and the series' 1 / (1 − gain) infinite.
  double every_octave = 0.0, noise_octaves = 0.0, amplitude = d.detail.amplitude;
  for (int k = 0; k < detail::kMaxOctaves; ++k, amplitude *= detail_gain_) {
    every_octave += amplitude;
    if (k >= first_detail_octave_) noise_octaves += amplitude;
  }
  const double detail_max = std::max(every_octave, base_->rules.max_ruggedness() * noise_octaves);
  elevation_range_ = {
      static_cast<float>(std::floor(d.sea_level - d.sea_depth)),
      static_cast<float>(std::ceil(d.sea_level + d.max_mountain_altitude + detail_max))};
  const std::uint32_t warp_seed = static_cast<std::uint32_t>(mix64(d.seed ^ 0x77617270ULL));
  for (int level = 0; level <= base_->rules.max_level; ++level) {
    warp_by_level_.push_back(detail::warp_octaves(
        d.warp, d.warp_wavelength, base_->rules.edge_length(level), d.radius, warp_seed));
  }
}

Planet::~Planet() = default;

const detail::WarpOctaves& Planet::warp_octaves(int level) const {
  assert(level >= 0 && static_cast<std::size_t>(level) < warp_by_level_.size());
  return warp_by_level_[static_cast<std::size_t>(level)];
}

bool Planet::warps(int level) const {
  return warp_octaves(level).count > 0;
}

Vec3d Planet::warp(const Vec3d& direction, int level) const {
  return detail::warped(warp_octaves(level), direction);
}

std::shared_ptr<const Planet> Planet::create(const PlanetDefinition& definition,
                                             const BuildOptions& options) {
  Result<std::shared_ptr<const Planet>> planet = build(definition, nullptr, options);
  return planet ? std::move(planet).value() : nullptr;
}

Result<std::shared_ptr<const Planet>> Planet::build(const PlanetDefinition& definition,
                                                    const ContinentMap* map,
                                                    const BuildOptions& options) {
  // The id hashes the definition, map reference included: a planet built from other pixels than
  // the ones its definition names would serve different tiles under the same immutable URLs.
  if (map == nullptr && !definition.continent_map.empty()) {
    return Error{"names continent map " + definition.continent_map +
                     "; its decoded pixels are needed to build the planet",
                 "/continent_map"};
  }
  if (map != nullptr) {
    if (definition.continent_map.empty()) {
      return Error{
          "a continent map was given but the definition names none (set it to the "
          "map's hash)",
          "/continent_map"};
    }
    if (!map->hash.empty() && map->hash != definition.continent_map) {
      return Error{"the continent map given is " + map->hash + ", the definition names " +
                       definition.continent_map,
                   "/continent_map"};
    }
    if (terrain::Status ok = map->validate(); !ok) return ok.error();
  }
  return std::shared_ptr<const Planet>(new Planet(definition, options, map));
}

Result<std::shared_ptr<const Planet>> Planet::from_json(const nlohmann::json& document) {
  Result<PlanetDefinition> definition = parse_planet(document);
  if (!definition) return definition.error();
  return build(*definition, nullptr);
}

int Planet::level_for_spacing(double spacing) const {
  const Rules& r = rules();
  int level = r.mesh_level;
  while (level < r.max_level && r.edge_length(level) > 2.0 * spacing) ++level;
  return level;
}

double Planet::octaves_for_spacing(double spacing) const {
  const DetailParams& d = definition().detail;
  // Octave k has wavelength λ/r^k; it is visible while that is at least two samples.
  const double n =
      std::log(d.wavelength / (2.0 * std::max(spacing, 1e-6))) / std::log(d.lacunarity);
  return std::clamp(n + 1.0, 0.0, static_cast<double>(detail::kMaxOctaves));
}

double Planet::ground_spacing(int z, int cells) const {
  return std::numbers::pi * definition().radius / (std::ldexp(1.0, z) * cells);
}

double Planet::relief_between_samples(double spacing) const {
  const Rules& r = rules();
  const double edge = r.edge_length(level_for_spacing(spacing));
  return r.roughness(edge) + r.drain_rise(edge) + r.shelf_break_relief(edge);
}

terrain::Interval Planet::elevation_range() const {
  return elevation_range_;
}

detail::DetailOctaves Planet::detail_octaves(double octaves) const {
  detail::DetailOctaves plan;
  plan.first = first_detail_octave_;
  plan.octaves = octaves;
  plan.amplitude = first_detail_amplitude_;
  plan.frequency = first_detail_frequency_;
  plan.gain = detail_gain_;
  plan.lacunarity = definition().detail.lacunarity;
  plan.seed = detail_seed_;
  return plan;
}

bool Planet::has_detail_octaves(double octaves) const {
  return detail_octaves(octaves).covers(first_detail_octave_);
}

double Planet::detail(const Vec3d& p, double octaves) const {
  return detail::detail_sum(detail_octaves(octaves), p);
}

void Planet::detail(std::span<const Vec3d> directions, double octaves,
                    std::span<double> out) const {
  assert(out.size() >= directions.size());
  detail::detail_sums(detail_octaves(octaves), directions.data(), directions.size(), out.data());
}

Sampler::Sampler(std::shared_ptr<const Planet> planet, std::size_t trim_bound)
    : planet_(std::move(planet)),
      hierarchy_(planet_->base_mesh().hierarchy.rules()),
      trim_bound_(trim_bound) {
  trim();
}

void Sampler::trim() {
  // Room for a tile's refinement (about 45 000 triangles and 11 000 vertices at zoom 10) beyond
  // the base mesh, so the first tiles do not copy the hierarchy as it grows; the pages are only
  // touched as triangles are made. A trim keeps what the vectors have grown to: their pages stay
  // mapped, and the tiles after it neither copy the hierarchy nor fault fresh pages in (a tenth
  // of a tile's time while panning). trim_when_large bounds that memory either way.
  const Hierarchy& base = planet_->base_mesh().hierarchy;
  hierarchy_.tris.reserve(base.tris.size() + (std::size_t{1} << 17));
  hierarchy_.vertices.reserve(base.vertices.size() + (std::size_t{1} << 15));
  hierarchy_.tris.assign(base.tris.begin(), base.tris.end());
  hierarchy_.vertices.assign(base.vertices.begin(), base.vertices.end());
  ++generation_;
}

void Sampler::trim_when_large() {
  // Bounded memory for long-lived samplers: start again from the base mesh now and then. 2²⁰
  // triangles and their vertices are about 65 MB; a lone sample at full detail anywhere adds
  // about 450, so the sample route's samplers (one per planet and thread) trim every two
  // thousand random samples or so, after which a sample splits its few dozen levels again.
  // At 2²³ they grew to about 520 MB each. A tile's sampler keeps less (PlanetTiles).
  if (hierarchy_.tris.size() > trim_bound_) trim();
}

PointSample Sampler::sample(double latitude, double longitude) {
  return sample(latitude, longitude, 0.01);
}

PointSample Sampler::sample(double latitude, double longitude, double spacing) {
  if (longitude >= 180.0) longitude -= 360.0;  // one direction for the antimeridian
  const Vec3d p = planet_->geodesy().direction(std::clamp(latitude, -90.0, 90.0), longitude);
  return at(p, planet_->level_for_spacing(spacing), planet_->octaves_for_spacing(spacing));
}

PointSample Sampler::at(const Vec3d& p, int level, double octaves) {
  return at(p, level, octaves, DescentStart{});
}

PointSample Sampler::at(const Vec3d& p, int level, double octaves, const DescentStart& start) {
  trim_when_large();  // before the start is checked: a trim makes it stale
  const Vec3d q = planet_->warp(p, level);
  return evaluate(descend(q, level, start), q, level, octaves);
}

double Sampler::land_ground(std::int32_t t, const std::array<const Vertex*, 3>& corner,
                            const std::array<double, 3>& w) {
  LeafSurface& leaf = leaf_surfaces_[static_cast<std::size_t>(t) % kLeafSurfaces];  // t ≥ 0
  if (leaf.tri != t || leaf.generation != generation_) {
    const double radius = planet_->definition().radius;
    if (all_dry(corner)) {
      leaf.cubic.emplace(corner, radius);
      leaf.floor.reset();
    } else {
      leaf.floor.emplace(corner, radius);
    }
    leaf.tri = t;
    leaf.generation = generation_;
  }
  return leaf.floor ? (*leaf.floor)(w) : (*leaf.cubic)(w);
}

PointSample Sampler::at_from_root(const Vec3d& p, int level, double octaves) {
  trim_when_large();
  const Vec3d q = planet_->warp(p, level);
  return evaluate(hierarchy_.locate(q, level), q, level, octaves);
}

DescentStart Sampler::start_at(std::int32_t t) const {
  const Tri& tri = hierarchy_.tris[static_cast<std::size_t>(t)];
  DescentStart start;
  start.tri = t;
  start.generation = generation_;
  start.level = tri.level;
  for (std::size_t k = 0; k < 3; ++k) {
    start.normal[k] =
        cross(hierarchy_.vertices[tri.v[k]].p, hierarchy_.vertices[tri.v[(k + 1) % 3]].p);
  }
  return start;
}

std::int32_t Sampler::descend(const Vec3d& p, int level, const DescentStart& start) {
  const bool current = path_level_ == level && !path_.empty() && leaf_.generation == generation_;
  if (current) {
    // Walk from the last leaf across the edges p lies beyond: a level is a triangulation, so a
    // triangle of it that holds p by the margin is the leaf p's descent ends in.
    DescentStart at = leaf_;
    for (int step = 0; step <= kWalkSteps; ++step) {
      if (at.holds(p)) return settle(at, p, level);
      if (step == kWalkSteps) break;
      std::size_t beyond = 0;
      for (std::size_t k = 1; k < 3; ++k) {
        if (dot(at.normal[k], p) < dot(at.normal[beyond], p)) beyond = k;
      }
      if (beyond == 0) hierarchy_.ensure_partner(at.tri);
      at = start_at(hierarchy_.tris[static_cast<std::size_t>(at.tri)].nb[beyond]);
    }
  }
  // Else descend from the deepest triangle of the last descent that holds p.
  std::size_t keep = 0;
  if (current) {
    for (std::size_t k = path_.size(); k-- > 0;) {
      if (path_[k].holds(p)) {
        keep = k + 1;
        break;
      }
    }
  }
  if (keep > 0) {
    path_.resize(keep);
  } else {
    path_.clear();
    path_level_ = level;
    const bool usable = start.generation == generation_ && start.level <= level && start.holds(p);
    path_.push_back(usable ? start : start_at(hierarchy_.root_face(p)));
  }
  return descend_path(p, level);
}

std::int32_t Sampler::descend_path(const Vec3d& p, int level) {
  std::int32_t t = path_.back().tri;
  while (hierarchy_.tris[static_cast<std::size_t>(t)].level < level && !hierarchy_.open_sea(t)) {
    hierarchy_.ensure_split(t);
    t = hierarchy_.locate_child(t, p);
    path_.push_back(start_at(t));
  }
  leaf_ = path_.back();
  return t;
}

std::int32_t Sampler::settle(const DescentStart& at, const Vec3d& p, int level) {
  // Open sea stops a descent at its first open-sea triangle, so the walk's triangle is the leaf
  // only where it is that one, or where it is of the level asked for and not open sea. Each
  // level is a triangulation, so p's descent passes through it either way.
  const std::int32_t stop = hierarchy_.open_sea_stop(at.tri);
  const int at_level = hierarchy_.tris[static_cast<std::size_t>(at.tri)].level;
  if (stop == at.tri || (stop < 0 && at_level >= level)) {
    leaf_ = at;
    return at.tri;
  }
  path_.assign(1, stop >= 0 ? start_at(stop) : at);
  return descend_path(p, level);
}

DescentStart Sampler::descent_start(const Vec3d& centre, std::span<const Vec3d> points, int level) {
  trim_when_large();
  return find_descent_start(centre, points, level);
}

DescentStart Sampler::find_descent_start(const Vec3d& centre, std::span<const Vec3d> points,
                                         int level) {
  std::vector<std::int32_t> path{hierarchy_.root_face(centre)};
  while (hierarchy_.tris[static_cast<std::size_t>(path.back())].level < level &&
         !hierarchy_.open_sea(path.back())) {
    hierarchy_.ensure_split(path.back());
    path.push_back(hierarchy_.locate_child(path.back(), centre));
  }
  for (auto it = path.rbegin(); it != path.rend(); ++it) {
    const DescentStart start = start_at(*it);
    if (start.holds(centre) &&
        std::all_of(points.begin(), points.end(), [&](const Vec3d& p) { return start.holds(p); })) {
      return start;
    }
  }
  return {};
}

PointSample Sampler::evaluate(std::int32_t t, const Vec3d& p, int level, double octaves) {
  const Undetailed sample = undetailed(t, p, level);
  if (sample.weight > 0.0 && octaves > 0.0) return finish(sample, planet_->detail(p, octaves));
  return finish(sample, std::nullopt);
}

void Sampler::at(std::span<const Vec3d> given, int level, double octaves, const DescentStart& start,
                 std::span<PointSample> out) {
  assert(out.size() >= given.size());
  // Where the level is warped, every direction at once (the same bits as one by one).
  std::span<const Vec3d> directions = given;
  if (planet_->warps(level)) {
    warped_.resize(given.size());
    warp_scratch_.resize(3 * given.size());
    detail::warped(planet_->warp_octaves(level), given.data(), given.size(), warped_.data(),
                   warp_scratch_.data());
    directions = warped_;
  }
  if (!planet_->has_detail_octaves(octaves)) {  // nothing to batch: the noise sums no octave
    for (std::size_t i = 0; i < directions.size(); ++i) {
      trim_when_large();
      out[i] = evaluate(descend(directions[i], level, start), directions[i], level, octaves);
    }
    return;
  }
  pending_.clear();
  detailed_.clear();
  for (const Vec3d& p : directions) {
    trim_when_large();
    pending_.push_back(undetailed(descend(p, level, start), p, level));
    if (pending_.back().weight > 0.0 && octaves > 0.0) detailed_.push_back(p);
  }
  detail_.resize(detailed_.size());
  planet_->detail(detailed_, octaves, detail_);
  std::size_t next = 0;
  for (std::size_t i = 0; i < directions.size(); ++i) {
    const Undetailed& sample = pending_[i];
    out[i] = sample.weight > 0.0 && octaves > 0.0 ? finish(sample, detail_[next++])
                                                  : finish(sample, std::nullopt);
  }
}

PointSample Sampler::finish(const Undetailed& sample, std::optional<double> detail) const {
  PointSample out = sample.out;
  if (detail) out.ground += sample.weight * *detail;
  const terrain::Interval range = planet_->elevation_range();
  out.ground = std::clamp(out.ground, static_cast<double>(range.lo), static_cast<double>(range.hi));
  // A sea or lake face at exactly its water level is still water; on land only water above the
  // ground counts.
  const bool open_water = sample.face != FaceType::land;
  // On land, water stands only in a river's channel (half as wide as the river is deep over the
  // riverbed slope, §5.3's s_rb): three river vertices around a triangle that no split has yet
  // separated by a ridge do not make a lake.
  const bool submerged = open_water
                             ? sample.water >= out.ground
                             : sample.water > out.ground && out.river_distance <= sample.channel;
  if (submerged) {
    out.water = sample.water;
    out.type = sample.face == FaceType::sea    ? SurfaceType::sea
               : sample.face == FaceType::lake ? SurfaceType::lake
                                               : SurfaceType::river;
  } else {
    out.water = out.ground;
    out.type = sample.coast ? SurfaceType::coast : SurfaceType::land;
  }
  return out;
}

Sampler::Undetailed Sampler::undetailed(std::int32_t t, const Vec3d& p, int level,
                                        bool with_floors) {
  const Tri& tri = hierarchy_.tris[static_cast<std::size_t>(t)];
  const Vertex& x = hierarchy_.vertices[tri.v[0]];
  const Vertex& y = hierarchy_.vertices[tri.v[1]];
  const Vertex& z = hierarchy_.vertices[tri.v[2]];
  const std::array<double, 3> w = barycentric(x.p, y.p, z.p, p);
  PointSample out;
  out.level = level;
  out.river_distance = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < 3; ++k) {
    if (tri.edge[k] != EdgeType::river) continue;
    const Vec3d& u = hierarchy_.vertices[tri.v[k]].p;
    const Vec3d& v = hierarchy_.vertices[tri.v[(k + 1) % 3]].p;
    // Distance to the great-circle arc u–v: to its circle where p projects inside the arc,
    // else to the nearer end.
    const Vec3d n = normalize(cross(u, v));
    const Vec3d q = sub(p, scale(n, dot(p, n)));
    const bool inside = dot(cross(u, q), n) >= 0 && dot(cross(q, v), n) >= 0;
    const double arc =
        inside ? std::asin(std::min(1.0, std::abs(dot(p, n)))) : std::min(angle(p, u), angle(p, v));
    const double metres = arc * planet_->definition().radius;
    if (metres < out.river_distance) {
      out.river_distance = metres;
      // The edge drains what its upstream end does.
      out.river_drainage_area = std::min(hierarchy_.vertices[tri.v[k]].drainage_area,
                                         hierarchy_.vertices[tri.v[(k + 1) % 3]].drainage_area);
    }
  }
  if (tri.face != FaceType::land) {  // under the sea or a lake
    out.ground = w[0] * x.ground + w[1] * y.ground + w[2] * z.ground;
  } else {
    out.ground = land_ground(t, {&x, &y, &z}, w);
  }
  // River corners count as river features too: a channel around a vertex reaches into the
  // triangles that touch the river only there.
  double channel = 0.0;
  for (const Vertex* v : {&x, &y, &z}) {
    if ((v->flags & kRiver) == 0 || !(v->water > v->ground)) continue;
    const double metres = angle(p, v->p) * planet_->definition().radius;
    if (metres <= out.river_distance) {  // at a vertex, it drains more than its upstream edges
      out.river_distance = metres;
      out.river_drainage_area = v->drainage_area;
    }
    channel = std::max(channel, (v->water - v->ground) / planet_->definition().min_riverbed_slope);
  }
  Undetailed sample;
  sample.out = out;
  sample.water = w[0] * x.water + w[1] * y.water + w[2] * z.water;
  sample.weight = w[0] * x.detail + w[1] * y.detail + w[2] * z.detail;
  sample.channel = channel;
  sample.face = tri.face;
  sample.coast = ((x.flags | y.flags | z.flags) & kCoast) != 0;
  // Last: the walk may split triangles, which moves tri, x, y and z.
  if (with_floors && sample.face == FaceType::land && drainage_floors()) {
    sample.out.ground = floors::floor_by_walk(hierarchy_, t, p, sample.out.ground,
                                              floors::floor_shape(planet_->rules(), level), walk_);
  }
  return sample;
}

nlohmann::json sample_json(double latitude, double longitude, const PointSample& s) {
  return {{"latitude", latitude}, {"longitude", longitude},       {"ground", s.ground},
          {"water", s.water},     {"type", surface_name(s.type)}, {"level", s.level}};
}

}  // namespace planet
