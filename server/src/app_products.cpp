// The product pipeline: memory cache, shared caches (disk, Redis), cheap reuse, then the making
// on the generation pool, whose result every cache keeps. Scene and planet tiles and meshes,
// pictures and trace bundles all take it, so a change to how products are cached is made once.
#include <chrono>

#include "app_http.hpp"

namespace server {

namespace {

// What /metrics counts a backend as: "gpu: <device>", "cpu (fallback: …)" and plain "cpu".
std::string_view backend_class(std::string_view backend) {
  if (backend.starts_with("gpu")) return "gpu";
  if (backend.starts_with("cpu (fall")) return "cpu-fallback";
  return "cpu";
}

}  // namespace

Outcome App::serve_product(ProductJob job) {
  if (auto hit = cache_.find(job.key)) return job.respond(job.reply, hit);
  if (auto hit = find_shared(job.key)) {
    cache_.insert(job.key, hit);
    return job.respond(job.reply, hit);
  }
  if (job.reuse) {
    if (auto reused = job.reuse()) {
      cache_.insert(job.key, reused);
      return job.respond(job.reply, reused);
    }
  }
  Deferred deferred;
  deferred.cost = job.cost;
  deferred.lane = job.lane;
  deferred.work = [this, job = std::move(job), abandoned = deferred.abandoned]() -> Response {
    const auto start = std::chrono::steady_clock::now();
    terrain::Result<CachedProduct, Response> made = job.make(*abandoned);
    if (!made) return made.error();
    auto product = std::make_shared<CachedProduct>(std::move(made).value());
    if (product->backend.empty()) product->backend = "cpu";
    metrics_.generation(
        job.metric, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
        backend_class(product->backend));
    product->etag = detail::product_etag(product->body);
    product->file = SealedFile::create(product->body);
    cache_.insert(job.key, product);
    store_shared(job.key, *product);
    return job.respond(job.reply, product);
  };
  return deferred;
}

}  // namespace server
