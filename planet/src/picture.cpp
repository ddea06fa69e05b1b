#include "planet/picture.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <thread>

#include "terrain/image_io.hpp"

namespace planet {
namespace {

struct Rgb {
  double r, g, b;
};

Rgb mixrgb(Rgb a, Rgb b, double t) {
  t = std::clamp(t, 0.0, 1.0);
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

Rgb land_colour(double h) {  // metres above sea level
  const Rgb lowland{70, 140, 60}, hills{150, 150, 80}, rock{130, 105, 85}, snow{245, 245, 245};
  if (h < 800) return mixrgb(lowland, hills, h / 800);
  if (h < 2500) return mixrgb(hills, rock, (h - 800) / 1700);
  return mixrgb(rock, snow, (h - 2500) / 2500);
}

}  // namespace

std::vector<std::uint8_t> planet_picture_rgb(const std::shared_ptr<const Planet>& planet,
                                             const PictureOptions& options) {
  const int width = std::max(8, options.width), height = width / 2;
  const double step = 360.0 / width;  // degrees per pixel
  const double spacing = planet->ground_spacing(0, height);
  // One ring of samples more than the picture for the shading's central differences.
  const int gw = width + 2, gh = height + 2;
  std::vector<double> ground(static_cast<std::size_t>(gw) * gh);
  std::vector<std::uint8_t> type(ground.size());
  std::vector<std::uint8_t> river(ground.size());
  std::vector<double> water(ground.size());
  // Strokes as wide as hydraulic geometry has channels (w ∝ Q^0.5, Q ∝ drainage area), scaled
  // so the largest river is 3 pixels wide; the thinnest keep a quarter pixel on either side.
  const double pixel = planet->ground_spacing(0, height);
  const double largest = std::max(planet->base_mesh().stats.largest_drainage_area, 1.0);
  const auto half_width = [&](double drainage_area) {
    return pixel * std::clamp(1.5 * std::sqrt(drainage_area / largest), 0.25, 1.5);
  };
  auto rows = [&](int from, int to) {
    Sampler sampler(planet);
    for (int r = from; r < to; ++r) {
      const double lat = std::clamp(90.0 - (r - 0.5) * step, -90.0, 90.0);
      for (int c = 0; c < gw; ++c) {
        double lon = -180.0 + (c - 0.5) * step;
        if (lon < -180.0) lon += 360.0;
        if (lon >= 180.0) lon -= 360.0;
        const PointSample s = sampler.sample(lat, lon, spacing);
        const std::size_t at = static_cast<std::size_t>(r) * gw + static_cast<std::size_t>(c);
        ground[at] = s.ground;
        water[at] = s.water;
        river[at] = s.river_distance < half_width(s.river_drainage_area) ? 1 : 0;
        type[at] = static_cast<std::uint8_t>(s.type);
      }
    }
  };
  const int threads = std::max(1, options.threads);
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back(rows, gh * t / threads, gh * (t + 1) / threads);
  }
  for (std::thread& t : pool) t.join();

  const double sea = planet->definition().sea_level;
  const double metres = std::numbers::pi * planet->definition().radius * step / 180.0;
  const double az = (360.0 - options.azimuth_deg + 90.0) * std::numbers::pi / 180.0;
  const double alt = options.altitude_deg * std::numbers::pi / 180.0;
  const double lx = std::cos(alt) * std::cos(az), ly = std::cos(alt) * std::sin(az),
               lz = std::sin(alt);
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(width) * height * 3);
  for (int r = 0; r < height; ++r) {
    const double lat = 90.0 - (r + 0.5) * step;
    const double dx_m = std::max(metres * std::cos(lat * std::numbers::pi / 180.0), 1.0);
    for (int c = 0; c < width; ++c) {
      const std::size_t at = static_cast<std::size_t>(r + 1) * gw + static_cast<std::size_t>(c + 1);
      const double dzdx = (ground[at + 1] - ground[at - 1]) / (2 * dx_m) * options.z_factor;
      const double dzdy =
          (ground[at - static_cast<std::size_t>(gw)] - ground[at + static_cast<std::size_t>(gw)]) /
          (2 * metres) * options.z_factor;
      const double n = std::sqrt(dzdx * dzdx + dzdy * dzdy + 1.0);
      const double shade = std::clamp((-dzdx * lx - dzdy * ly + lz) / n, 0.0, 1.0);
      Rgb colour{};
      const auto t = static_cast<SurfaceType>(type[at]);
      if (t == SurfaceType::sea) {
        const double depth = std::clamp((sea - ground[at]) / 5000.0, 0.0, 1.0);
        colour = mixrgb(Rgb{90, 160, 210}, Rgb{15, 35, 90}, std::sqrt(depth));
      } else if (t == SurfaceType::lake) {
        const double depth = std::clamp((water[at] - ground[at]) / 500.0, 0.0, 1.0);
        colour = mixrgb(Rgb{70, 140, 205}, Rgb{25, 60, 140}, std::sqrt(depth));
      } else if (t == SurfaceType::river || river[at] != 0) {
        colour = Rgb{40, 90, 230};
      } else {
        colour = land_colour(ground[at] - sea);
        const double light = 0.35 + 0.65 * shade / std::sin(alt);
        colour = {colour.r * light, colour.g * light, colour.b * light};
      }
      std::uint8_t* out =
          &rgb[(static_cast<std::size_t>(r) * width + static_cast<std::size_t>(c)) * 3];
      out[0] = static_cast<std::uint8_t>(std::clamp(colour.r, 0.0, 255.0));
      out[1] = static_cast<std::uint8_t>(std::clamp(colour.g, 0.0, 255.0));
      out[2] = static_cast<std::uint8_t>(std::clamp(colour.b, 0.0, 255.0));
    }
  }
  return rgb;
}

Result<std::vector<std::uint8_t>> planet_picture_png(const std::shared_ptr<const Planet>& planet,
                                                     const PictureOptions& options) {
  const int width = std::max(8, options.width);
  const std::vector<std::uint8_t> rgb = planet_picture_rgb(planet, options);
  return terrain::encode_png_rgb8(width, width / 2, rgb.data(), terrain::PngKind::shaded);
}

}  // namespace planet
