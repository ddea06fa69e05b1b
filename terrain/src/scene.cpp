#include "terrain/scene.hpp"

#include <openssl/evp.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "field_reader.hpp"
#include "nodes/replace.hpp"
#include "terrain/evaluate.hpp"
#include "terrain/json_text.hpp"
#include "terrain/noise.hpp"

namespace terrain {

std::string sha256_hex(std::string_view bytes) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int length = 0;
  EVP_Digest(bytes.data(), bytes.size(), digest.data(), &length, EVP_sha256(), nullptr);
  std::string hex;
  hex.reserve(length * 2);
  for (unsigned int i = 0; i < length; ++i) {
    std::array<char, 3> byte{};
    std::snprintf(byte.data(), byte.size(), "%02x", digest[i]);
    hex += byte.data();
  }
  return hex;
}

std::uint32_t ParseContext::noise_seed(std::int64_t node_seed) const {
  return noise::hash(scene_seed, static_cast<std::uint32_t>(node_seed));
}

BakeCache::Grid BakeCache::get_or_make(const std::string& key, const std::function<Grid()>& make) {
  {
    std::unique_lock lock(mutex_);
    made_.wait(lock, [&] { return !in_flight_.contains(key); });
    if (auto it = entries_.find(key); it != entries_.end()) {
      it->second.second = ++clock_;
      return it->second.first;
    }
    in_flight_.insert(key);
  }
  Grid grid;
  bool from_shared = false;
  try {
    // Another process may have made it (the shared stores); else it is made here, and shared.
    if (shared_.find) {
      if (std::optional<std::vector<float>> found = shared_.find(key)) {
        grid = std::make_shared<const std::vector<float>>(std::move(*found));
        from_shared = true;
      }
    }
    if (!grid) {
      grid = make();
      if (grid && shared_.insert) shared_.insert(key, *grid);
    }
  } catch (...) {
    std::lock_guard lock(mutex_);
    in_flight_.erase(key);
    made_.notify_all();
    throw;
  }
  std::lock_guard lock(mutex_);
  in_flight_.erase(key);
  if (grid) {
    insert(key, grid);
    ++(from_shared ? shared_hits_ : made_count_);
  }
  made_.notify_all();
  return grid;
}

std::int64_t BakeCache::made() const {
  std::lock_guard lock(mutex_);
  return made_count_;
}

std::int64_t BakeCache::shared_hits() const {
  std::lock_guard lock(mutex_);
  return shared_hits_;
}

void BakeCache::insert(const std::string& key, Grid grid) {
  const std::size_t size = grid->size() * sizeof(float);
  if (size > max_bytes_) return;
  auto [it, inserted] = entries_.try_emplace(key, std::move(grid), ++clock_);
  if (!inserted) return;
  bytes_ += size;
  while (bytes_ > max_bytes_) {
    auto oldest = entries_.begin();
    for (auto e = entries_.begin(); e != entries_.end(); ++e) {
      if (e->second.second < oldest->second.second) oldest = e;
    }
    bytes_ -= oldest->second.first->size() * sizeof(float);
    entries_.erase(oldest);
  }
}

void BakeCache::share_with(Shared shared) {
  std::lock_guard lock(mutex_);
  shared_ = std::move(shared);
}

std::size_t BakeCache::bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}

Box2 Scene::area() const {
  if (extent) return *extent;
  if (!bounds.support.empty() && std::isfinite(bounds.support.lo.x)) return bounds.support;
  return Box2::around({0, 0}, 1000.0f);
}

namespace {

struct ParsedNode {
  NodePtr node;
  nlohmann::json canonical;
  std::int64_t expanded_size = 0;
  int height = 1;           ///< levels below and including this node, references expanded
  bool adds_water = false;  ///< whether a node in it made a water layer (a drainage)
};

class SceneParser {
 public:
  SceneParser(const nlohmann::json& document, const ParseOptions& options)
      : document_(document), options_(options) {
    context_.options = &options_;
  }

  Result<Scene> parse();

 private:
  Result<ParsedNode> parse_node(const nlohmann::json& j, const std::string& pointer, int depth);
  Result<ParsedNode> resolve(const std::string& name, const std::string& pointer, int depth);

  const nlohmann::json& document_;
  const ParseOptions& options_;
  ParseContext context_;
  const nlohmann::json* definitions_ = nullptr;
  std::map<std::string, ParsedNode, std::less<>> parsed_definitions_;
  std::set<std::string, std::less<>> in_progress_;
};

Result<ParsedNode> SceneParser::resolve(const std::string& name, const std::string& pointer,
                                        int depth) {
  if (auto it = parsed_definitions_.find(name); it != parsed_definitions_.end()) {
    return it->second;
  }
  if (definitions_ == nullptr || !definitions_->contains(name)) {
    return Error{"refers to an undefined definition '" + name + "'", pointer};
  }
  if (in_progress_.contains(name)) {
    return Error{"definition '" + name + "' refers to itself (a cycle)", pointer};
  }
  in_progress_.insert(name);
  Result<ParsedNode> parsed =
      parse_node((*definitions_)[name], pointer_join("/definitions", name), depth);
  in_progress_.erase(name);
  if (!parsed) return parsed;
  parsed_definitions_.emplace(name, *parsed);
  return parsed;
}

Result<ParsedNode> SceneParser::parse_node(const nlohmann::json& j, const std::string& pointer,
                                           int depth) {
  if (depth > options_.limits.max_depth) {
    return Error{"nesting is deeper than the limit of " +
                     std::to_string(options_.limits.max_depth) + " levels",
                 pointer};
  }
  if (!j.is_object()) return Error{"a node must be a JSON object", pointer};
  if (j.contains("ref")) {
    const nlohmann::json& ref = j["ref"];
    if (!ref.is_string()) return Error{"must be the name of a definition", pointer + "/ref"};
    if (j.size() != 1) {
      return Error{"a reference node has only \"ref\"; wrap it in a transform to place it",
                   pointer};
    }
    const std::string name = ref.get<std::string>();
    Result<ParsedNode> target = resolve(name, pointer + "/ref", depth);
    if (!target) return target.error();
    ParsedNode out = *target;
    if (depth + out.height - 1 > options_.limits.max_depth) {
      return Error{"expanding this reference nests deeper than the limit of " +
                       std::to_string(options_.limits.max_depth) + " levels",
                   pointer};
    }
    if (out.adds_water && (context_.reshaping_ancestors > 0 || context_.in_water_tree)) {
      return Error{
          "refers to a definition holding a drainage, which belongs in the terrain tree "
          "and not under a transform, warp or erosion",
          pointer + "/ref"};
    }
    out.canonical = nlohmann::json{{"ref", name}};
    return out;
  }
  const auto type_it = j.find("type");
  if (type_it == j.end()) return Error{"is required (or \"ref\")", pointer + "/type"};
  if (!type_it->is_string()) return Error{"must be a string", pointer + "/type"};
  const NodeType* type = find_node_type(type_it->get<std::string>());
  if (type == nullptr) {
    std::string known;
    for (const NodeType* t : node_types())
      known += (known.empty() ? "" : ", ") + std::string(t->name);
    return Error{"unknown node type '" + type_it->get<std::string>() + "' (known: " + known + ")",
                 pointer + "/type"};
  }

  const std::size_t water_layers_before = context_.water_layers.size();
  auto node = std::make_shared<Node>();
  node->type = type;
  nlohmann::json canonical = nlohmann::json::object();
  canonical["type"] = type->name;
  if (const auto id = j.find("id"); id != j.end()) {
    if (!id->is_string()) return Error{"must be a string", pointer + "/id"};
    node->id = id->get<std::string>();
    canonical["id"] = node->id;
  }

  std::int64_t size = 1;
  int height = 1;
  const auto children_it = j.find("children");
  if (type->max_children == 0) {
    if (children_it != j.end()) {
      return Error{"a " + std::string(type->name) + " has no children", pointer + "/children"};
    }
  } else {
    if (children_it == j.end() || !children_it->is_array()) {
      return Error{"must be an array of nodes", pointer + "/children"};
    }
    const std::size_t count = children_it->size();
    if (count < type->min_children || count > type->max_children) {
      const std::string expected = type->min_children == type->max_children
                                       ? std::to_string(type->min_children)
                                       : "at least " + std::to_string(type->min_children);
      return Error{"a " + std::string(type->name) + " takes " + expected + " children, not " +
                       std::to_string(count),
                   pointer + "/children"};
    }
    nlohmann::json canonical_children = nlohmann::json::array();
    // Transforms and warps move their subtree; primitives with children bake it into a grid.
    const bool reshapes = type->category == NodeCategory::warp ||
                          (type->category == NodeCategory::primitive && type->max_children > 0);
    context_.reshaping_ancestors += reshapes ? 1 : 0;
    for (std::size_t i = 0; i < count; ++i) {
      Result<ParsedNode> child =
          parse_node((*children_it)[i], pointer_join(pointer + "/children", i), depth + 1);
      if (!child) return child.error();
      node->children.push_back(child->node);
      canonical_children.push_back(std::move(child->canonical));
      size += child->expanded_size;
      height = std::max(height, child->height + 1);
    }
    context_.reshaping_ancestors -= reshapes ? 1 : 0;
    canonical["children"] = std::move(canonical_children);
  }
  if (size > options_.limits.max_nodes) {
    return Error{
        "the scene expands to more than " + std::to_string(options_.limits.max_nodes) + " nodes",
        pointer};
  }

  FieldReader reader(j, pointer);
  reader.declare_numbers_to(options_.declared_numbers);
  reader.skip("type");
  reader.skip("id");
  reader.skip("children");
  context_.children = node->children;
  Result<NodeParams> params = type->parse(reader, context_);
  context_.children = {};
  if (!params) return params.error();
  reader.reject_unknown();
  if (!reader.ok()) return reader.error();
  node->params = std::move(*params);
  for (auto& [key, value] : node->params.canonical.items()) canonical[key] = value;
  const bool adds_water = context_.water_layers.size() > water_layers_before;
  return ParsedNode{std::move(node), std::move(canonical), size, height, adds_water};
}

Result<Scene> SceneParser::parse() {
  if (!document_.is_object()) return Error{"a scene must be a JSON object", ""};
  FieldReader reader(document_, "");
  Scene scene;
  const std::string format = reader.string("format", kSceneFormat);
  if (reader.ok() && format != kSceneFormat) {
    reader.fail("must be \"" + std::string(kSceneFormat) + "\"", "format");
  }
  scene.name = reader.string("name", "");
  if (reader.ok() && scene.name.size() > options_.limits.max_name_bytes) {
    reader.fail("must be at most " + std::to_string(options_.limits.max_name_bytes) +
                    " bytes of UTF-8, not " + std::to_string(scene.name.size()),
                "name");
  }
  scene.seed = static_cast<std::uint32_t>(reader.integer("seed", 0, 0, 0xffffffffLL));
  scene.base_elevation = static_cast<float>(reader.number("base_elevation", 0.0, {-1e5, 1e5}));
  if (reader.has("extent")) {
    FieldReader extent = reader.nested("extent");
    const Vec2 lo = extent.vec2("min", std::nullopt, {-1e7, 1e7});
    const Vec2 hi = extent.vec2("max", std::nullopt, {-1e7, 1e7});
    if (extent.ok() && !(lo.x < hi.x && lo.y < hi.y)) {
      extent.fail("must be larger than min on both axes", "max");
    }
    reader.adopt("extent", extent);
    scene.extent = Box2{lo, hi};
  }
  if (reader.has("georeference")) {
    FieldReader geo = reader.nested("georeference");
    scene.georeference.latitude = geo.number("latitude", 0.0, {-85.0, 85.0});
    scene.georeference.longitude = geo.number("longitude", 0.0, {-180.0, 180.0});
    scene.georeference.heading = geo.number("heading", 0.0, {-360.0, 360.0});
    reader.adopt("georeference", geo);
  }
  const nlohmann::json* material = reader.raw("material");
  if (material != nullptr && reader.ok()) {
    Result<Material> parsed = parse_material(*material, "/material");
    if (!parsed) return parsed.error();
    scene.material = *parsed;
  }
  definitions_ = reader.raw("definitions");
  if (definitions_ != nullptr && !definitions_->is_object()) {
    reader.fail("must be an object mapping names to nodes", "definitions");
  }
  const nlohmann::json* root = reader.raw("root");
  if (root == nullptr) reader.fail("is required", "root");
  const nlohmann::json* water = reader.raw("water");
  reader.reject_unknown();
  if (!reader.ok()) return reader.error();

  context_.scene_seed = scene.seed;
  context_.base_elevation = scene.base_elevation;
  Result<ParsedNode> parsed_root = parse_node(*root, "/root", 1);
  if (!parsed_root) return parsed_root.error();
  // Definitions parsed below that the root does not use make no water.
  const std::vector<NodePtr> root_water_layers = std::move(context_.water_layers);
  context_.water_layers.clear();

  nlohmann::json canonical = reader.canonical();
  // Written only when it draws differently from the defaults: an explicit default material
  // is the same scene, with the same hash.
  if (!same_material(scene.material, Material{}))
    canonical["material"] = material_json(scene.material);
  if (definitions_ != nullptr) {
    // Every definition must be valid, referenced or not: nothing unchecked is stored.
    nlohmann::json defs = nlohmann::json::object();
    for (const auto& [name, value] : definitions_->items()) {
      Result<ParsedNode> def = resolve(name, pointer_join("/definitions", name), 1);
      if (!def) return def.error();
      defs[name] = def->canonical;
      scene.definitions.emplace(name, def->node);
    }
    canonical["definitions"] = std::move(defs);
  }
  canonical["root"] = parsed_root->canonical;
  scene.root = parsed_root->node;
  scene.bounds = tree_bounds(*scene.root, {});
  if (water != nullptr) {
    context_.in_water_tree = true;
    Result<ParsedNode> parsed_water = parse_node(*water, "/water", 1);
    context_.in_water_tree = false;
    if (!parsed_water) return parsed_water.error();
    canonical["water"] = parsed_water->canonical;
    scene.water = parsed_water->node;
  }
  // The terrain's own water (a drainage's rivers and lakes) over the authored layer, each later
  // one over the earlier where it is.
  for (const NodePtr& layer : root_water_layers) {
    if (!scene.water) {
      scene.water = layer;
      continue;
    }
    auto over = std::make_shared<Node>();
    over->type = &replace_node_type();
    over->params.pool = {1.0f};  // weight "progressive": wet where either layer is
    over->children = {scene.water, layer};
    scene.water = std::move(over);
  }
  if (scene.water) scene.water_bounds = tree_bounds(*scene.water, {});
  scene.canonical = std::move(canonical);
  scene.hash = "sha256:" + sha256_hex(scene.canonical_text());
  scene.baked = !context_.unbaked;
  return scene;
}

}  // namespace

Result<Scene> parse_scene(const nlohmann::json& document, const ParseOptions& options) {
  SceneParser parser(document, options);
  return parser.parse();
}

Result<Scene> load_scene_file(const std::string& path, ParseOptions options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{"cannot read " + path, ""};
  std::stringstream text;
  text << in.rdbuf();
  if (!options.images) {
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    options.images = [folder](std::string_view reference) -> Result<Raster> {
      return read_heightfield((folder / std::string(reference)).string());
    };
  }
  return parse_scene_text(text.str(), options);
}

Result<Scene> parse_scene_text(std::string_view text, const ParseOptions& options) {
  Result<nlohmann::json> document = parse_json_text(text, "the scene");
  if (!document) return document.error();
  return parse_scene(*document, options);
}

}  // namespace terrain
