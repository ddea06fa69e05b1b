#include "nodes/image.hpp"

#include <array>
#include <cmath>
#include <optional>

#include "field_reader.hpp"
#include "nodes/skeleton_spec.hpp"
#include "nodes/stored_bounds.hpp"
#include "terrain/heightfield.hpp"
#include "terrain/scene.hpp"

namespace terrain {
namespace {

// Pool: 0 λ_f, 1 λ_α, 2 h_lo, 3 h_hi, 4..7 support box, 8 mapping record offset (a quad, or a
// polyline), 9 heightfield record offset (both relative to the node's first float), 10 mapping
// (0 quad, 1 curve, 2 the support box itself, axis-aligned: what the erosion node packs), 11 width
// across the curve, 12 curve length; then the two records.
constexpr int kLipschitz = 0, kWeightLipschitz = 1, kLo = 2, kHi = 3, kBox = 4, kMapping = 8,
              kField = 9, kMode = 10, kWidth = 11, kLength = 12;

// The fixed part of the pool; the mapping and heightfield record offsets are filled in after.
std::vector<float> pack_header(const Heightfield& field, float stretch, const Box2& box, float mode,
                               float width, float length) {
  return {field.lipschitz() * stretch,
          field.weight_lipschitz() * stretch,
          field.height_range().lo,
          field.height_range().hi,
          box.lo.x,
          box.lo.y,
          box.hi.x,
          box.hi.y,
          0.0f,
          0.0f,
          mode,
          width,
          length};
}

// The quadrangle mapping: corners north-west, north-east, south-east, south-west of the image.
Result<QuadMap> read_corners(FieldReader& reader) {
  std::array<Vec2, 4> corners{};
  const nlohmann::json* raw = reader.raw("corners");
  nlohmann::json canonical = nlohmann::json::array();
  if (!raw->is_array() || raw->size() != 4) {
    reader.fail("must be four corners [[x, y], …]: north-west, north-east, south-east, south-west",
                "corners");
    return reader.error();
  }
  for (std::size_t k = 0; k < 4; ++k) {
    const nlohmann::json& c = (*raw)[k];
    if (!c.is_array() || c.size() != 2 || !c[0].is_number() || !c[1].is_number() ||
        !std::isfinite(c[0].get<double>()) || !std::isfinite(c[1].get<double>())) {
      return Error{"must be a point [x, y]", pointer_join(reader.pointer() + "/corners", k)};
    }
    corners[k] = {static_cast<float>(c[0].get<double>()), static_cast<float>(c[1].get<double>())};
    canonical.push_back({c[0].get<double>(), c[1].get<double>()});
  }
  reader.canonical()["corners"] = canonical;
  Result<QuadMap> quad = QuadMap::create(corners[0], corners[1], corners[2], corners[3]);
  if (!quad) return Error{quad.error().message, pointer_join(reader.pointer(), "corners")};
  return quad;
}

Result<NodeParams> parse_image(FieldReader& reader, ParseContext& context) {
  const std::string reference = reader.string("image", std::nullopt);
  if (reader.has("corners") == reader.has("curve")) {
    reader.fail("give either corners (a quadrangle) or curve (along a skeleton)", "corners");
    return reader.error();
  }
  std::optional<QuadMap> quad;
  std::optional<Polyline> skeleton;
  float width = 0.0f;
  if (reader.has("corners")) {
    Result<QuadMap> q = read_corners(reader);
    if (!q) return q.error();
    quad = *q;
  } else {
    FieldReader curve = reader.nested("curve");
    Result<Polyline> line = read_skeleton(curve);
    if (!line) return line.error();
    width = static_cast<float>(curve.number("width", std::nullopt, {0.0, 1e6, true}));
    reader.adopt("curve", curve);
    if (!reader.ok()) return reader.error();
    skeleton = std::move(*line);
  }
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

  // |∇h| = |h_u ∇u + h_v ∇v|: through the quad's inverse Jacobian, or along the curve where
  // |∇u| ≤ 1/length (∇s is a unit tangent or 0) and |∇v| = 1/width.
  NodeParams out;
  if (quad) {
    out.pool = pack_image_on_quad(*field, *quad);
  } else {
    const float stretch =
        std::sqrt(1.0f / (skeleton->length() * skeleton->length()) + 1.0f / (width * width));
    out.pool = pack_header(*field, stretch, skeleton->bounds().expanded(0.5f * width), 1.0f, width,
                           skeleton->length());
    out.pool[kMapping] = static_cast<float>(out.pool.size());
    skeleton->pack(out.pool);
    out.pool[kField] = static_cast<float>(out.pool.size());
    field->pack(out.pool);
  }
  out.canonical = reader.canonical();
  return out;
}

// (u, v) on an axis-aligned box (lo.x, lo.y, hi.x, hi.y), v = 0 on its north edge. Outside it u
// and v leave [0, 1], where the heightfield clamps them and its border weight is 0: the same as
// QuadMap's nearest-point extension, which for a rectangle is clamping.
UvMap box_map(const float* box, Vec2 p) {
  const float inv_width = 1.0f / (box[2] - box[0]);
  const float inv_height = 1.0f / (box[3] - box[1]);
  UvMap m;
  m.u = (p.x - box[0]) * inv_width;
  m.v = (box[3] - p.y) * inv_height;
  m.du = {inv_width, 0.0f};
  m.dv = {0.0f, -inv_height};
  return m;
}

void image_leaf(const float* params, const PointBlock& points, FieldBlock& out) {
  const auto mapping = static_cast<std::size_t>(params[kMapping]);
  const auto field = static_cast<std::size_t>(params[kField]);
  const bool along_curve = params[kMode] == 1.0f;
  const bool on_box = params[kMode] == 2.0f;
  const float inv_width = along_curve ? 1.0f / params[kWidth] : 0.0f;
  const float inv_length = along_curve && params[kLength] > 0.0f ? 1.0f / params[kLength] : 0.0f;
  for (int i = 0; i < points.count; ++i) {
    const Vec2 p{points.x[i], points.y[i]};
    UvMap m;
    if (along_curve) {
      // u along the curve, v across it: row 0 (v = 0) on the left of the direction of travel.
      const PolylineSample q = polyline_eval(params + mapping, p);
      m.u = q.s * inv_length;
      m.v = 0.5f - q.signed_distance * inv_width;
      m.du = q.grad_s * inv_length;
      m.dv = q.grad_d * -inv_width;
    } else if (on_box) {
      m = box_map(params + kBox, p);
    } else {
      m = quad_inverse(params, mapping, p);
    }
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

std::vector<float> pack_image_on_quad(const Heightfield& field, const QuadMap& quad) {
  std::vector<float> pool =
      pack_header(field, quad.inverse_jacobian_bound(), quad.bounds(), 0.0f, 0.0f, 0.0f);
  pool[kMapping] = static_cast<float>(pool.size());
  quad.pack(pool);
  pool[kField] = static_cast<float>(pool.size());
  field.pack(pool);
  return pool;
}

namespace {
// The mapping's few fixed steps, and for a curve mapping its polyline's chunks and segments (a
// quadrangle's corners are coordinates, not counts).
std::size_t image_loop_iterations(std::span<const float> params) {
  constexpr std::size_t kMappingSteps = 4;
  if (pool_count(params, kMode) != 1) return kMappingSteps;
  const std::size_t mapping = pool_count(params, kMapping);
  const std::span<const float> packed =
      mapping < params.size() ? params.subspan(mapping) : std::span<const float>{};
  return kMappingSteps + polyline_loop_iterations(packed);
}
}  // namespace

const NodeType& image_node_type() {
  static const NodeType type{
      .id = 4,
      .name = "image",
      .category = NodeCategory::primitive,
      .min_children = 0,
      .max_children = 0,
      .summary =
          "a heightfield image (16-bit PNG, float TIFF, EXR) on a convex quadrangle or "
          "along a curve",
      .parse = parse_image,
      .kernels = {.leaf = image_leaf,
                  .leaf_bounds = image_bounds,
                  .varies_with_spacing = never_varies_with_spacing},
      .example_json = R"({"type": "image", "image": "mountain.png",
 "corners": [[-900, 800], [1000, 1000], [800, -900], [-1000, -800]],
 "elevation": 50, "height_scale": 600, "margin": 0.1})",
      .loop_iterations = image_loop_iterations,
      .shader = {.call = "image_leaf($at, $p)", .heavy = true},
  };
  return type;
}

}  // namespace terrain
