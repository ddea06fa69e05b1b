// Product goldens: the SHA-256 of products' bytes, kept in a JSON file beside the test with the
// product generation (terrain::kProductGeneration) that made them. A test compares what the code
// makes now with the file; scripts/accept-product-goldens.sh rewrites the file, and refuses new
// hashes of existing products under the generation already recorded, since servers of one
// generation must make the same bytes (shared caches and ETags carry the generation). The file
// also records the content hash of each product's input (the scene or planet): a product of an
// input that changed is a new product (new versions, new URLs and cache keys), accepted under
// any generation.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "terrain/scene.hpp"
#include "terrain/tile_products.hpp"

namespace terrain::testing {

/// Product name ("butte/local-1-0-0.png?encoding=terrarium") → SHA-256 of its bytes.
using ProductHashes = std::map<std::string, std::string>;

/// Input name ("butte", the products' names up to their first '/') → its content hash (a
/// scene's "sha256:…", a planet's id).
using InputHashes = std::map<std::string, std::string>;

/// The input a product is made from: its name up to the first '/'.
inline std::string input_of(const std::string& product) {
  return product.substr(0, product.find('/'));
}

/// "local-1-0-0.png?encoding=terrarium": a product's name in the golden files.
inline std::string product_name(TileScheme scheme, const TileAddress& a,
                                const TileFormatInfo& info) {
  std::string name = std::string(scheme_name(scheme)) + "-" + std::to_string(a.z) + "-" +
                     std::to_string(a.x) + "-" + std::to_string(a.y) + "." +
                     std::string(info.extension);
  if (!info.encoding.empty()) name += "?encoding=" + std::string(info.encoding);
  return name;
}

inline std::string hash_of(const std::vector<std::uint8_t>& bytes) {
  return sha256_hex(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

/// Compares `made` with the golden file, or, when TERRAIN_ACCEPT_GOLDENS is set, writes it.
inline void check_product_goldens(const std::string& file, const InputHashes& inputs,
                                  const ProductHashes& made) {
  nlohmann::json golden = nlohmann::json::object();
  if (std::ifstream in(file); in) golden = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(golden.is_discarded()) << file << " is not JSON";
  const int recorded = golden.value("generation", 0);
  const nlohmann::json hashes = golden.value("products", nlohmann::json::object());
  const nlohmann::json recorded_inputs = golden.value("inputs", nlohmann::json::object());
  for (const auto& [name, hash] : made) {
    ASSERT_TRUE(inputs.contains(input_of(name))) << name << ": its input has no hash";
  }

  // Changed bytes of an unchanged input need a new generation; a changed input explains them.
  std::ostringstream changed, changed_input;
  for (const auto& [name, hash] : made) {
    if (!hashes.contains(name) || hashes[name] == hash) continue;
    const std::string& input = input_of(name);
    const bool same_input = recorded_inputs.value(input, "") == inputs.at(input);
    (same_input ? changed : changed_input) << "\n  " << name;
  }
  if (std::getenv("TERRAIN_ACCEPT_GOLDENS") != nullptr) {
    ASSERT_TRUE(changed.str().empty() || recorded != kProductGeneration)
        << "these products' bytes changed under product generation " << recorded
        << ": raise terrain::kProductGeneration (tile_products.hpp), then accept again:"
        << changed.str();
    nlohmann::json out{{"generation", kProductGeneration}, {"inputs", inputs}, {"products", made}};
    std::ofstream(file) << out.dump(2) << "\n";
    return;
  }
  ASSERT_EQ(recorded, kProductGeneration)
      << file << " holds generation " << recorded << "; the code makes generation "
      << kProductGeneration << ": run scripts/accept-product-goldens.sh";
  EXPECT_TRUE(changed.str().empty())
      << "products' bytes changed: raise terrain::kProductGeneration, then run "
         "scripts/accept-product-goldens.sh:"
      << changed.str();
  EXPECT_TRUE(changed_input.str().empty())
      << "these products' scene or planet changed: run scripts/accept-product-goldens.sh:"
      << changed_input.str();
  for (const auto& [name, hash] : made) {
    EXPECT_TRUE(hashes.contains(name)) << name << " has no golden: accept it";
  }
  for (const auto& [name, hash] : hashes.items()) {
    EXPECT_TRUE(made.contains(name)) << name << " is in the goldens but no longer made";
  }
}

}  // namespace terrain::testing
