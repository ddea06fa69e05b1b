#include "planet/geodesy.hpp"

#include <cmath>
#include <numbers>

namespace planet {
namespace {
constexpr double kDegree = std::numbers::pi / 180.0;
}

Geodesy::Geodesy(double equatorial_radius, double flattening)
    : a_(equatorial_radius),
      f_(flattening),
      e2_(flattening * (2.0 - flattening)),
      geocentric_(equatorial_radius, flattening),
      geodesic_(equatorial_radius, flattening) {}

Vec3d Geodesy::ecef(double latitude, double longitude, double height) const {
  Vec3d out{};
  geocentric_.Forward(latitude, longitude, height, out[0], out[1], out[2]);
  return out;
}

void Geodesy::geographic(const Vec3d& p, double& latitude, double& longitude,
                         double& height) const {
  geocentric_.Reverse(p[0], p[1], p[2], latitude, longitude, height);
}

Vec3d Geodesy::direction(double sin_lat, double cos_lat, double sin_lon, double cos_lon) const {
  // ECEF at height 0 is N(φ)·(cos φ cos λ, cos φ sin λ, (1 − e²) sin φ); N cancels on
  // normalising. For the sphere (e² = 0) the vector is already unit length.
  Vec3d d{cos_lat * cos_lon, cos_lat * sin_lon, (1.0 - e2_) * sin_lat};
  if (e2_ != 0.0) {
    const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    d = {d[0] / n, d[1] / n, d[2] / n};
  }
  return d;
}

Vec3d Geodesy::direction(double latitude, double longitude) const {
  const double phi = latitude * kDegree, lambda = longitude * kDegree;
  return direction(std::sin(phi), std::cos(phi), std::sin(lambda), std::cos(lambda));
}

void Geodesy::direction_to_geographic(const Vec3d& d, double& latitude, double& longitude) const {
  // Geocentric latitude ψ of the ray; on the ellipsoid's surface tan φ = tan ψ / (1 − e²).
  const double horizontal = std::hypot(d[0], d[1]);
  latitude = std::atan2(d[2], (1.0 - e2_) * horizontal) / kDegree;
  longitude = std::atan2(d[1], d[0]) / kDegree;
}

double Geodesy::distance(double lat1, double lon1, double lat2, double lon2) const {
  double s12 = 0.0;
  geodesic_.Inverse(lat1, lon1, lat2, lon2, s12);
  return s12;
}

}  // namespace planet
