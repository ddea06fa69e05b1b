// The one list of node types. Adding a node type: write its header + source pair under nodes/
// and add it here; parsing, serialisation, compilation, the evaluators, the docs examples, the
// property tests and the benchmarks all iterate this list.
#include <algorithm>
#include <array>

#include "nodes/add.hpp"
#include "nodes/blend.hpp"
#include "nodes/contour.hpp"
#include "nodes/curve.hpp"
#include "nodes/disc.hpp"
#include "nodes/drainage.hpp"
#include "nodes/erosion.hpp"
#include "nodes/image.hpp"
#include "nodes/lod.hpp"
#include "nodes/replace.hpp"
#include "nodes/transform.hpp"
#include "nodes/warp.hpp"
#include "terrain/node.hpp"

namespace terrain {

std::span<const NodeType* const> node_types() {
  static const NodeType* const kTypes[] = {
      &disc_node_type(),    &curve_node_type(),    &contour_node_type(),   &image_node_type(),
      &erosion_node_type(), &drainage_node_type(), &blend_node_type(),     &replace_node_type(),
      &add_node_type(),     &lod_node_type(),      &transform_node_type(), &warp_node_type(),
  };
  return kTypes;
}

std::size_t no_loops(std::span<const float>) {
  return 0;
}

const NodeType* node_type_by_id(std::uint16_t id) {
  static const std::array<const NodeType*, 256> kById = [] {
    std::array<const NodeType*, 256> table{};
    for (const NodeType* type : node_types()) table[type->id] = type;
    return table;
  }();
  return id < kById.size() ? kById[id] : nullptr;
}

std::string_view category_name(NodeCategory category) {
  switch (category) {
    case NodeCategory::primitive:
      return "primitive";
    case NodeCategory::blend:
      return "blend";
    case NodeCategory::binary:
      return "binary";
    case NodeCategory::warp:
      return "warp";
  }
  return "unknown";
}

const NodeType* find_node_type(std::string_view name) {
  for (const NodeType* type : node_types()) {
    if (type->name == name) return type;
  }
  return nullptr;
}

}  // namespace terrain
