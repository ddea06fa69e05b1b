#include "nodes/skeleton_spec.hpp"

#include <cmath>
#include <vector>

namespace terrain {

Result<Polyline> read_skeleton(FieldReader& reader) {
  std::vector<CurvePiece> pieces;
  const nlohmann::json* raw_pieces = reader.raw("pieces");
  nlohmann::json canonical_pieces = nlohmann::json::array();
  if (raw_pieces == nullptr || !raw_pieces->is_array() || raw_pieces->empty()) {
    reader.fail("must be a non-empty array of pieces, each 2 to 4 points [x, y, z]", "pieces");
    return reader.error();
  }
  for (std::size_t i = 0; i < raw_pieces->size(); ++i) {
    const nlohmann::json& piece = (*raw_pieces)[i];
    const std::string at = pointer_join(reader.pointer() + "/pieces", i);
    if (!piece.is_array() || piece.size() < 2 || piece.size() > 4) {
      return Error{"a piece is 2 (segment), 3 (quadratic) or 4 (cubic) points", at};
    }
    CurvePiece parsed;
    nlohmann::json canonical_piece = nlohmann::json::array();
    for (std::size_t k = 0; k < piece.size(); ++k) {
      const nlohmann::json& p = piece[k];
      bool valid = p.is_array() && p.size() == 3;
      for (std::size_t c = 0; valid && c < 3; ++c) {
        valid = p[c].is_number() && std::isfinite(p[c].get<double>()) &&
                std::abs(p[c].get<double>()) <= 1e7;
      }
      if (!valid) return Error{"must be a point [x, y, z] of finite numbers", pointer_join(at, k)};
      parsed.points.push_back({static_cast<float>(p[0].get<double>()),
                               static_cast<float>(p[1].get<double>()),
                               static_cast<float>(p[2].get<double>())});
      canonical_piece.push_back({p[0].get<double>(), p[1].get<double>(), p[2].get<double>()});
    }
    pieces.push_back(std::move(parsed));
    canonical_pieces.push_back(std::move(canonical_piece));
  }
  reader.canonical()["pieces"] = std::move(canonical_pieces);
  PolylineOptions polyline_options;
  polyline_options.tolerance = static_cast<float>(reader.number("tolerance", 0.02, {0.001, 100.0}));
  if (!reader.ok()) return reader.error();
  Result<Polyline> polyline = Polyline::build(pieces, polyline_options);
  if (!polyline) {
    return Error{polyline.error().message, reader.pointer() + polyline.error().pointer};
  }
  return polyline;
}

}  // namespace terrain
