// Every number parameter of every node type at the limits of its range: the parameters and their
// ranges are those the node type's own parser declares (ParseOptions::declared_numbers) while it
// reads its registry example, so a new node type or parameter is covered without touching this
// file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "field_checks.hpp"

#include "terrain/evaluate.hpp"
#include "terrain/node.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"
#include "terrain/tile_source.hpp"

namespace terrain {
namespace {

Result<Raster> flat_image(std::string_view) {
  Raster r;
  r.width = 8;
  r.height = 8;
  r.samples.assign(64, 0.5f);
  return r;
}

nlohmann::json example_scene(const NodeType& type) {
  return nlohmann::json::parse(R"({"format": "terrain-scene/1", "name": "limits", "seed": 3,
    "root": )" + std::string(type.example_json) +
                               "}");
}

/// The numbers the root node itself declares (not those of its children).
std::vector<DeclaredNumber> declared_parameters(const NodeType& type) {
  std::vector<DeclaredNumber> declared;
  ParseOptions options;
  options.images = flat_image;
  options.declared_numbers = &declared;
  const Result<Scene> scene = parse_scene(example_scene(type), options);
  EXPECT_TRUE(scene.ok()) << type.name;
  std::erase_if(declared, [](const DeclaredNumber& d) {
    return !d.pointer.starts_with("/root/") || d.pointer.starts_with("/root/children/");
  });
  return declared;
}

/// Values at and just inside the limits. The float32 neighbours matter: the canonical text may
/// hold the float a limit rounds to, which lies outside the limit in double.
std::vector<double> values_at_limits(const DeclaredNumber& d) {
  if (d.integer) return {d.min, d.max};
  const auto inside_float = [](double limit, double toward) {
    return static_cast<double>(
        std::nextafter(static_cast<float>(limit), static_cast<float>(toward)));
  };
  std::vector<double> values{d.max, std::nextafter(d.max, d.min), inside_float(d.max, d.min)};
  if (d.exclusive_min) {
    values.push_back(d.min + std::abs(d.min) * 1e-12 + 1e-300);
    values.push_back(d.min + 1e-40);
    if (d.min == 0.0) values.push_back(std::numeric_limits<float>::min());
  } else {
    values.push_back(d.min);
  }
  values.push_back(std::nextafter(d.min, d.max));
  values.push_back(inside_float(d.min, d.max));
  return values;
}

bool says_out_of_range(const std::string& message) {
  return message.find("at most") != std::string::npos ||
         message.find("within [") != std::string::npos ||
         message.find("must be from") != std::string::npos ||
         message.find("integer from") != std::string::npos;
}

struct AtLimit {
  std::string label;  ///< "pointer = value", for messages
  Result<Scene> scene;
};

/// The example with one parameter set to `value`, parsed.
AtLimit parse_at(const NodeType& type, const DeclaredNumber& d, double value) {
  nlohmann::json doc = example_scene(type);
  doc[nlohmann::json::json_pointer(d.pointer)] =
      d.integer ? nlohmann::json(static_cast<std::int64_t>(value)) : nlohmann::json(value);
  ParseOptions options;
  options.images = flat_image;
  return {d.pointer + " = " + nlohmann::json(value).dump(), parse_scene(doc, options)};
}

/// Every accepted value, or a refusal naming the parameter's pointer for one that is not
/// strictly inside its range or is a float32 denormal (a value inside it may only be refused by
/// a constraint between fields, such as lod's fine_spacing < coarse_spacing).
template <typename Check>
void for_each_value_at_limits(const NodeType& type, Check check) {
  const std::vector<DeclaredNumber> parameters = declared_parameters(type);
  for (const DeclaredNumber& d : parameters) {
    for (const double value : values_at_limits(d)) {
      AtLimit at = parse_at(type, d, value);
      if (at.scene.ok()) {
        check(at.label, *at.scene);
        continue;
      }
      // Values kept as float32 denormals (or flushed to 0) are refused whatever their range.
      const float stored = static_cast<float>(value);
      const bool normal = value == 0.0 || std::abs(stored) >= std::numeric_limits<float>::min();
      const bool inside = value > d.min && value < d.max;
      const bool limit = !d.exclusive_min && (value == d.min || value == d.max);
      if (normal && (inside || limit)) {
        EXPECT_FALSE(says_out_of_range(at.scene.error().message))
            << at.label << " is within its range but was refused: " << at.scene.error().message;
      } else {
        EXPECT_EQ(at.scene.error().pointer, d.pointer) << at.label;
      }
    }
  }
}

class EveryNodeTypeAtItsLimits : public ::testing::TestWithParam<const NodeType*> {};

// A scene that is accepted is stored as its canonical text: that text must read back as the same
// scene and compile, or the stored scene could never be served again.
TEST_P(EveryNodeTypeAtItsLimits, CanonicalFormParsesAgainAndCompiles) {
  for_each_value_at_limits(*GetParam(), [](const std::string& label, const Scene& scene) {
    ParseOptions options;
    options.images = flat_image;
    const Result<Scene> again = parse_scene_text(scene.canonical_text(), options);
    ASSERT_TRUE(again.ok()) << label << ": the canonical form " << scene.canonical_text()
                            << " is refused at " << again.error().pointer << ": "
                            << again.error().message;
    EXPECT_EQ(again->canonical_text(), scene.canonical_text()) << label;
    const Result<TileSource> source = TileSource::from_scene(*again);
    EXPECT_TRUE(source.ok()) << label << ": " << (source.ok() ? "" : source.error().message);
  });
}

bool finite_bounds(const NodeBounds& b) {
  const bool elevation =
      b.elevation.empty() || (std::isfinite(b.elevation.lo) && std::isfinite(b.elevation.hi));
  return elevation && std::isfinite(b.elevation_lipschitz) && std::isfinite(b.weight_lipschitz);
}

// No valid parameter may make an elevation, a gradient or a bound NaN or infinite: tiles encode
// them, validation reports the bounds, and the sphere tracer divides by the Lipschitz bound.
TEST_P(EveryNodeTypeAtItsLimits, ElevationsGradientsAndBoundsStayFinite) {
  for_each_value_at_limits(*GetParam(), [](const std::string& label, const Scene& scene) {
    EXPECT_TRUE(finite_bounds(scene.bounds)) << label << ": the scene's bounds";
    const Program program = testing::compile_or_die(scene);
    Evaluator evaluator(program);
    const Box2 region = testing::sampling_box(scene);
    const Vec2 size = region.size();
    constexpr int kSteps = 12;
    for (int j = 0; j <= kSteps; ++j) {
      for (int i = 0; i <= kSteps; ++i) {
        const Vec2 p{region.lo.x + size.x * static_cast<float>(i) / kSteps,
                     region.lo.y + size.y * static_cast<float>(j) / kSteps};
        const FieldSample s = evaluator.sample(p);
        ASSERT_TRUE(std::isfinite(s.elevation) && std::isfinite(s.elevation_gradient.x) &&
                    std::isfinite(s.elevation_gradient.y) && std::isfinite(s.weight))
            << label << " at (" << p.x << ", " << p.y << "): elevation " << s.elevation
            << ", gradient (" << s.elevation_gradient.x << ", " << s.elevation_gradient.y << ")";
      }
      const Box2 row{{region.lo.x, region.lo.y + size.y * static_cast<float>(j) / kSteps},
                     {region.hi.x, region.lo.y + size.y * static_cast<float>(j + 1) / kSteps}};
      EXPECT_TRUE(finite_bounds(evaluator.bounds({row, 0.0f}))) << label << ": bounds of a row";
    }
  });
}

// The blend's background is divided by its threshold: the smallest thresholds a scene may give,
// with a base far from zero, keep elevations, gradients and bounds finite (1e-300 used to be
// stored as 0: NaN elevations; 1e-40, a denormal: an infinite Lipschitz bound).
TEST(BlendThreshold, SmallestAcceptedKeepsEverythingFinite) {
  for (const double threshold : {1e-300, 1e-40, 1.2e-38, 1e-10, 1e-4}) {
    const std::string text = R"({"root": {"type": "blend", "base": 100000, "threshold": )" +
                             nlohmann::json(threshold).dump() + R"(, "children": [
        {"type": "disc", "center": [0, 0], "radius": 1000, "elevation": -100000}]}})";
    const Result<Scene> scene = parse_scene_text(text);
    if (!scene.ok()) {
      EXPECT_EQ(scene.error().pointer, "/root/threshold") << threshold;
      continue;
    }
    EXPECT_TRUE(finite_bounds(scene->bounds)) << "threshold " << threshold;
    const Program program = testing::compile_or_die(*scene);  // the evaluator refers to it
    Evaluator evaluator(program);
    for (float x = -1500.0f; x <= 1500.0f; x += 37.0f) {
      const FieldSample s = evaluator.sample({x, 0.0f});
      ASSERT_TRUE(std::isfinite(s.elevation) && std::isfinite(s.elevation_gradient.x))
          << "threshold " << threshold << " at x = " << x;
    }
  }
}

std::string type_name(const ::testing::TestParamInfo<const NodeType*>& info) {
  return std::string(info.param->name);
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryNodeTypeAtItsLimits, ::testing::ValuesIn(node_types()),
                         type_name);

// The enumeration sees a node's own numbers, nested ones and [x, y] components, not its children's.
TEST(DeclaredParameters, AreTheNodesOwnNumbersWithTheirRanges) {
  const std::vector<DeclaredNumber> disc = declared_parameters(*find_node_type("disc"));
  const auto find = [&disc](std::string_view pointer) {
    return std::find_if(disc.begin(), disc.end(),
                        [pointer](const DeclaredNumber& d) { return d.pointer == pointer; });
  };
  ASSERT_NE(find("/root/radius"), disc.end());
  EXPECT_EQ(find("/root/radius")->max, 1e7);
  EXPECT_NE(find("/root/center/1"), disc.end());
  EXPECT_NE(find("/root/noise/amplitude"), disc.end());
  EXPECT_TRUE(find("/root/noise/octaves")->integer);
  EXPECT_TRUE(declared_parameters(*find_node_type("transform")).size() > 4);
}

// The documented minimum scale, written as the docs write it, survives canonicalisation.
TEST(TransformScale, DocumentedMinimumReadsBackFromItsCanonicalForm) {
  const Scene scene = testing::parse_or_die(R"({"root": {"type": "transform", "scale": 0.0001,
    "children": [{"type": "disc", "center": [0, 0], "radius": 1000, "elevation": 100}]}})");
  const Result<Scene> again = parse_scene_text(scene.canonical_text());
  ASSERT_TRUE(again.ok()) << again.error().pointer << ": " << again.error().message;
  EXPECT_EQ(again->hash, scene.hash);
}

}  // namespace
}  // namespace terrain
