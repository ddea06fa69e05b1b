// Which tiles an edit changes: tiles before and after an edit are generated on a grid of addresses
// in several formats and compared byte for byte with what SceneChange predicts. Every tile whose
// bytes changed must be predicted (soundness, in every format). A predicted tile whose float32
// heights did not change must be explained by the test's knowledge of the edit: the one honest
// exception, a tile that only the faint fringe of a fall-off reaches (the edit rounds away in
// float32), or one of the documented over-approximations (a changed curve counts along its whole
// length, a noise warp by its displacement bound, the water mask wherever water may be, a child
// whose place in its blend's order moved wherever it weighs).
#include "terrain/scene_diff.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "example_tile_sources.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/tile_products.hpp"

namespace terrain {
namespace {

using nlohmann::json;

struct Version {
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const TileSource> source;
};

Version version_of(const json& document) {
  Result<Scene> scene = parse_scene(document);
  if (!scene) throw std::runtime_error(scene.error().pointer + ": " + scene.error().message);
  Result<TileSource> source = TileSource::from_scene(*scene);
  if (!source) throw std::runtime_error(source.error().message);
  return {std::make_shared<const Scene>(std::move(*scene)),
          std::make_shared<const TileSource>(std::move(*source))};
}

Version version_of_text(const std::string& text) {
  return version_of(json::parse(text));
}

json example_json(const std::string& name) {
  std::ifstream in(testing::kExampleScenes / (name + ".json"));
  return json::parse(in);
}

SceneChange change_between(const Version& a, const Version& b) {
  return SceneChange::between(a.scene, a.source, b.scene, b.source);
}

// A small scene with something of every kind an edit can reach: blend children (more than the
// BVH's leaf size), a transform around a blend, a noise warp. Radii and centres are not round, so
// no circle is tangent to a tile's edge.
const char* const kHills = R"({
  "seed": 7, "extent": {"min": [-3000, -3000], "max": [3000, 3000]},
  "georeference": {"latitude": 45.5, "longitude": 6.5, "heading": 30},
  "root": {"type": "blend", "children": [
    {"type": "disc", "id": "ground", "center": [0, 0], "radius": 4300, "elevation": 100,
     "noise": {"kind": "fbm", "amplitude": 30, "wavelength": 1700, "octaves": 5, "seed": 1}},
    {"type": "disc", "id": "a", "center": [-1234.5, 710.25], "radius": 611.3, "elevation": 260,
     "noise": {"kind": "fbm", "amplitude": 60, "wavelength": 500, "octaves": 5, "seed": 2}},
    {"type": "disc", "id": "b", "center": [905.5, -802.75], "radius": 707.7, "elevation": 220},
    {"type": "disc", "id": "c", "center": [1520.5, 1490.25], "radius": 433.3, "elevation": 180,
     "noise": {"kind": "ridged", "amplitude": 50, "wavelength": 400, "octaves": 4, "seed": 3}},
    {"type": "disc", "id": "d", "center": [-1700.5, -1800.25], "radius": 520.9, "elevation": 140},
    {"type": "transform", "translate": [300.5, 2100.5], "rotate": 33, "scale": 1.25, "children": [
      {"type": "blend", "children": [
        {"type": "disc", "center": [-200, 0], "radius": 300.7, "elevation": 150},
        {"type": "disc", "center": [250, 50], "radius": 260.3, "elevation": 190}]}]},
    {"type": "warp", "noise": {"kind": "fbm", "amplitude": 40, "wavelength": 1500, "octaves": 3,
                               "seed": 4},
     "children": [{"type": "disc", "center": [-2200.5, 300.5], "radius": 480.1,
                   "elevation": 210}]}]}})";

// Wyvill's fall-off of a disc in the root frame.
struct Disc {
  double x = 0.0, y = 0.0, radius = 0.0;
  double weight(double px, double py) const {
    const double t2 = ((px - x) * (px - x) + (py - y) * (py - y)) / (radius * radius);
    return t2 < 1.0 ? (1.0 - t2) * (1.0 - t2) * (1.0 - t2) : 0.0;
  }
};

Disc disc_of(const json& node) {
  return {node["center"][0].get<double>(), node["center"][1].get<double>(),
          node["radius"].get<double>()};
}

// Heights (with slopes) rather than encoded bytes: what a format's bytes are made of.
constexpr int kCentreHeights = 100;  // the cell-centred grid of the height images
constexpr int kCornerHeights = 101;  // the cell-corner grid of the meshes
constexpr int kWaterMask = 102;      // TileGenerator::water_mask, in quantized-mesh tiles

using Key = std::tuple<int, std::int64_t, std::int64_t>;  // z, x, y

struct TileGrid {
  TileScheme scheme = TileScheme::local;
  std::vector<TileAddress> addresses;
  std::vector<TileFormat> formats;
  ProductOptions options;
};

// Every tile of the local scheme at the given zooms.
TileGrid local_grid(const std::vector<int>& zooms, std::vector<TileFormat> formats) {
  TileGrid g;
  g.formats = std::move(formats);
  g.options.size = 64;
  g.options.grid = 33;
  for (int z : zooms) {
    for (std::int64_t y = 0; y < (std::int64_t{1} << z); ++y) {
      for (std::int64_t x = 0; x < (std::int64_t{1} << z); ++x) g.addresses.push_back({z, x, y});
    }
  }
  return g;
}

// The tiles of a scheme's zoom over the scene's area.
TileGrid area_grid(const Version& v, TileScheme scheme, int z, std::vector<TileFormat> formats) {
  TileGrid g;
  g.scheme = scheme;
  g.formats = std::move(formats);
  g.options.size = 64;
  g.options.grid = 17;
  const TileRange r = tiles_covering_area(*v.source, scheme, z);
  for (std::int64_t y = r.min_y; y <= r.max_y; ++y) {
    for (std::int64_t x = r.min_x; x <= r.max_x; ++x) g.addresses.push_back({z, x, y});
  }
  return g;
}

std::vector<std::uint8_t> bits_of(const HeightTile& t) {
  std::vector<std::uint8_t> out;
  for (const std::vector<float>* v : {&t.elevation, &t.slope_east, &t.slope_north}) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(v->data());
    out.insert(out.end(), p, p + v->size() * sizeof(float));
  }
  return out;
}

bool is_mesh(TileFormat f) {
  return format_info(f).mesh;
}

// Products of one version on a grid: format (or a pseudo-format above) → tile → bytes.
using Tiles = std::map<int, std::map<Key, std::vector<std::uint8_t>>>;

Tiles make_tiles(const Version& v, const TileGrid& grid) {
  ProductMaker maker(*v.source);
  TileGenerator generator(*v.source);
  const auto has = [&](auto pick) {
    return std::any_of(grid.formats.begin(), grid.formats.end(), pick);
  };
  const bool images = has([](TileFormat f) { return !is_mesh(f); });
  const bool meshes = has([](TileFormat f) { return is_mesh(f); });
  const bool water = has([](TileFormat f) { return f == TileFormat::quantized_mesh; });
  Tiles out;
  for (const TileAddress& a : grid.addresses) {
    const Key key{a.z, a.x, a.y};
    // One height tile per sample layout, encoded in every format of that layout.
    for (const bool mesh : {false, true}) {
      if (!(mesh ? meshes : images)) continue;
      const TileFormat layout = mesh ? TileFormat::draco : TileFormat::geotiff;
      Result<HeightTile> t = maker.height_tile(grid.scheme, a, layout, grid.options);
      if (!t) throw std::runtime_error(t.error().message);
      out[mesh ? kCornerHeights : kCentreHeights][key] = bits_of(*t);
      for (TileFormat f : grid.formats) {
        if (is_mesh(f) != mesh || f == TileFormat::quantized_mesh) continue;
        Result<Product> p =
            encode_product(*t, f, grid.options, maker.constants(), v.source->georeference);
        if (!p) throw std::runtime_error(p.error().message);
        out[static_cast<int>(f)][key] = std::move(p->bytes);
      }
    }
    if (water) {
      Result<Product> p = maker.make(grid.scheme, a, TileFormat::quantized_mesh, grid.options);
      if (!p) throw std::runtime_error(p.error().message);
      out[static_cast<int>(TileFormat::quantized_mesh)][key] = std::move(p->bytes);
      Result<std::vector<std::uint8_t>> mask = generator.water_mask(grid.scheme, a);
      if (!mask) throw std::runtime_error(mask.error().message);
      out[kWaterMask][key] = std::move(*mask);
    }
  }
  return out;
}

// Tiles of a version, made once per test binary (the unedited versions serve many tests).
const Tiles& tiles_of(const Version& v, const TileGrid& grid, const std::string& grid_name) {
  static std::map<std::string, Tiles> cache;
  const std::string key = v.scene->hash + "/" + grid_name;
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, make_tiles(v, grid)).first;
  return it->second;
}

std::set<Key> changed_between(const Tiles& a, const Tiles& b, int format) {
  std::set<Key> out;
  for (const auto& [key, bytes] : a.at(format)) {
    if (b.at(format).at(key) != bytes) out.insert(key);
  }
  return out;
}

std::string describe(const std::set<Key>& keys) {
  std::ostringstream s;
  for (const auto& [z, x, y] : keys) s << z << "/" << x << "/" << y << " ";
  return s.str();
}

/// Whether a tile that SceneChange predicts but whose heights did not change is one the test
/// expects (the edit reaches it only where its effect rounds away). Gets the tile's samples.
using Explain = std::function<bool(const HeightTile& before)>;

/// The largest weight of `discs` over a tile's samples is below 1e-5.
Explain only_faint_fringe(std::vector<Disc> discs) {
  return [discs](const HeightTile& t) {
    double most = 0.0;
    for (std::size_t i = 0; i < t.scene_x.size(); ++i) {
      for (const Disc& d : discs) most = std::max(most, d.weight(t.scene_x[i], t.scene_y[i]));
    }
    return most < 1e-5;
  };
}

/// The most tiles predicted and the most whose heights changed, over the formats that are not
/// global. Every caller checks them: without that, an edit that changed nothing would pass.
struct [[nodiscard]] Counts {
  std::size_t predicted = 0, changed = 0;
};

/// The edit changed some tiles, and fewer were predicted than the grid holds: a local change.
void expect_local(const Counts& counts, std::size_t tiles) {
  EXPECT_GT(counts.changed, 0u) << "the edit changed no tile";
  EXPECT_GE(counts.predicted, counts.changed);
  EXPECT_LT(counts.predicted, tiles) << "a local edit predicted every tile";
}

// Compares the prediction with the tiles, format by format: soundness for every format;
// exactness, up to `explain`, for the float heights behind the images and the meshes.
Counts expect_prediction(const Version& before, const Version& after, const TileGrid& grid,
                         const std::string& grid_name, const Explain& explain) {
  const SceneChange change = change_between(before, after);
  const Tiles& a = tiles_of(before, grid, grid_name);
  const Tiles b = make_tiles(after, grid);
  std::set<int> zooms;
  for (const TileAddress& t : grid.addresses) zooms.insert(t.z);
  Counts counts;
  ProductMaker maker(*before.source);
  for (TileFormat f : grid.formats) {
    SCOPED_TRACE(std::string(format_info(f).extension) + " " +
                 std::string(format_info(f).encoding));
    std::set<Key> predicted;
    for (int z : zooms) {
      bool truncated = true;
      for (const TileAddress& t :
           change.changed_tiles(grid.scheme, z, f, grid.options, 1u << 20, &truncated)) {
        predicted.insert({t.z, t.x, t.y});
      }
      EXPECT_FALSE(truncated);
    }
    for (const TileAddress& t : grid.addresses) {
      const bool listed = predicted.count({t.z, t.x, t.y}) > 0;
      EXPECT_EQ(change.tile_may_change(grid.scheme, t, f, grid.options), listed)
          << t.z << "/" << t.x << "/" << t.y;
    }
    // Soundness: every tile whose bytes changed was predicted.
    std::set<Key> missed;
    for (const Key& k : changed_between(a, b, static_cast<int>(f))) {
      if (predicted.count(k) == 0) missed.insert(k);
    }
    EXPECT_TRUE(missed.empty()) << "changed but not predicted: " << describe(missed);
    // Exactness against the float heights (and water mask) the format is made of.
    if (change.format_global(f)) continue;
    std::set<Key> changed = changed_between(a, b, is_mesh(f) ? kCornerHeights : kCentreHeights);
    if (f == TileFormat::quantized_mesh) changed.merge(changed_between(a, b, kWaterMask));
    counts.predicted = std::max(counts.predicted, predicted.size());
    counts.changed = std::max(counts.changed, changed.size());
    std::set<Key> unexplained;
    for (const Key& k : predicted) {
      if (changed.count(k) > 0) continue;
      const auto& [z, x, y] = k;
      Result<HeightTile> t = maker.height_tile(grid.scheme, {z, x, y}, f, grid.options);
      if (!t || !explain(*t)) unexplained.insert(k);
    }
    EXPECT_TRUE(unexplained.empty())
        << "predicted, unchanged and not explained: " << describe(unexplained);
    for (const Key& k : changed) {
      EXPECT_GT(predicted.count(k), 0u) << "heights changed, not predicted: " << describe({k});
    }
  }
  return counts;
}

/// expect_prediction for an edit whose change is local (see expect_local).
void expect_local_prediction(const Version& before, const Version& after, const TileGrid& grid,
                             const std::string& grid_name, const Explain& explain) {
  expect_local(expect_prediction(before, after, grid, grid_name, explain), grid.addresses.size());
}

const std::vector<TileFormat> kImageAndMesh = {TileFormat::geotiff, TileFormat::terrain_rgb,
                                               TileFormat::gray16, TileFormat::normal_map,
                                               TileFormat::draco};

// Zoom 3 (tiles of 750 m over the hills) for most edits; one test goes down to zoom 4.
TileGrid hills_grid() {
  return local_grid({3}, kImageAndMesh);
}

TEST(SceneChange, IdenticalScenesChangeNoTile) {
  const Version a = version_of_text(kHills);
  const Version b = version_of_text(kHills);
  const SceneChange change = change_between(a, b);
  EXPECT_TRUE(change.unchanged());
  EXPECT_FALSE(change.everything());
  EXPECT_FALSE(change.box());
  EXPECT_FALSE(change.format_global(TileFormat::gray16));
  const ProductOptions options;
  EXPECT_TRUE(
      change.changed_tiles(TileScheme::local, 3, TileFormat::geotiff, options, 100).empty());
  EXPECT_FALSE(change.tile_may_change(TileScheme::local, {2, 1, 1}, TileFormat::glb, options));
}

TEST(SceneChange, ReorderedKeysAndNewLabelsChangeNoTile) {
  // The same canonical scene written otherwise, and a node label (kept in the canonical form, so
  // a new version hash) that no evaluator reads.
  json other = json::parse(kHills);
  other["root"]["children"][2]["id"] = "renamed";
  const std::string text = other.dump(2);  // keys sorted, other layout
  const SceneChange change = change_between(version_of_text(kHills), version_of_text(text));
  EXPECT_TRUE(change.unchanged());
  EXPECT_TRUE(
      change.changed_tiles(TileScheme::webmercator, 14, TileFormat::terrain_rgb, {}, 10).empty());
}

TEST(SceneChange, MovingADiscChangesExactlyTheTilesItsOldAndNewDiscsTouch) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["root"]["children"][1]["center"] = {-700.5, 1100.25};
  const Version a = version_of(base), b = version_of(edited);
  const SceneChange change = change_between(a, b);
  EXPECT_FALSE(change.unchanged());
  EXPECT_FALSE(change.everything());
  EXPECT_FALSE(change.format_global(TileFormat::gray16));
  const Disc old_disc = disc_of(base["root"]["children"][1]);
  const Disc new_disc = disc_of(edited["root"]["children"][1]);
  ASSERT_TRUE(change.box());
  for (const Disc& d : {old_disc, new_disc}) {  // (up to the float rounding of the circles)
    EXPECT_LE(change.box()->lo.x, d.x - d.radius + 1e-3);
    EXPECT_LE(change.box()->lo.y, d.y - d.radius + 1e-3);
    EXPECT_GE(change.box()->hi.x, d.x + d.radius - 1e-3);
    EXPECT_GE(change.box()->hi.y, d.y + d.radius - 1e-3);
  }
  // Nothing beyond the two circles' boxes (and float slack).
  EXPECT_GE(change.box()->lo.x, old_disc.x - old_disc.radius - 1.0);
  EXPECT_LE(change.box()->hi.y, new_disc.y + new_disc.radius + 1.0);
  const Counts counts = expect_prediction(a, b, local_grid({2, 3, 4}, kImageAndMesh), "hills234",
                                          only_faint_fringe({old_disc, new_disc}));
  EXPECT_GT(counts.changed, 20u);
  EXPECT_LT(counts.predicted, 336u / 3);
}

TEST(SceneChange, GrowingADiscChangesTheTilesOfItsLargerCircle) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["root"]["children"][3]["radius"] = 801.9;
  const Disc grown = disc_of(edited["root"]["children"][3]);
  expect_local_prediction(version_of(base), version_of(edited), hills_grid(), "hills",
                          only_faint_fringe({grown}));
}

TEST(SceneChange, RaisingADiscMakesGray16AndMeshesGlobalWhenTheirQuantisationMoves) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["root"]["children"][2]["elevation"] = 900;  // the scene's highest point rises
  const Version a = version_of(base), b = version_of(edited);
  const SceneChange change = change_between(a, b);
  const ProductConstants ca = ProductMaker(*a.source).constants();
  const ProductConstants cb = ProductMaker(*b.source).constants();
  EXPECT_TRUE(change.format_global(TileFormat::gray16));
  EXPECT_EQ(change.format_global(TileFormat::draco), ca.position_quantum != cb.position_quantum);
  EXPECT_EQ(change.format_global(TileFormat::quantized_mesh), ca.edge_quantum != cb.edge_quantum);
  EXPECT_FALSE(change.format_global(TileFormat::geotiff));
  EXPECT_FALSE(change.format_global(TileFormat::terrain_rgb));
  EXPECT_TRUE(change.format_global(TileFormat::color_png));  // heights are fractions of the relief
  EXPECT_FALSE(change.everything());
  expect_local_prediction(a, b, hills_grid(), "hills",
                          only_faint_fringe({disc_of(base["root"]["children"][2])}));

  // A smaller rise keeps the scene's range, hence every quantisation: only local tiles change.
  json lower = base;
  lower["root"]["children"][2]["elevation"] = 215;
  const SceneChange small = change_between(a, version_of(lower));
  EXPECT_FALSE(small.format_global(TileFormat::gray16));
  EXPECT_FALSE(small.format_global(TileFormat::glb));
  EXPECT_FALSE(small.format_global(TileFormat::quantized_mesh));
}

TEST(SceneChange, ANewMaterialChangesEveryColourTileAndNoHeightProduct) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["material"] = {{"grass", "#ff0000"}};
  const SceneChange change = change_between(version_of(base), version_of(edited));
  EXPECT_FALSE(change.unchanged());
  EXPECT_FALSE(change.everything());
  EXPECT_FALSE(change.box());
  EXPECT_TRUE(change.format_global(TileFormat::color_png));
  EXPECT_TRUE(change.format_global(TileFormat::color_jpeg));
  const ProductOptions options;
  EXPECT_EQ(
      change.changed_tiles(TileScheme::local, 3, TileFormat::color_jpeg, options, 1000).size(),
      64u);
  for (TileFormat f : {TileFormat::terrain_rgb, TileFormat::gray16, TileFormat::hillshade,
                       TileFormat::quantized_mesh, TileFormat::glb}) {
    EXPECT_FALSE(change.format_global(f));
    EXPECT_TRUE(change.changed_tiles(TileScheme::local, 3, f, options, 1000).empty());
  }
}

TEST(SceneChange, AddingADiscInTheMiddleOfABlendChangesOnlyWhereItWeighs) {
  const json base = json::parse(kHills);
  json edited = base;
  const json added = json::parse(
      R"({"type": "disc", "center": [-300.5, -1500.5], "radius": 377.7, "elevation": 300})");
  auto& children = edited["root"]["children"];
  children.insert(children.begin() + 2, added);
  expect_local_prediction(version_of(base), version_of(edited), hills_grid(), "hills",
                          only_faint_fringe({disc_of(added)}));
}

TEST(SceneChange, RemovingADiscFromABlendChangesOnlyWhereItWeighed) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["root"]["children"].erase(edited["root"]["children"].begin() + 4);
  expect_local_prediction(version_of(base), version_of(edited), hills_grid(), "hills",
                          only_faint_fringe({disc_of(base["root"]["children"][4])}));
}

// A disc of the transformed blend, in the root frame: rotate 33°, scale 1.25, then translate.
Disc transformed(const json& disc) {
  const Disc d = disc_of(disc);
  const double c = std::cos(33.0 * std::numbers::pi / 180.0);
  const double s = std::sin(33.0 * std::numbers::pi / 180.0);
  return {300.5 + 1.25 * (c * d.x - s * d.y), 2100.5 + 1.25 * (s * d.x + c * d.y), 1.25 * d.radius};
}

TEST(SceneChange, EditingInsideATransformChangesOnlyWhereTheEditedDiscLies) {
  const json base = json::parse(kHills);
  json edited = base;
  json& inner = edited["root"]["children"][5]["children"][0]["children"][1];
  inner["center"] = {310, -20};
  inner["elevation"] = 170;
  const Disc old_disc = transformed(base["root"]["children"][5]["children"][0]["children"][1]);
  const Disc new_disc = transformed(inner);
  expect_local_prediction(version_of(base), version_of(edited), hills_grid(), "hills",
                          only_faint_fringe({old_disc, new_disc}));
}

TEST(SceneChange, EditingInsideANoiseWarpChangesOnlyNearTheWarpedDisc) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["root"]["children"][6]["children"][0]["elevation"] = 190;
  // The warp moves the disc by at most its displacement bound (about the noise amplitude): a
  // predicted tile that did not change must still come within that of the disc's circle.
  Disc reach = disc_of(base["root"]["children"][6]["children"][0]);
  reach.radius += 80.0;
  expect_local_prediction(version_of(base), version_of(edited), hills_grid(), "hills",
                          [reach](const HeightTile& t) {
                            for (std::size_t i = 0; i < t.scene_x.size(); ++i) {
                              if (reach.weight(t.scene_x[i], t.scene_y[i]) > 0.0) return true;
                            }
                            return false;
                          });
}

TEST(SceneChange, SceneWideFieldsChangeEveryTile) {
  const json base = json::parse(kHills);
  const Version a = version_of(base);
  const auto expect_everything = [&](const json& edited, const char* what) {
    SCOPED_TRACE(what);
    const SceneChange change = change_between(a, version_of(edited));
    EXPECT_TRUE(change.everything());
    EXPECT_FALSE(change.unchanged());
    EXPECT_FALSE(change.box());
    EXPECT_TRUE(change.format_global(TileFormat::terrain_rgb));
    EXPECT_TRUE(change.tile_may_change(TileScheme::local, {4, 15, 0}, TileFormat::geotiff, {}));
    bool truncated = false;
    EXPECT_EQ(change.changed_tiles(TileScheme::local, 3, TileFormat::geotiff, {}, 1000, &truncated)
                  .size(),
              64u);
    EXPECT_FALSE(truncated);
  };
  json seed = base;
  seed["seed"] = 8;
  expect_everything(seed, "seed");
  json extent = base;
  extent["extent"]["max"] = {3000, 3100};
  expect_everything(extent, "extent");
  json level = base;
  level["base_elevation"] = 5;
  expect_everything(level, "base elevation");
  json georeference = base;
  georeference["georeference"]["heading"] = 31;
  expect_everything(georeference, "georeference");
  // Without a declared extent the tile area is the root's support: growing it moves every tile.
  json implicit = base;
  implicit.erase("extent");
  json wider = implicit;
  wider["root"]["children"][0]["radius"] = 4400;
  EXPECT_TRUE(change_between(version_of(implicit), version_of(wider)).everything());
}

TEST(SceneChange, ChangedTilesStopAtTheLimit) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["root"]["children"][0]["elevation"] = 101;  // the ground under everything
  const SceneChange change = change_between(version_of(base), version_of(edited));
  bool truncated = false;
  const std::vector<TileAddress> some =
      change.changed_tiles(TileScheme::local, 8, TileFormat::geotiff, {}, 50, &truncated);
  EXPECT_EQ(some.size(), 50u);
  EXPECT_TRUE(truncated);
  for (const TileAddress& t : some) {
    EXPECT_TRUE(change.tile_may_change(TileScheme::local, t, TileFormat::geotiff, {}));
  }
  // Out-of-range requests: no list, and no tile claimed unchanged.
  EXPECT_TRUE(change.changed_tiles(TileScheme::local, 30, TileFormat::geotiff, {}, 10).empty());
  EXPECT_TRUE(change.tile_may_change(TileScheme::local, {2, 9, 0}, TileFormat::geotiff, {}));
}

TEST(SceneChange, MovingOneHillOfAManyHillBlendLeavesEveryOtherTileIdentical) {
  // hills-river blends sixteen overlapping hills: their float sums depend on the order they are
  // accumulated in, which the compiler keeps independent of the other children.
  const json base = example_json("hills-river");
  json edited = base;
  // The westernmost hill moves east, across the middle of the others.
  json& hill = edited["root"]["children"][0]["children"][2];
  const Disc old_hill = disc_of(hill);
  hill["center"] = {2300.5, 300.5};
  const Disc new_hill = disc_of(hill);
  const TileGrid grid = local_grid({3}, {TileFormat::geotiff, TileFormat::terrain_rgb});
  const Counts counts = expect_prediction(version_of(base), version_of(edited), grid, "river",
                                          only_faint_fringe({old_hill, new_hill}));
  EXPECT_GT(counts.changed, 0u);
  EXPECT_LT(counts.predicted, 64u);
}

TEST(SceneChange, BlendAccumulationOrderIgnoresUnrelatedChildren) {
  // Five hills in a row along x, then a sixth far to the north: a compiler that sorted children
  // along the blend's longer axis would see that axis flip, and reorder the sums of the five.
  std::string children;
  for (int i : {2, 0, 4, 1, 3}) {  // declared out of x order
    children += R"({"type": "disc", "center": [)" + std::to_string(-900 + 450 * i) +
                R"(.5, 10.5], "radius": 700.3, "elevation": )" + std::to_string(100 + 37 * i) +
                R"(, "noise": {"kind": "fbm", "seed": )" + std::to_string(i) + "}},";
  }
  const std::string far = R"({"type": "disc", "center": [0, 9000], "radius": 600, "elevation": 1})";
  const Version a = version_of_text(R"({"root": {"type": "blend", "children": [)" +
                                    children.substr(0, children.size() - 1) + "]}}");
  const Version b =
      version_of_text(R"({"root": {"type": "blend", "children": [)" + children + far + "]}}");
  const Program& pa = *a.source->terrain;
  const Program& pb = *b.source->terrain;
  GridSpec grid{-1500.25, -700.25, 23.5, 128, 64};
  const GridResult ga = evaluate_grid(pa, grid, 1), gb = evaluate_grid(pb, grid, 1);
  EXPECT_EQ(0, std::memcmp(ga.elevation.data(), gb.elevation.data(),
                           ga.elevation.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(ga.gradient_x.data(), gb.gradient_x.data(),
                           ga.gradient_x.size() * sizeof(float)));
}

TEST(SceneChange, AnEditThatMovesAChildInTheBlendOrderCountsWhereverTheChildWeighs) {
  // The transformed pair's support centre crosses the others' when its far disc moves east, so
  // its place in the root blend's accumulation order changes: the sums where its near disc and
  // the other hills overlap may round otherwise, although that disc did not move.
  const json base = json::parse(R"({
    "extent": {"min": [-3000, -3000], "max": [3000, 3000]},
    "root": {"type": "blend", "children": [
      {"type": "disc", "center": [0, 0], "radius": 4300, "elevation": 100,
       "noise": {"kind": "fbm", "amplitude": 30, "wavelength": 1700, "octaves": 5, "seed": 1}},
      {"type": "disc", "center": [300.5, 200.5], "radius": 700.3, "elevation": 200},
      {"type": "transform", "translate": [10.5, -20.5], "children": [{"type": "blend", "children": [
        {"type": "disc", "center": [150.5, 100.5], "radius": 500.7, "elevation": 160},
        {"type": "disc", "center": [-2200.5, 0], "radius": 400.3, "elevation": 300}]}]},
      {"type": "disc", "center": [-100.5, -300.5], "radius": 650.9, "elevation": 250}]}})");
  json edited = base;
  edited["root"]["children"][2]["children"][0]["children"][1]["center"] = {2200.5, 0};
  const Version a = version_of(base), b = version_of(edited);
  const SceneChange change = change_between(a, b);
  const ProductOptions options;
  // The tile of the near disc's centre (zoom 3 tiles are 750 m wide).
  EXPECT_TRUE(change.tile_may_change(TileScheme::local, {3, 4, 3}, TileFormat::geotiff, options));
  std::vector<Disc> pair;
  for (const json* scene : {&base, static_cast<const json*>(&edited)}) {
    for (const json& d : (*scene)["root"]["children"][2]["children"][0]["children"]) {
      Disc disc = disc_of(d);
      disc.x += 10.5;
      disc.y -= 20.5;
      pair.push_back(disc);
    }
  }
  expect_local_prediction(a, b, local_grid({3}, {TileFormat::geotiff}), "order",
                          [pair](const HeightTile& t) {
                            for (std::size_t i = 0; i < t.scene_x.size(); ++i) {
                              for (const Disc& d : pair) {
                                if (d.weight(t.scene_x[i], t.scene_y[i]) > 0.0) return true;
                              }
                            }
                            return false;
                          });
}

TEST(SceneChange, EditingACurvePointChangesOnlyTilesTheCurveReaches) {
  const json base = example_json("hills-river");
  json edited = base;
  json& river = edited["root"]["children"][1];
  river["pieces"][2][1] = {100.0, 520.0, 67.5};  // the middle control point of the third piece
  const Version a = version_of(base), b = version_of(edited);
  // A changed primitive counts wherever it has weight: along the whole river.
  Box2 reach;
  for (const Version* v : {&a, &b}) {
    reach = reach.united(tree_bounds(*v->scene->root->children[1], {}).support);
  }
  const TileGrid grid = local_grid({3}, {TileFormat::geotiff, TileFormat::terrain_rgb});
  const Counts counts = expect_prediction(a, b, grid, "river", [reach](const HeightTile& t) {
    for (std::size_t i = 0; i < t.scene_x.size(); ++i) {
      if (reach.contains({static_cast<float>(t.scene_x[i]), static_cast<float>(t.scene_y[i])}))
        return true;
    }
    return false;
  });
  EXPECT_GT(counts.changed, 0u);
}

TEST(SceneChange, WebMercatorTilesFollowTheGeoreference) {
  const json base = json::parse(kHills);
  json edited = base;
  edited["root"]["children"][3]["center"] = {1100.5, 1900.25};
  const Version a = version_of(base), b = version_of(edited);
  // The mercator tiles over the scene at zoom 14 (about 1.7 km wide at 45.5° N).
  const TileGrid grid =
      area_grid(a, TileScheme::webmercator, 14, {TileFormat::geotiff, TileFormat::terrain_rgb});
  const Counts counts =
      expect_prediction(a, b, grid, "mercator",
                        only_faint_fringe({disc_of(base["root"]["children"][3]),
                                           disc_of(edited["root"]["children"][3])}));
  EXPECT_GT(counts.changed, 0u);
  EXPECT_LT(counts.predicted, grid.addresses.size());
}

// A small georeferenced scene with a water layer, for quantized-mesh tiles.
const char* const kLake = R"({
  "extent": {"min": [-2000, -2000], "max": [2000, 2000]},
  "georeference": {"latitude": 44.6, "longitude": -1.2, "heading": 10},
  "water": {"type": "disc", "center": [-400.5, -300.5], "radius": 900.3, "elevation": 108},
  "root": {"type": "blend", "children": [
    {"type": "disc", "center": [0, 0], "radius": 3100, "elevation": 110},
    {"type": "disc", "center": [-400.5, -300.5], "radius": 700.7, "elevation": 90},
    {"type": "disc", "center": [1200.5, 1100.5], "radius": 600.9, "elevation": 180}]}})";

// The water is wet where its disc's weight reaches 0.5: within 0.454 of its radius.
Explain near_wet_water(std::vector<Disc> waters) {
  return [waters](const HeightTile& t) {
    for (std::size_t i = 0; i < t.scene_x.size(); ++i) {
      for (const Disc& w : waters) {
        if (std::hypot(t.scene_x[i] - w.x, t.scene_y[i] - w.y) < 0.5 * w.radius) return true;
      }
    }
    return false;
  };
}

TEST(SceneChange, MovingTheWaterChangesOnlyQuantizedMeshTilesWhereWaterIs) {
  const json base = json::parse(kLake);
  json edited = base;
  edited["water"]["center"] = {-100.5, -200.5};
  const Version a = version_of(base), b = version_of(edited);
  const SceneChange change = change_between(a, b);
  EXPECT_FALSE(change.unchanged());
  const TileGrid grid =
      area_grid(a, TileScheme::geographic, 14, {TileFormat::quantized_mesh, TileFormat::geotiff});
  // Terrain tiles do not see the water at all.
  EXPECT_TRUE(
      change.changed_tiles(TileScheme::geographic, 14, TileFormat::geotiff, grid.options, 100)
          .empty());
  const std::size_t predicted =
      change
          .changed_tiles(TileScheme::geographic, 14, TileFormat::quantized_mesh, grid.options, 100)
          .size();
  EXPECT_GT(predicted, 0u);
  EXPECT_LT(predicted, grid.addresses.size());
  // A tile predicted in vain lies where water is (where the mask depends on the terrain too).
  expect_local_prediction(a, b, grid, "lake",
                          near_wet_water({disc_of(base["water"]), disc_of(edited["water"])}));
  // Without the water mask extension the meshes do not change either.
  ProductOptions plain = grid.options;
  plain.watermask = false;
  EXPECT_TRUE(
      change.changed_tiles(TileScheme::geographic, 14, TileFormat::quantized_mesh, plain, 100)
          .empty());
}

TEST(SceneChange, RemovingTheWaterChangesTheMaskWhereItWas) {
  const json base = json::parse(kLake);
  json dry = base;
  dry.erase("water");
  const Version a = version_of(base), b = version_of(dry);
  const SceneChange change = change_between(a, b);
  EXPECT_FALSE(change.unchanged());
  const TileGrid grid =
      area_grid(a, TileScheme::geographic, 14, {TileFormat::quantized_mesh, TileFormat::geotiff});
  EXPECT_TRUE(
      change.changed_tiles(TileScheme::geographic, 14, TileFormat::geotiff, grid.options, 100)
          .empty());
  expect_local_prediction(a, b, grid, "lake", near_wet_water({disc_of(base["water"])}));
}

TEST(SceneChange, RaisingALakeBedChangesTheMaskWhereBothAre) {
  const json base = json::parse(kLake);
  json edited = base;
  edited["root"]["children"][1]["elevation"] = 112;  // the lake bed rises above the water
  const Version a = version_of(base), b = version_of(edited);
  const TileGrid grid = area_grid(a, TileScheme::geographic, 14, {TileFormat::quantized_mesh});
  expect_local_prediction(a, b, grid, "lake-mesh",
                          only_faint_fringe({disc_of(base["root"]["children"][1])}));
}

}  // namespace
}  // namespace terrain

namespace terrain {
namespace {

// An erosion node bakes its whole subtree into one grid: an edit under it may change every
// sample of its square (the rivers reroute), and nothing outside.
TEST(SceneChange, EditingUnderAnErosionChangesItsSquareAndNothingElse) {
  const json base = json::parse(R"({
    "seed": 7, "extent": {"min": [-3000, -3000], "max": [3000, 3000]},
    "root": {"type": "blend", "children": [
      {"type": "disc", "center": [0, 0], "radius": 4300, "elevation": 100},
      {"type": "erosion", "resolution": 48, "iterations": 6, "center": [1210.5, 1190.25],
       "size": 1300.5, "children": [
        {"type": "disc", "center": [1210.5, 1190.25], "radius": 600.5, "elevation": 300,
         "noise": {"kind": "ridged", "amplitude": 200, "wavelength": 400, "octaves": 4}}]}]}})");
  json edited = base;
  edited["root"]["children"][1]["children"][0]["elevation"] = 340;
  const Box2 square{{1210.5f - 650.25f, 1190.25f - 650.25f},
                    {1210.5f + 650.25f, 1190.25f + 650.25f}};
  // A predicted tile that kept its heights lies on the square's border fall-off at most.
  const Explain on_the_square = [square](const HeightTile& t) {
    for (std::size_t i = 0; i < t.scene_x.size(); ++i) {
      if (square.contains({static_cast<float>(t.scene_x[i]), static_cast<float>(t.scene_y[i])})) {
        return true;
      }
    }
    return false;
  };
  expect_local_prediction(version_of(base), version_of(edited), hills_grid(), "erosion",
                          on_the_square);
}

}  // namespace
}  // namespace terrain
