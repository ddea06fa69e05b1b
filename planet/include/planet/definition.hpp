// A planet definition: a seed plus the parameters of Derzapf et al. 2011 (Table 2), parsed from
// JSON with errors that name the offending field, serialised canonically (every field explicit,
// keys sorted, shortest round-trip numbers) and identified by the SHA-256 of that text.
//
// Units: metres for lengths and altitudes, dimensionless slopes (metres per metre: Table 2's
// "1 m/km" is 0.001). Altitudes are relative to the planet's reference surface (the sphere of
// `radius`, or the ellipsoid when `flattening` > 0); Table 2's 3 km sea level datum is shifted
// to 0 so that tiles carry heights above sea level.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "terrain/material.hpp"
#include "terrain/result.hpp"

namespace planet {

using terrain::Error;
using terrain::Result;

/// Schneider's rescale-and-add fractal added below the mesh's resolution (planet.md "Detail").
struct DetailParams {
  double amplitude = 350.0;     ///< metres at the first octave
  double wavelength = 60000.0;  ///< metres, the first octave's wavelength
  double hurst = 0.9;           ///< H: octave k has amplitude·lacunarity^(−kH)
  double lacunarity = 2.2;      ///< r: octave k has wavelength / r^k
};

/// How dry land between the base mesh's rivers is made (planet.md "Relief models").
/// `displacement`: midpoint displacement of the smooth surface, raised to drain along one edge
/// (Derzapf et al.'s eq. 5, 11 and 12 with the drain rise). `drainage`: every dry vertex hangs
/// from the corner it drains to by a rise that steepens towards the headwaters, and the ground
/// is lowered along the drains of the level sampled, so that every level is a drainage network
/// whose slopes follow Flint's law down to kilometre-scale valleys.
enum class ReliefModel { displacement, drainage };
std::string_view relief_model_name(ReliefModel model);

/// The most lakes a definition may ask for (each is placed once when the planet is built).
inline constexpr int kMaxLakes = 1000;

struct PlanetDefinition {
  std::uint64_t seed = 1;
  double radius = 6371000.0;             ///< r (Table 2: 6371 km); the equatorial radius
  double flattening = 0.0;               ///< 0: sphere (default); > 0: ellipsoid of revolution
  int continents = 6;                    ///< Table 2: 6
  double land_fraction = 0.5;            ///< Table 2: 50 % of the surface
  double sea_level = 0.0;                ///< ε_sea, relative to the reference surface
  double sea_depth = 4500.0;             ///< deepest ocean floor below sea level
  double max_river_altitude = 9000;      ///< a_max_river above sea level (Table 2: 12 km − 3 km)
  double max_mountain_altitude = 10000;  ///< a_max_mountain above sea level (13 km − 3 km)
  double river_depth = 300.0;            ///< ε_river, depth of a river at its mouth
  double min_river_length = 200000.0;    ///< l_rmin: new river arms only on longer edges
  double min_river_slope = 0.001;        ///< s_r (1 m/km) at river_slope_area
  /// Flint's law for the base network's rivers (planet.md "Base mesh"): their least slope is
  /// s_r · (A / river_slope_area)^−θ where they drain A > river_slope_area, and the rise to a
  /// spring is shared out along the river in proportion to A^−θ, so profiles are concave —
  /// steep headwaters, gentle lowlands. θ = river_concavity; 0 gives the paper's straight ones.
  double river_concavity = 0.5;
  double river_slope_area = 1e9;        ///< m² (1 000 km²)
  double min_riverbed_slope = 0.3;      ///< s_rb (300 m/km)
  double min_slope_near_river = 0.001;  ///< s_p (1 m/km)
  double riverbed_edge_height = 10.0;   ///< ε_rb
  double max_ground_slope = 1.0;        ///< s_g (1000 m/km)
  double mountain_slope = 0.012;        ///< e_m of eq. 5 (not in Table 2)
  /// Every new land vertex stands at least this slope above the neighbour it drains to (not in
  /// the paper): the surface has no pits at any level (planet.md "Drainage at every level").
  double min_drain_slope = 0.03;
  /// Relief regions (planet.md "Relief regions"): how much the ground's roughness varies from
  /// plains (smooth) to mountain belts (rugged). 0 gives every continent the same roughness.
  double relief_contrast = 1.0;
  /// Metres between mountain belts: the wavelength of the field whose ridges they follow.
  double belt_wavelength = 4000000.0;
  /// Metres the belts lift dry land on their crests (rivers keep their beds through them).
  double belt_height = 3000.0;
  /// Metres plateaus (tablelands) lift dry land: smooth tops, rugged escarpments, on a field of
  /// the regional field's wavelength; 0 for none.
  double plateau_height = 1500.0;
  /// Metres inland over which the land is smoother towards the coast (coastal plains); 0 for
  /// none.
  double coastal_plain_width = 300000.0;
  /// Continental shelves (planet.md "Continental shelves"): the sea floor within shelf_width of
  /// a coast lies no deeper than shelf_depth (half of it at the coast); 0 for none.
  double shelf_width = 80000.0;
  double shelf_depth = 130.0;
  /// Lakes (planet.md "Lakes"): how many the base mesh holds, each on a river at its outlet's
  /// level; 0 for none.
  int lakes = 24;
  /// The climate's share of dry land, 0 to 1: a lake whose climate is drier than 1 − aridity
  /// loses more water than it gains and is kept closed, below its rim, with no outflow.
  double aridity = 0.35;
  /// Domain warping (Schneider et al. 2006, planet.md "Winding valleys"): every point is
  /// evaluated where a smooth noise field moves it, each octave by up to this share of its
  /// wavelength, so that valleys and ridges along the mesh's straight edges wind; 0 for none
  /// (the default: it costs Flint's law some squares, planet.md says which).
  double warp = 0.0;
  /// Metres: the warp's longest wavelength; each next octave is a quarter as long, down to four
  /// edges of the level sampled, six at most.
  double warp_wavelength = 40000.0;
  ReliefModel relief_model = ReliefModel::drainage;
  int base_faces = 5000;      ///< base shape accuracy; rounded to 8·2^k faces
  double finest_edge = 10.0;  ///< refinement stops at edges this short; detail noise goes on
  DetailParams detail;
  /// "" (random continents), or "sha256:<64 lowercase hex>": the hash of an image whose pixels
  /// say where land is (planet/continent_map.hpp). Only a hash, never a path or URL, so a
  /// definition can never make a server read a file or fetch anything; whoever builds the planet
  /// supplies the decoded pixels. With a map, `continents` and `land_fraction` are ignored.
  std::string continent_map;
  /// The colours of the planet's colour tiles and of the viewer ("material", docs/material.md);
  /// written to the canonical form only when it differs from the defaults.
  terrain::Material material;

  /// Faces of the base mesh after rounding: the 8·2^k nearest to base_faces (in log scale).
  int base_levels() const;
};

/// Parses and validates a definition. Missing fields take the defaults above; unknown fields,
/// wrong types and out-of-range values are refused with the field's JSON pointer ("/radius",
/// "/detail/hurst"). Never throws.
Result<PlanetDefinition> parse_planet(const nlohmann::json& document);
/// The same from text; malformed JSON is refused with pointer "".
Result<PlanetDefinition> parse_planet_text(std::string_view text);
/// Reads a definition file.
Result<PlanetDefinition> load_planet_file(const std::string& path);

/// A numeric field's accepted range, as the parser checks it: a value outside it is refused
/// naming `pointer`. Relations between fields (sea_depth above river_depth, …) come on top.
struct FieldRange {
  std::string pointer;  ///< "/radius", "/detail/hurst"
  double lo = 0.0, hi = 0.0;
  bool lo_open = false;  ///< lo itself is refused: the value must exceed it
  bool integer = false;
};
/// Every numeric field but the seed (any unsigned 64-bit integer), from the tables that parse
/// them, so whatever probes the ranges (tests/planet/definition_ranges_test.cpp) follows new
/// fields.
std::vector<FieldRange> numeric_field_ranges();

/// Every field explicit, except continent_map, written only when set, and material,
/// min_drain_slope, the relief fields (relief_model included), lakes, aridity and the warp, written
/// only when they differ from the defaults (so planets defined before those fields existed keep
/// their ids): parse_planet(canonical_json(d)) gives d back.
nlohmann::json canonical_json(const PlanetDefinition& definition);
/// Every field at its default, those canonical_json leaves out included (continent_map as "",
/// material as its JSON): what docs/planet.md's table of fields must list
/// (PlanetDocs.DescribeEveryFieldWithItsDefault).
nlohmann::json definition_defaults();
/// The canonical text: keys sorted, no whitespace, shortest round-trip numbers.
std::string canonical_text(const PlanetDefinition& definition);
/// The planet's id: lowercase hex SHA-256 of canonical_text (64 characters, URL-safe).
std::string planet_id(const PlanetDefinition& definition);

}  // namespace planet
