// The planet's noise four lanes at a time (planet/src/detail_batch.hpp) against the scalar noise
// it must equal bit for bit: the relief regions' three fields and the fractal detail are
// evaluated in AVX2 lanes where the CPU has them, and a tile's bytes may not depend on that.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "detail_batch.hpp"
#include "gradient_noise.hpp"

namespace planet::detail {
namespace {

// Coordinates spanning the cells a region field meets (tens of cells), the detail's finest
// octaves (millions) and beyond 2^50, where the lanes hand over to the scalar noise.
std::vector<double> coordinates() {
  std::mt19937_64 random(20261206);
  std::vector<double> out;
  for (const double span : {3.0, 40.0, 1e6, 0x1p49, 0x1p51}) {
    std::uniform_real_distribution<double> within(-span, span);
    for (int i = 0; i < 64; ++i) out.push_back(within(random));
  }
  out.push_back(0.0);
  out.push_back(-0.0);
  out.push_back(-1.0);  // an integral coordinate: the corner itself
  out.push_back(std::nextafter(1.0, 0.0));
  return out;
}

TEST(GradientLanes, FourSeedsGiveTheBitsOfFourCalls) {
  const std::vector<double> c = coordinates();
  std::mt19937 random(7);
  int compared = 0;
  for (std::size_t i = 0; i + 12 <= c.size(); i += 3) {
    Four x{}, y{}, z{};
    FourSeeds seed{};
    for (std::size_t lane = 0; lane < 4; ++lane) {
      // Lanes from different spans, so that a large coordinate in one lane sends them all down
      // the scalar path as well as not.
      x[lane] = c[(i + 7 * lane) % c.size()];
      y[lane] = c[(i + 7 * lane + 1) % c.size()];
      z[lane] = c[(i + 7 * lane + 2) % c.size()];
      seed[lane] = static_cast<std::uint32_t>(random());
    }
    const Four lanes = gradient3_fours(x, y, z, seed);
    for (std::size_t lane = 0; lane < 4; ++lane) {
      const double one = gradient3(x[lane], y[lane], z[lane], seed[lane]);
      ASSERT_EQ(std::bit_cast<std::uint64_t>(lanes[lane]), std::bit_cast<std::uint64_t>(one))
          << "lane " << lane << " at (" << x[lane] << ", " << y[lane] << ", " << z[lane] << ")";
      ++compared;
    }
  }
  EXPECT_GT(compared, 300);
}

TEST(GradientLanes, DetailSumsGiveTheBitsOfOneByOne) {
  std::mt19937_64 random(42);
  std::normal_distribution<double> normal;
  std::vector<Vec3d> directions(103);  // not a multiple of four: the last ones go one by one
  for (Vec3d& d : directions) d = normalize({normal(random), normal(random), normal(random)});
  DetailOctaves plan;
  plan.first = 2;
  plan.octaves = 11.4;  // the last octave faded in
  plan.amplitude = 120.0;
  plan.frequency = 6371000.0 / 2000.0;
  plan.seed = 99;
  std::vector<double> together(directions.size());
  detail_sums(plan, directions.data(), directions.size(), together.data());
  for (std::size_t i = 0; i < directions.size(); ++i) {
    ASSERT_EQ(std::bit_cast<std::uint64_t>(together[i]),
              std::bit_cast<std::uint64_t>(detail_sum(plan, directions[i])))
        << "direction " << i;
  }
}

}  // namespace
}  // namespace planet::detail
