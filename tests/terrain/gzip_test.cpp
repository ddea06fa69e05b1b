// gzip: round trips, deterministic headers, the output limit and refusal of malformed input.
#include "terrain/gzip.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace terrain {
namespace {

std::vector<std::uint8_t> random_bytes(std::size_t size, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::uint8_t> out(size);
  for (auto& b : out) b = static_cast<std::uint8_t>(rng() % 7);  // compressible
  return out;
}

std::vector<std::uint8_t> compress(std::span<const std::uint8_t> data, int level = 6) {
  auto r = gzip_compress(data, level);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(r).value() : std::vector<std::uint8_t>{};
}

TEST(Gzip, RoundTripsBytesOfEverySize) {
  // 3 MiB crosses zlib's feeding pieces (1 MiB) and the 32 KiB output buffer many times.
  for (const std::size_t size :
       {std::size_t{0}, std::size_t{1}, std::size_t{1000}, std::size_t{3} << 20}) {
    for (const int level : {0, 1, 6, 9}) {
      if (size > 1000 && level > 1) continue;  // slow and adds nothing
      const auto data =
          random_bytes(size, static_cast<unsigned>(size) + static_cast<unsigned>(level));
      const auto packed = compress(data, level);
      auto unpacked = gzip_decompress(packed, size);
      ASSERT_TRUE(unpacked.ok()) << unpacked.error().message;
      EXPECT_EQ(*unpacked, data) << "size " << size << ", level " << level;
    }
  }
}

TEST(Gzip, RoundTripsText) {
  const std::string json = R"({"tilejson":"2.1.0","format":"quantized-mesh-1.0"})";
  auto packed = gzip_compress(json);
  ASSERT_TRUE(packed.ok());
  auto unpacked = gzip_decompress(*packed, 1000);
  ASSERT_TRUE(unpacked.ok());
  EXPECT_EQ(std::string(unpacked->begin(), unpacked->end()), json);
}

TEST(Gzip, OutputIsDeterministicWithZeroTimeAndFixedOsByte) {
  const auto data = random_bytes(50000, 3);
  const auto a = compress(data);
  const auto b = compress(data);
  EXPECT_EQ(a, b);
  ASSERT_GE(a.size(), 18u);
  EXPECT_EQ(a[0], 0x1f);  // magic
  EXPECT_EQ(a[1], 0x8b);
  EXPECT_EQ(a[2], 8);                       // deflate
  EXPECT_EQ(a[3], 0);                       // no name, comment, extra or header CRC
  EXPECT_EQ(a[4] | a[5] | a[6] | a[7], 0);  // mtime
  EXPECT_EQ(a[9], gzip_os_byte);
}

TEST(Gzip, DecompressStopsAtTheOutputLimit) {
  const std::vector<std::uint8_t> zeros(1 << 20, 0);
  const auto packed = compress(zeros, 9);
  EXPECT_LT(packed.size(), 2000u);  // a million zeros: a small bomb
  EXPECT_TRUE(gzip_decompress(packed, zeros.size()).ok());
  auto limited = gzip_decompress(packed, zeros.size() - 1);
  ASSERT_FALSE(limited.ok());
  EXPECT_NE(limited.error().message.find("limit"), std::string::npos);
}

TEST(Gzip, RefusesMalformedInput) {
  const auto data = random_bytes(20000, 5);
  const auto packed = compress(data);

  EXPECT_FALSE(gzip_compress(data, 10).ok());
  EXPECT_FALSE(gzip_compress(data, -1).ok());

  EXPECT_FALSE(gzip_decompress({}, 100).ok());
  const std::string text = "not gzip at all";
  EXPECT_FALSE(gzip_decompress(
                   std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), 100)
                   .ok());
  for (const std::size_t cut :
       {std::size_t{5}, std::size_t{10}, packed.size() / 2, packed.size() - 4, packed.size() - 1}) {
    auto r = gzip_decompress(std::span(packed.data(), cut), data.size());
    EXPECT_FALSE(r.ok()) << "truncated to " << cut;
  }
  auto corrupt_crc = packed;
  corrupt_crc[corrupt_crc.size() - 6] ^= 0x40;
  EXPECT_FALSE(gzip_decompress(corrupt_crc, data.size()).ok());
  auto corrupt_length = packed;
  corrupt_length[corrupt_length.size() - 2] ^= 0x01;
  EXPECT_FALSE(gzip_decompress(corrupt_length, data.size()).ok());
  auto trailing = packed;
  trailing.push_back(0);
  EXPECT_FALSE(gzip_decompress(trailing, data.size()).ok());

  // Arbitrary damage is refused or decoded, never a crash or an overrun of the limit.
  std::mt19937 rng(9);
  for (int trial = 0; trial < 200; ++trial) {
    auto damaged = packed;
    damaged[10 + rng() % (damaged.size() - 10)] ^= static_cast<std::uint8_t>(1 + rng() % 255);
    auto r = gzip_decompress(damaged, data.size());
    if (r.ok()) {
      EXPECT_LE(r->size(), data.size());
    }
  }
}

}  // namespace
}  // namespace terrain
