#include "nodes/image.hpp"

#include <array>

#include "field_reader.hpp"
#include "nodes/stored_bounds.hpp"
#include "terrain/heightfield.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

// Pool: 0 λ_f, 1 λ_α, 2 h_lo, 3 h_hi, 4..7 support box, 8 quad record offset, 9 heightfield record
// offset (both relative to the node's first float), then the two records.
constexpr int kLipschitz = 0, kWeightLipschitz = 1, kLo = 2, kHi = 3, kBox = 4, kQuad = 8,
              kField = 9, kHeader = 10;

Result<NodeParams> parse_image(FieldReader& reader, ParseContext& context) {
  const std::string reference = reader.string("image", std::nullopt);
  std::array<Vec2, 4> corners{};
  const nlohmann::json* raw = reader.raw("corners");
  nlohmann::json canonical_corners = nlohmann::json::array();
  if (raw == nullptr || !raw->is_array() || raw->size() != 4) {
    reader.fail("must be four corners [[x, y], …]: north-west, north-east, south-east, south-west",
                "corners");
  } else {
    for (std::size_t k = 0; k < 4; ++k) {
      const nlohmann::json& c = (*raw)[k];
      if (!c.is_array() || c.size() != 2 || !c[0].is_number() || !c[1].is_number() ||
          !std::isfinite(c[0].get<double>()) || !std::isfinite(c[1].get<double>())) {
        return Error{"must be a point [x, y]", pointer_join(reader.pointer() + "/corners", k)};
      }
      corners[k] = {static_cast<float>(c[0].get<double>()), static_cast<float>(c[1].get<double>())};
      canonical_corners.push_back({c[0].get<double>(), c[1].get<double>()});
    }
  }
  reader.canonical()["corners"] = canonical_corners;
  HeightfieldParams hp;
  hp.offset = static_cast<float>(reader.number("elevation", 0.0, {-1e5, 1e5}));
  hp.scale = static_cast<float>(reader.number("height_scale", 1.0, {-1e5, 1e5}));
  hp.margin_u = hp.margin_v = static_cast<float>(reader.number("margin", 0.05, {0.001, 0.5}));
  if (!reader.ok()) return reader.error();

  const std::string image_pointer = pointer_join(reader.pointer(), "image");
  if (!context.options->images) {
    return Error{"images cannot be resolved here (no image store was given)", image_pointer};
  }
  Result<Raster> raster = context.options->images(reference);
  if (!raster) return Error{"image '" + reference + "': " + raster.error().message, image_pointer};
  if (static_cast<std::int64_t>(raster->width) * raster->height >
      context.options->limits.max_image_pixels) {
    return Error{"image '" + reference + "' has more pixels than the limit of " +
                     std::to_string(context.options->limits.max_image_pixels),
                 image_pointer};
  }
  Result<Heightfield> field = Heightfield::create(*raster, hp);
  if (!field) return Error{"image '" + reference + "': " + field.error().message, image_pointer};
  Result<QuadMap> quad = QuadMap::create(corners[0], corners[1], corners[2], corners[3]);
  if (!quad) return Error{quad.error().message, pointer_join(reader.pointer(), "corners")};

  NodeParams out;
  const float stretch = quad->inverse_jacobian_bound();
  const Box2 box = quad->bounds();
  out.pool = {field->lipschitz() * stretch,
              field->weight_lipschitz() * stretch,
              field->height_range().lo,
              field->height_range().hi,
              box.lo.x,
              box.lo.y,
              box.hi.x,
              box.hi.y,
              0.0f,
              0.0f};
  out.pool[kQuad] = static_cast<float>(out.pool.size());
  quad->pack(out.pool);
  out.pool[kField] = static_cast<float>(out.pool.size());
  field->pack(out.pool);
  out.canonical = reader.canonical();
  (void)kHeader;
  return out;
}

void image_leaf(const float* params, const PointBlock& points, FieldBlock& out) {
  const auto quad = static_cast<std::size_t>(params[kQuad]);
  const auto field = static_cast<std::size_t>(params[kField]);
  for (int i = 0; i < points.count; ++i) {
    const UvMap m = quad_inverse(params, quad, {points.x[i], points.y[i]});
    const UvSample h = heightfield_height(params, field, m.u, m.v);
    const UvSample w = heightfield_weight(params, field, m.u, m.v);
    const Vec2 gh = chain(h, m);
    const Vec2 gw = chain(w, m);
    out.f[i] = h.value;
    out.fx[i] = gh.x;
    out.fy[i] = gh.y;
    out.a[i] = w.value;
    out.ax[i] = gw.x;
    out.ay[i] = gw.y;
  }
}

NodeBounds image_bounds(const float* params, const BoundsQuery& query) {
  return stored_bounds(stored_box(params + kBox), {params[kLo], params[kHi]}, params[kLipschitz],
                       params[kWeightLipschitz], query);
}

}  // namespace

const NodeType& image_node_type() {
  static const NodeType type{
      .id = 4,
      .name = "image",
      .category = NodeCategory::primitive,
      .min_children = 0,
      .max_children = 0,
      .summary = "a heightfield image (16-bit PNG, float TIFF, EXR) on a convex quadrangle",
      .parse = parse_image,
      .kernels = {.leaf = image_leaf, .leaf_bounds = image_bounds},
      .example_json = R"({"type": "image", "image": "mountain.png",
 "corners": [[-900, 800], [1000, 1000], [800, -900], [-1000, -800]],
 "elevation": 50, "height_scale": 600, "margin": 0.1})",
  };
  return type;
}

}  // namespace terrain
