// GET …/analysis.json: the geomorphometry of a scene version (docs/analysis.md), what
// `terrain analyze` prints, made on the generation pool and cached like every product.
#include "server/app.hpp"

#include <string>

#include <nlohmann/json.hpp>

#include "app_http.hpp"
#include "app_support.hpp"
#include "terrain/scene_analysis.hpp"

namespace server {

using namespace detail;  // NOLINT: the App's own helpers (app_support.hpp, app_http.hpp)

namespace {

/// The server's largest analysis grid: 2048² samples of the scene, a few seconds of one core on
/// the example scenes; the CLI goes to kMaxSceneAnalysisSide.
constexpr int kMaxServedAnalysisSide = 2048;

}  // namespace

Outcome App::scene_analysis(const Request& request, const LoadedVersion& loaded,
                            const Target& target, bool pinned) {
  terrain::SceneAnalysisOptions options;
  const std::optional<int> size = parse_integer<int>(target.get("size", "512"));
  if (!size || *size < 2 || *size > kMaxServedAnalysisSide) {
    return problem(request, http::status::bad_request, "Bad analysis",
                   "size must be an integer from 2 to " + std::to_string(kMaxServedAnalysisSide),
                   "/size");
  }
  options.size = *size;
  if (target.query.contains("sea_level")) {
    const std::optional<double> z = parse_double(target.get("sea_level"));
    if (!z || std::abs(*z) > 1e5) {
      return problem(request, http::status::bad_request, "Bad analysis",
                     "sea_level must be an elevation in metres within ±100000", "/sea_level");
    }
    options.sea_level = static_cast<float>(*z);
  }
  if (target.query.contains("channel_area")) {
    const std::optional<double> a = parse_double(target.get("channel_area"));
    if (!a || !(*a > 0.0) || *a > 1e15) {
      return problem(request, http::status::bad_request, "Bad analysis",
                     "channel_area must be an area in m² greater than 0", "/channel_area");
    }
    options.analysis.channel_area = *a;
  }
  // The body's format is part of the key (kAnalysisFormat): a shared cache may hold another
  // release's analysis of the same scene.
  const std::string key = loaded.version.hash + "|analysis.json|" +
                          std::to_string(terrain::kAnalysisFormat) + "|" +
                          std::to_string(options.size) + "|" + target.get("sea_level", "-") + "|" +
                          target.get("channel_area", "-");
  ProductJob job;
  job.key = key;
  job.reply = ReplyContext::of(request, cache_policy(pinned));
  job.respond = [](const ReplyContext& reply, const std::shared_ptr<const CachedProduct>& p) {
    return json_text_response(reply.shadow(), p->body, reply.cache_control);
  };
  const double samples = static_cast<double>(options.size) * options.size;
  job.cost = static_cast<double>(loaded.source->terrain->code.size()) * samples;
  job.metric = "analysis";
  job.make = [options, reply = job.reply, scene = loaded.scene, source = loaded.source](
                 const std::atomic<bool>&) -> terrain::Result<CachedProduct, Response> {
    terrain::Result<nlohmann::json> analysis =
        terrain::analyze_scene(*scene, *source->terrain, options);
    // The options were checked: what is left is a refusal by kind (a water layer over a limit).
    if (!analysis) return problem(reply.shadow(), "Analysis failed", analysis.error());
    CachedProduct bytes;
    bytes.media_type = "application/json";
    bytes.body = analysis->dump();
    return bytes;
  };
  return serve_product(std::move(job));
}

}  // namespace server
