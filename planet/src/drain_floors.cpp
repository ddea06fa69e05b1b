#include "drain_floors.hpp"

namespace planet::floors {

double floor_by_walk(Hierarchy& hierarchy, std::int32_t leaf, const Vec3d& p, double ground,
                     const FloorShape& shape, std::vector<std::int32_t>& visited) {
  double result = ground;
  visited.clear();
  visited.push_back(leaf);
  for (std::size_t next = 0; next < visited.size(); ++next) {
    const std::int32_t u = visited[next];
    for (std::size_t k = 0; k < 3; ++k) {
      if (k == 0) hierarchy.ensure_partner(u);  // may grow tris: read it afresh below
      const Tri& tri = hierarchy.tris[static_cast<std::size_t>(u)];
      const Vertex& a = hierarchy.vertices[tri.v[k]];
      const Vertex& b = hierarchy.vertices[tri.v[(k + 1) % 3]];
      if (!within_reach(a.p, b.p, p, shape)) continue;
      if (floored_edge(hierarchy, tri, k)) {
        result = std::min(result, lowered(ground, drain_segment(a, b, shape), p, shape));
      }
      const std::int32_t across = tri.nb[k];
      if (across >= 0 && std::find(visited.begin(), visited.end(), across) == visited.end()) {
        visited.push_back(across);
      }
    }
  }
  return result;
}

}  // namespace planet::floors
