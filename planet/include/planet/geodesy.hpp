// Geodesy of a planet (GeographicLib): geographic ↔ ECEF, geodesic distances, and the unit
// direction from the centre that the planet's mesh hierarchy is indexed by. A sphere by default;
// an ellipsoid of revolution when the definition's flattening is positive. World positions are
// doubles throughout, so a centimetre stays a centimetre anywhere on an Earth-sized planet.
#pragma once

#include <array>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/Geodesic.hpp>

namespace planet {

using Vec3d = std::array<double, 3>;

class Geodesy {
 public:
  Geodesy(double equatorial_radius, double flattening);

  double equatorial_radius() const { return a_; }
  double flattening() const { return f_; }

  /// Earth-centred, earth-fixed position (metres) of geodetic latitude, longitude (degrees) and
  /// height above the reference surface (metres).
  Vec3d ecef(double latitude, double longitude, double height) const;
  /// Geodetic latitude, longitude (degrees) and height of an ECEF position.
  void geographic(const Vec3d& ecef, double& latitude, double& longitude, double& height) const;

  /// The unit vector from the centre through the surface point at (latitude, longitude): the
  /// normalised ECEF position at height 0. The planet's heights are a function of it. Computed
  /// from sines and cosines directly (equal to normalising ecef(...) to rounding), so that tiles
  /// can reuse the trigonometry of a row and of a column.
  Vec3d direction(double latitude, double longitude) const;
  /// The same from sin/cos of latitude and longitude.
  Vec3d direction(double sin_lat, double cos_lat, double sin_lon, double cos_lon) const;
  /// Geodetic latitude and longitude of the surface point in a direction.
  void direction_to_geographic(const Vec3d& direction, double& latitude, double& longitude) const;

  /// Geodesic distance in metres between two geographic points (on the reference surface).
  double distance(double lat1, double lon1, double lat2, double lon2) const;

 private:
  double a_, f_, e2_;
  GeographicLib::Geocentric geocentric_;
  GeographicLib::Geodesic geodesic_;
};

}  // namespace planet
