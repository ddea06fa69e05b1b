// Property checks shared by the node-type and example-scene tests: gradients against central
// differences, Lipschitz and range bounds against sampled data, compiled program against tree.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "terrain/evaluate.hpp"
#include "terrain/program.hpp"
#include "terrain/scene.hpp"

namespace terrain::testing {

inline Scene parse_or_die(const std::string& text, const ParseOptions& options = {}) {
  Result<Scene> scene = parse_scene_text(text, options);
  EXPECT_TRUE(scene.ok()) << (scene.ok() ? ""
                                         : scene.error().pointer + ": " + scene.error().message);
  if (!scene.ok()) throw std::runtime_error("scene did not parse");
  return std::move(scene).value();
}

inline Program compile_or_die(const Scene& scene, const CompileOptions& options = {}) {
  Result<Program> program = compile(scene, options);
  EXPECT_TRUE(program.ok());
  if (!program.ok()) throw std::runtime_error("scene did not compile");
  return std::move(program).value();
}

/// The box sampled by the checks: the scene's support, widened so outside points are seen too.
inline Box2 sampling_box(const Scene& scene) {
  const Box2 area = scene.area();
  const Vec2 s = area.size();
  return area.expanded(0.15f * std::max(s.x, s.y));
}

inline Vec2 random_point(std::mt19937& rng, const Box2& box) {
  std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y);
  return {ux(rng), uy(rng)};
}

/// Central differences agree with the analytic gradient at (nearly) every sampled point; kinks
/// (ridged noise creases, clamped weights) may disagree on a small fraction.
inline void expect_gradients_match(const Scene& scene, int samples, float spacing = 0.0f) {
  const Program program = compile_or_die(scene);
  Evaluator e(program);
  std::mt19937 rng(12345);
  const Box2 box = sampling_box(scene);
  const float h = 0.02f;
  int mismatches = 0;
  for (int k = 0; k < samples; ++k) {
    const Vec2 p = random_point(rng, box);
    const FieldSample s = e.sample(p, spacing);
    const FieldSample xp = e.sample({p.x + h, p.y}, spacing),
                      xm = e.sample({p.x - h, p.y}, spacing);
    const FieldSample yp = e.sample({p.x, p.y + h}, spacing),
                      ym = e.sample({p.x, p.y - h}, spacing);
    const float fdx = (xp.elevation - xm.elevation) / (2 * h);
    const float fdy = (yp.elevation - ym.elevation) / (2 * h);
    const float adx = (xp.weight - xm.weight) / (2 * h);
    const float ady = (yp.weight - ym.weight) / (2 * h);
    const float scale = 1.0f + std::abs(s.elevation) * 1e-4f / h;  // float rounding of f
    const bool f_ok =
        std::abs(fdx - s.elevation_gradient.x) <= 0.02f * scale + 0.02f * std::abs(fdx) &&
        std::abs(fdy - s.elevation_gradient.y) <= 0.02f * scale + 0.02f * std::abs(fdy);
    const bool a_ok = std::abs(adx - s.weight_gradient.x) <= 1e-3f + 0.02f * std::abs(adx) &&
                      std::abs(ady - s.weight_gradient.y) <= 1e-3f + 0.02f * std::abs(ady);
    if (!f_ok || !a_ok) ++mismatches;
  }
  EXPECT_LE(mismatches, samples / 50) << "gradient mismatches in " << scene.name;
}

/// Sampled slopes never exceed the Lipschitz bounds, globally and over random boxes from half a
/// metre (where bounds come from each octave's own slope) to a fifth of the scene, at full and
/// at coarse detail; values stay in their ranges; α vanishes outside the support.
inline void expect_bounds_hold(const Scene& scene, int boxes, int pairs_per_box) {
  const Program program = compile_or_die(scene);
  Evaluator e(program);
  std::mt19937 rng(777);
  const Box2 region = sampling_box(scene);
  const NodeBounds global = e.bounds({Box2::everywhere(), 0.0f});
  // The program's global bound (the maximum over a partition of the plane) is sound too.
  EXPECT_LE(program.bounds.elevation_lipschitz, global.elevation_lipschitz * 1.0001f + 1e-6f);
  const float extent = std::max(region.size().x, region.size().y);
  std::uniform_real_distribution<float> log_size(std::log(0.5f), std::log(0.2f * extent));
  for (int b = 0; b < boxes; ++b) {
    const Vec2 c = random_point(rng, region);
    const float half = std::exp(log_size(rng));
    const Box2 box = Box2::around(c, half);
    // One box in three at a coarse level of detail (octaves dropped by the sample spacing).
    const float spacing = b % 3 == 2 ? 0.05f * half : 0.0f;
    const NodeBounds local = e.bounds({box, spacing});
    EXPECT_LE(local.elevation_lipschitz, global.elevation_lipschitz * 1.0001f + 1e-6f);
    for (int k = 0; k < pairs_per_box; ++k) {
      const Vec2 p = random_point(rng, box);
      const Vec2 q = random_point(rng, box);
      const FieldSample sp = e.sample(p, spacing), sq = e.sample(q, spacing);
      const float d = length(p - q);
      const float tol = 1e-4f * (1.0f + std::abs(sp.elevation));
      ASSERT_LE(std::abs(sp.elevation - sq.elevation), local.elevation_lipschitz * d * 1.001f + tol)
          << scene.name << ": slope bound over box broken at (" << p.x << ", " << p.y << ")";
      ASSERT_LE(std::abs(sp.weight - sq.weight), local.weight_lipschitz * d * 1.001f + 1e-5f)
          << scene.name << ": weight slope bound broken";
      ASSERT_LE(length(sp.elevation_gradient), local.elevation_lipschitz * 1.001f + 1e-4f)
          << scene.name << ": |∇f| above the local bound at (" << p.x << ", " << p.y << ")";
      ASSERT_LE(length(sp.elevation_gradient), program.bounds.elevation_lipschitz * 1.001f + 1e-4f)
          << scene.name << ": |∇f| above the global bound at (" << p.x << ", " << p.y << ")";
      ASSERT_GE(sp.elevation, local.elevation.lo - tol) << scene.name;
      ASSERT_LE(sp.elevation, local.elevation.hi + tol) << scene.name;
      ASSERT_GE(sp.weight, -1e-6f);
      if (!global.support.contains(p)) {
        ASSERT_EQ(sp.weight, 0.0f) << scene.name << ": weight outside the support";
      }
    }
  }
}

/// The compiled program (culling, BVH, concatenated transforms) equals the tree evaluator.
inline void expect_program_equals_tree(const Scene& scene, int samples, float spacing = 0.0f) {
  const Program program = compile_or_die(scene);
  Evaluator e(program);
  std::mt19937 rng(99);
  const Box2 box = sampling_box(scene);
  for (int k = 0; k < samples; ++k) {
    const Vec2 p = random_point(rng, box);
    const FieldSample a = e.sample(p, spacing);
    const FieldSample b = evaluate_tree(scene, p, spacing);
    const float tol = 1e-4f * (1.0f + std::abs(b.elevation));
    ASSERT_NEAR(a.elevation, b.elevation, tol) << scene.name << " at " << p.x << ", " << p.y;
    ASSERT_NEAR(a.weight, b.weight, 1e-5f);
    ASSERT_NEAR(a.elevation_gradient.x, b.elevation_gradient.x,
                5e-3f * (1 + std::abs(b.elevation_gradient.x)));
    ASSERT_NEAR(a.elevation_gradient.y, b.elevation_gradient.y,
                5e-3f * (1 + std::abs(b.elevation_gradient.y)));
  }
}

/// A point's field does not depend on how points are grouped into blocks (kernels pick dense or
/// packed paths per block, and neighbouring tiles must agree on shared samples bit for bit): the
/// same bits for a point alone, in 8×8 blocks of a grid, in blocks offset by a few rows and
/// columns, and in blocks of points scattered over the whole grid.
inline void expect_block_layout_independent(const Scene& scene, float spacing) {
  const Program program = compile_or_die(scene);
  Evaluator e(program);
  const Box2 box = sampling_box(scene);
  constexpr int kSide = 48;  // coarse enough to cross every feature, fine enough for its edges
  std::vector<Vec2> points;
  for (int j = 0; j < kSide; ++j) {
    for (int i = 0; i < kSide; ++i) {
      points.push_back({box.lo.x + box.size().x * static_cast<float>(i) / (kSide - 1),
                        box.lo.y + box.size().y * static_cast<float>(j) / (kSide - 1)});
    }
  }
  std::vector<FieldSample> alone;
  for (const Vec2& p : points) alone.push_back(e.sample(p, spacing));
  const auto bits = [](float v) { return std::bit_cast<std::uint32_t>(v); };
  const auto check = [&](const std::vector<int>& members, const char* layout) {
    PointBlock block;
    block.count = static_cast<int>(members.size());
    block.spacing = spacing;
    for (int k = 0; k < block.count; ++k) {
      block.x[k] = points[static_cast<std::size_t>(members[static_cast<std::size_t>(k)])].x;
      block.y[k] = points[static_cast<std::size_t>(members[static_cast<std::size_t>(k)])].y;
    }
    block.recompute_box();
    FieldBlock out;
    e.evaluate(block, out);
    for (int k = 0; k < block.count; ++k) {
      const FieldSample& a = alone[static_cast<std::size_t>(members[static_cast<std::size_t>(k)])];
      const FieldSample b = out.at(k);
      ASSERT_TRUE(bits(a.elevation) == bits(b.elevation) && bits(a.weight) == bits(b.weight) &&
                  bits(a.elevation_gradient.x) == bits(b.elevation_gradient.x) &&
                  bits(a.elevation_gradient.y) == bits(b.elevation_gradient.y) &&
                  bits(a.weight_gradient.x) == bits(b.weight_gradient.x) &&
                  bits(a.weight_gradient.y) == bits(b.weight_gradient.y))
          << scene.name << ": " << layout << " block changes the field at (" << block.x[k] << ", "
          << block.y[k] << ")";
    }
  };
  for (const int offset : {0, 3}) {
    for (int by = -offset; by < kSide; by += 8) {
      for (int bx = -offset; bx < kSide; bx += 8) {
        std::vector<int> members;
        for (int j = std::max(by, 0); j < std::min(by + 8, kSide); ++j) {
          for (int i = std::max(bx, 0); i < std::min(bx + 8, kSide); ++i) {
            members.push_back(j * kSide + i);
          }
        }
        if (!members.empty()) check(members, offset == 0 ? "grid" : "offset grid");
      }
    }
  }
  const int blocks = (kSide * kSide + kBlockSize - 1) / kBlockSize;
  for (int b = 0; b < blocks; ++b) {
    std::vector<int> members;
    for (int k = b; k < kSide * kSide; k += blocks) members.push_back(k);
    check(members, "scattered");
  }
}

}  // namespace terrain::testing
