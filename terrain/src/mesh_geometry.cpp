// Tile meshes resolved to scene coordinates, and skirts.
#include "terrain/mesh_geometry.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <unordered_set>
#include <utility>

namespace terrain {

namespace {

std::string str(std::size_t v) {
  return std::to_string(v);
}

Status check_tile(const HeightTile& tile) {
  if (tile.layout != SampleLayout::cell_corners) {
    return Error{"meshes need the cell_corners layout, whose edge samples neighbours share",
                 "/tile/layout"};
  }
  if (tile.border != 0) return Error{"a cell_corners tile has no border", "/tile/border"};
  if (tile.width < 2 || tile.height != tile.width) {
    return Error{"a tile grid needs at least 2×2 samples and as many rows as columns",
                 "/tile/width"};
  }
  const std::size_t samples = static_cast<std::size_t>(tile.width) * tile.width;
  const std::pair<std::size_t, const char*> arrays[] = {{tile.elevation.size(), "elevation"},
                                                        {tile.slope_east.size(), "slope_east"},
                                                        {tile.slope_north.size(), "slope_north"},
                                                        {tile.scene_x.size(), "scene_x"},
                                                        {tile.scene_y.size(), "scene_y"}};
  for (const auto& [size, name] : arrays) {
    if (size != samples) {
      return Error{std::string(name) + " has " + str(size) + " samples, the " +
                       std::to_string(tile.width) + "×" + std::to_string(tile.width) +
                       " grid needs " + str(samples),
                   "/tile/" + std::string(name)};
    }
  }
  return Ok{};
}

Status check_mesh(const TileMesh& mesh, int grid_size) {
  if (mesh.grid_size != grid_size) {
    return Error{"the mesh triangulates a " + std::to_string(mesh.grid_size) +
                     "-sample grid, the tile has " + std::to_string(grid_size),
                 "/mesh/grid_size"};
  }
  if (mesh.triangles.empty() || mesh.vertices.empty()) {
    return Error{"the mesh has no triangles", "/mesh/triangles"};
  }
  if (mesh.triangles.size() % 3 != 0) {
    return Error{
        "the triangle list has " + str(mesh.triangles.size()) + " indices, not a multiple of 3",
        "/mesh/triangles"};
  }
  const std::size_t samples = static_cast<std::size_t>(grid_size) * grid_size;
  std::vector<bool> seen(samples, false);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const std::uint32_t v = mesh.vertices[i];
    if (v >= samples) {
      return Error{"grid index " + str(v) + " is outside the " + str(samples) + "-sample grid",
                   "/mesh/vertices/" + str(i)};
    }
    if (seen[v])
      return Error{"grid index " + str(v) + " is listed twice", "/mesh/vertices/" + str(i)};
    seen[v] = true;
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    if (mesh.triangles[i] >= mesh.vertices.size()) {
      return Error{"vertex " + str(mesh.triangles[i]) + " does not exist (the mesh has " +
                       str(mesh.vertices.size()) + ")",
                   "/mesh/triangles/" + str(i)};
    }
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); t += 3) {
    const std::uint32_t a = mesh.triangles[t], b = mesh.triangles[t + 1], c = mesh.triangles[t + 2];
    if (a == b || b == c || c == a) {
      return Error{"triangle " + str(t / 3) + " repeats a vertex", "/mesh/triangles/" + str(t)};
    }
  }
  return Ok{};
}

}  // namespace

std::array<float, 3> normal_from_slopes(float slope_east, float slope_north) {
  const double sx = slope_east, sy = slope_north;
  const double length = std::sqrt(sx * sx + sy * sy + 1.0);
  return {static_cast<float>(-sx / length), static_cast<float>(-sy / length),
          static_cast<float>(1.0 / length)};
}

Result<MeshGeometry> mesh_geometry(const HeightTile& tile, const TileMesh& mesh) {
  if (Status s = check_tile(tile); !s) return s.error();
  if (Status s = check_mesh(mesh, tile.width); !s) return s.error();
  MeshGeometry g;
  g.positions.reserve(mesh.vertices.size());
  g.normals.reserve(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const std::uint32_t s = mesh.vertices[i];
    const double x = tile.scene_x[s], y = tile.scene_y[s];
    const float h = tile.elevation[s], sx = tile.slope_east[s], sy = tile.slope_north[s];
    const std::pair<double, const char*> values[] = {
        {x, "scene_x"}, {y, "scene_y"}, {h, "elevation"}, {sx, "slope_east"}, {sy, "slope_north"}};
    for (const auto& [value, name] : values) {
      if (!std::isfinite(value)) {
        return Error{
            std::string(name) + " of sample " + str(s) + " (vertex " + str(i) + ") is not finite",
            "/tile/" + std::string(name) + "/" + str(s)};
      }
    }
    g.positions.push_back({x, y, static_cast<double>(h)});
    g.normals.push_back(normal_from_slopes(sx, sy));
  }
  g.triangles = mesh.triangles;
  g.samples = mesh.vertices;
  g.surface_vertices = static_cast<std::uint32_t>(mesh.vertices.size());
  return g;
}

Status add_skirts(MeshGeometry& g, double skirt_height) {
  if (!std::isfinite(skirt_height) || skirt_height < 0.0) {
    return Error{"skirt height must be a finite number of metres, at least 0", "/skirt_height"};
  }
  if (g.triangles.size() % 3 != 0 || g.normals.size() != g.positions.size() ||
      g.samples.size() != g.positions.size()) {
    return Error{"positions, normals, samples and triangles do not match in size", ""};
  }
  const auto edge = [](std::uint32_t from, std::uint32_t to) {
    return (static_cast<std::uint64_t>(from) << 32) | to;
  };
  // A boundary edge is one whose reverse no triangle uses; with consistent orientation each
  // directed edge occurs once, and the interior lies to its left (CCW seen from above).
  std::unordered_set<std::uint64_t> directed;
  directed.reserve(g.triangles.size());
  for (std::size_t i = 0; i < g.triangles.size(); ++i) {
    const std::uint32_t a = g.triangles[i], b = g.triangles[i - i % 3 + (i + 1) % 3];
    if (a >= g.positions.size()) {
      return Error{"vertex " + str(a) + " does not exist", "/triangles/" + str(i)};
    }
    if (!directed.insert(edge(a, b)).second) {
      return Error{"triangles are not consistently oriented: edge " + str(a) + "→" + str(b) +
                       " is used twice in the same direction",
                   "/triangles/" + str(i)};
    }
  }
  if (skirt_height == 0.0) return Ok{};
  constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> lowered(g.positions.size(), none);
  const auto lower = [&](std::uint32_t v) {
    if (lowered[v] == none) {
      lowered[v] = static_cast<std::uint32_t>(g.positions.size());
      const std::array<double, 3> p = g.positions[v];
      g.positions.push_back({p[0], p[1], p[2] - skirt_height});
      g.normals.push_back(g.normals[v]);
      g.samples.push_back(g.samples[v]);
    }
    return lowered[v];
  };
  const std::size_t surface_indices = g.triangles.size();
  for (std::size_t i = 0; i < surface_indices; ++i) {
    const std::uint32_t a = g.triangles[i], b = g.triangles[i - i % 3 + (i + 1) % 3];
    if (directed.count(edge(b, a)) != 0) continue;
    const std::uint32_t la = lower(a), lb = lower(b);
    // a→b has the outside on its right: (a, a', b) and (b, a', b') wind CCW seen from outside.
    g.triangles.insert(g.triangles.end(), {a, la, b, b, la, lb});
  }
  return Ok{};
}

}  // namespace terrain
