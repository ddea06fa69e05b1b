// Experiment (docs/analysis.md, "Floors along the drains"; not built by the project): samples a
// 512² square of a planet as `planet analyze` does, draws floors along the drain edges of the
// tile level's leaves onto it, and prints the geomorphometry. Usage and knobs: README.md.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <numbers>
#include <unordered_set>
#include <vector>

#include "planet/planet.hpp"
#include "planet/tiles.hpp"
#include "terrain/drainage.hpp"
#include "terrain/geomorphometry.hpp"
#include <OpenImageIO/imageio.h>

using namespace planet;
static double env(const char* n, double f) { const char* s = std::getenv(n); return s ? std::atof(s) : f; }

// The level at which tile-level edge k of triangle t was born as a drain (walking up halves).
static double born_length(const Hierarchy& h, const Rules& r, std::int32_t t, int k) {
  for (;;) {
    const Tri& tri = h.tris[t];
    if (tri.parent < 0) return r.edge_length(tri.level);
    const Tri& par = h.tris[tri.parent];
    int pk = -1;
    if (tri.which == 0) pk = k == 0 ? 2 : k == 1 ? 0 : -1;
    else pk = k == 0 ? 1 : k == 2 ? 0 : -1;
    if (pk < 0 || par.edge[pk] != EdgeType::drain) return r.edge_length(tri.level);
    t = tri.parent; k = pk;
  }
}

int main(int argc, char** argv) {
  std::ifstream in(argv[1]);
  auto planet = Planet::from_json(nlohmann::json::parse(in));
  if (!planet) { std::puts("bad planet"); return 1; }
  const auto P = *planet;
  const double lat0 = std::atof(argv[2]), lon0 = std::atof(argv[3]);
  const int zoom = std::atoi(argv[4]);
  const int n = 512;
  const double cell = P->ground_spacing(zoom, 256);
  const double R = P->definition().radius, deg = std::numbers::pi / 180, half = 0.5 * (n - 1) * cell;
  const double cosc = std::cos(lat0 * deg);
  std::vector<float> elev(n * n); std::vector<std::uint8_t> sea(n * n), wet(n * n);
  Sampler sampler(P);
  Hierarchy h = P->base_mesh().hierarchy;
  const int L = P->level_for_spacing(cell);
  std::unordered_set<std::int32_t> leaves;
  // The knobs, read once (README.md).
  const double clamp_mode = env("EXP_CLAMP", 0), kmin = env("EXP_KMIN", 4),
               wcells = env("EXP_W", 1.5), sf = env("EXP_SF", 0.002), sfr = env("EXP_SFR", 0),
               wfrac = env("EXP_WFRAC", 0), rr = env("EXP_ROUND", 0), kk = env("EXP_SMIN", 0),
               tau_frac = env("EXP_TAU", 0);
  for (int j = 0; j < n; ++j) for (int i = 0; i < n; ++i) {
    const double lat = lat0 + (-half + j * cell) / R / deg;
    const double lon = lon0 + (-half + i * cell) / (R * cosc) / deg;
    const PointSample s = sampler.sample(lat, lon, cell);
    const int c = j * n + i;
    elev[c] = float(s.ground);
    if (s.type == SurfaceType::sea) sea[c] = 1;
    else if (s.type == SurfaceType::river) wet[c] = terrain::kFlowingWater;
    else if (s.type == SurfaceType::lake) wet[c] = terrain::kStandingWater;
    const std::int32_t lt = h.locate(P->geodesy().direction(lat, lon), L);
    leaves.insert(lt);
    if (clamp_mode > 0 && s.type == SurfaceType::land) {
      const Tri& tr = h.tris[lt];
      double lo = 1e30, hi = -1e30;
      for (int k = 0; k < 3; ++k) { lo = std::min(lo, h.vertices[tr.v[k]].ground); hi = std::max(hi, h.vertices[tr.v[k]].ground); }
      elev[c] = float(std::max<double>(elev[c], lo));
      if (clamp_mode > 1) elev[c] = float(std::min<double>(elev[c], hi));
    }
  }
  for (int j = -4; j < n + 4; ++j) for (int i = -4; i < n + 4; ++i) {
    if (j >= 0 && j < n && i >= 0 && i < n) continue;
    const double lat = lat0 + (-half + j * cell) / R / deg;
    const double lon = lon0 + (-half + i * cell) / (R * cosc) / deg;
    leaves.insert(h.locate(P->geodesy().direction(lat, lon), L));
  }
  auto grid_of = [&](const Vec3d& p, double& x, double& y) {
    double la, lo; P->geodesy().direction_to_geographic(p, la, lo);
    double dl = lo - lon0; if (dl > 180) dl -= 360; if (dl < -180) dl += 360;
    x = (dl * deg * R * cosc + half) / cell; y = ((la - lat0) * deg * R + half) / cell;
  };
  std::vector<float> out = elev;
  std::vector<std::uint8_t> floored(n * n, 0);
  std::vector<double> softsum(n * n, 1.0), sminslope(n * n, 1e30);
  int floors = 0;
  std::map<std::pair<std::uint32_t, std::uint32_t>, double> edges;
  if (env("EXP_FLOORS", 1) > 0) {
    if (env("EXP_NB", 1) > 0) {
      std::vector<std::int32_t> first(leaves.begin(), leaves.end());
      for (std::int32_t t : first) {
        h.ensure_partner(t);
        for (int k = 0; k < 3; ++k) if (h.tris[t].nb[k] >= 0) leaves.insert(h.tris[t].nb[k]);
      }
    }
    for (std::int32_t t : leaves) {
      const Tri& tri = h.tris[t];
      for (int k = 0; k < 3; ++k) {
        if (tri.edge[k] != EdgeType::drain) continue;
        std::uint32_t a = tri.v[k], b = tri.v[(k + 1) % 3];
        if (a > b) std::swap(a, b);
        const double bl = born_length(h, P->rules(), t, k);
        auto [it, fresh] = edges.emplace(std::make_pair(a, b), bl);
        if (!fresh) it->second = std::max(it->second, bl);
      }
    }
    const int passes = tau_frac > 0 ? 2 : 1;
    for (int pass = 0; pass < passes; ++pass)
    for (auto& [e, bl] : edges) {
      if (bl < kmin * cell) continue;
      if (pass == passes - 1) ++floors;
      const Vertex& u = h.vertices[e.first]; const Vertex& v = h.vertices[e.second];
      double ux, uy, vx, vy; grid_of(u.p, ux, uy); grid_of(v.p, vx, vy);
      const double W = std::max(wcells, wfrac * bl / cell);
      const int x0 = std::max(0, int(std::floor(std::min(ux, vx) - W))), x1 = std::min(n - 1, int(std::ceil(std::max(ux, vx) + W)));
      const int y0 = std::max(0, int(std::floor(std::min(uy, vy) - W))), y1 = std::min(n - 1, int(std::ceil(std::max(uy, vy) + W)));
      const double ex = vx - ux, ey = vy - uy, ee = ex * ex + ey * ey;
      const double axis_slope = std::abs(u.ground - v.ground) / (std::sqrt(ee) * cell);
      const double cross = sf + sfr * axis_slope;
      for (int y = y0; y <= y1; ++y) for (int x = x0; x <= x1; ++x) {
        const int c = y * n + x;
        if (sea[c] || wet[c]) continue;
        double t = ee > 0 ? ((x - ux) * ex + (y - uy) * ey) / ee : 0; t = std::clamp(t, 0.0, 1.0);
        const double dx = x - (ux + t * ex), dy = y - (uy + t * ey), d = std::sqrt(dx * dx + dy * dy);
        if (d > W) continue;
        const double axis = u.ground + t * (v.ground - u.ground);
        const double g = d < rr ? d * d / (2 * rr) : d - rr / 2;
        const double f = axis + cross * g * cell;
        floored[c] = 1;
        if (tau_frac > 0 && pass == 0) {
          sminslope[c] = std::min(sminslope[c], axis_slope);
        } else if (tau_frac > 0) {
          const double tau = tau_frac * std::max(sminslope[c], 1e-5) * cell;
          softsum[c] += std::exp(-(f - elev[c]) / tau);
        } else if (kk > 0) {
          const double k = kk * cross * cell;
          const double a0 = out[c];
          const double hh = std::max(k - std::abs(a0 - f), 0.0) / k;
          out[c] = float(std::min(a0, f) - hh * hh * k * 0.25);
        } else if (f < out[c]) out[c] = float(f);
      }
    }
  }
  if (tau_frac > 0) {
    for (int c = 0; c < n * n; ++c) if (!sea[c] && !wet[c] && floored[c]) {
      const double tau = tau_frac * std::max(sminslope[c], 1e-5) * cell;
      out[c] = float(elev[c] - tau * std::log(softsum[c]));
    }
  }
  {
    int pin = 0, pout = 0, pwet = 0;
    for (int y = 1; y < n - 1; ++y) for (int x = 1; x < n - 1; ++x) {
      const int c = y * n + x; if (sea[c] || wet[c]) continue;
      bool pit = true, nearwet = false;
      for (int dy = -1; dy <= 1; ++dy) for (int dx = -1; dx <= 1; ++dx) { if (!dx && !dy) continue; const int q = c + dy * n + dx; if (sea[q] || wet[q]) nearwet = true; if (out[q] <= out[c]) pit = false; }
      if (!pit) continue;
      if (nearwet) ++pwet; else if (floored[c]) ++pin; else ++pout;
      if (pin <= 40 && pin % 10 == 0 && x > 10 && y > 10 && x < 500 && y < 500 && floored[c] && std::getenv("EXP_DUMP")) {
        std::printf("pit %d,%d\n", x, y);
        for (auto& [e, bl] : edges) {
          const Vertex& u = h.vertices[e.first]; const Vertex& v = h.vertices[e.second];
          double ux, uy, vx, vy; grid_of(u.p, ux, uy); grid_of(v.p, vx, vy);
          if (std::hypot(ux - x, uy - y) < 3 || std::hypot(vx - x, vy - y) < 3)
            std::printf("  edge (%.2f,%.2f %.2f)-(%.2f,%.2f %.2f) born %.0f flags %d %d\n", ux - x, uy - y, u.ground, vx - x, vy - y, v.ground, bl, u.flags, v.flags);
        }
        const Tri& lt = h.tris[h.locate(P->geodesy().direction(lat0 + (-half + y * cell) / R / deg, lon0 + (-half + x * cell) / (R * cosc) / deg), L)];
        for (int k = 0; k < 3; ++k) { const Vertex& q = h.vertices[lt.v[k]]; double qx, qy; grid_of(q.p, qx, qy); std::printf("  leaf corner (%.2f,%.2f) %.2f edge %d\n", qx - x, qy - y, q.ground, int(lt.edge[k])); }
        for (int dy = 1; dy >= -1; --dy) { for (int dx = -1; dx <= 1; ++dx) { const int q = c + dy * n + dx; std::printf(" %9.2f(%9.2f)%c", out[q], elev[q], floored[q] ? 'F' : ' '); } std::printf("\n"); }
      }
    }
    int fl = 0, lowered = 0, land = 0;
    for (int c = 0; c < n * n; ++c) { if (sea[c] || wet[c]) continue; ++land; fl += floored[c]; lowered += out[c] < elev[c]; }
    std::printf("pits in/out %d/%d lowered %4.1f%% ", pin, pout, 100.0 * lowered / std::max(1, land));
  }
  const terrain::ElevationGrid grid{n, n, cell, out, std::nullopt, sea, wet};
  terrain::AnalysisOptions opt;
  terrain::AnalysisPicture pic;
  auto figs = terrain::analyze(grid, opt, std::getenv("EXP_PIC") ? &pic : nullptr);
  if (std::getenv("EXP_PIC")) {
    auto o = OIIO::ImageOutput::create(std::getenv("EXP_PIC"));
    OIIO::ImageSpec spec(pic.width, pic.height, 3, OIIO::TypeDesc::UINT8);
    o->open(std::getenv("EXP_PIC"), spec); o->write_image(OIIO::TypeDesc::UINT8, pic.rgb.data()); o->close();
  }
  nlohmann::json j = terrain::to_json(*figs);
  const auto& f = j["flint"];
  std::printf("z%-2d L%d floors %6d pits %6.3f%% closed %5.2f%% theta %s r2 %s\n", zoom, L, floors,
              100 * j["pits"]["share"].get<double>(), 100 * j["closed_depression_share"].get<double>(),
              f.is_null() ? "-" : std::to_string(f["theta"].get<double>()).substr(0, 5).c_str(),
              f.is_null() ? "-" : std::to_string(f["r_squared"].get<double>()).substr(0, 5).c_str());
}
