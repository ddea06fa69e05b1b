// Follows the base network's rivers (BaseMesh::downstream) for the tests that check them.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>

#include "planet/base_mesh.hpp"

namespace planet::test {

/// Walks downstream from vertex v, expecting the water to fall at every step and the river bed
/// with it until the river reaches a lake (a lake lowers its shore, and a deep river's bed may
/// lie under it). Returns the vertex the river ends at: a mouth on the coast, a lake vertex
/// (lakes are placed on the finished mesh and end the rivers that reach them), or a sink.
inline std::size_t follow_river(const BaseMesh& mesh, std::size_t v) {
  const auto& vertices = mesh.hierarchy.vertices;
  std::size_t at = v;
  for (int steps = 0; mesh.downstream[at] >= 0 && (vertices[at].flags & kLake) == 0; ++steps) {
    const auto next = static_cast<std::size_t>(mesh.downstream[at]);
    EXPECT_LT(vertices[next].water, vertices[at].water) << "water must fall downstream of " << at;
    if ((vertices[next].flags & kLake) == 0) {
      EXPECT_LT(vertices[next].ground, vertices[at].ground) << "and so must the river bed";
    }
    if (steps > 100000 || vertices[next].water >= vertices[at].water) {
      ADD_FAILURE() << "the river from " << v << " does not end";
      return at;
    }
    at = next;
  }
  return at;
}

}  // namespace planet::test
