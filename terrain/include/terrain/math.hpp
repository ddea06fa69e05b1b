// Small value types shared by every evaluator: 2D vectors, boxes and intervals in scene metres.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain {

/// A 2D point or vector in scene metres (x east, y north).
struct Vec2 {
  float x = 0.0f;
  float y = 0.0f;

  friend constexpr Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
  friend constexpr Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
  friend constexpr Vec2 operator-(Vec2 a) { return {-a.x, -a.y}; }
  friend constexpr Vec2 operator*(Vec2 a, float s) { return {a.x * s, a.y * s}; }
  friend constexpr Vec2 operator*(float s, Vec2 a) { return {a.x * s, a.y * s}; }
  friend constexpr bool operator==(Vec2 a, Vec2 b) = default;
};

constexpr float dot(Vec2 a, Vec2 b) {
  return a.x * b.x + a.y * b.y;
}
constexpr float cross(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}
inline float length(Vec2 a) {
  return std::sqrt(dot(a, a));
}

/// A point or direction in 3-D (scene frame: x, y across, z up).
struct Vec3 {
  float x = 0, y = 0, z = 0;
};

/// A closed interval of reals; empty when lo > hi.
struct Interval {
  float lo = std::numeric_limits<float>::infinity();
  float hi = -std::numeric_limits<float>::infinity();

  static constexpr Interval point(float v) { return {v, v}; }
  constexpr bool empty() const { return lo > hi; }
  constexpr float width() const { return hi - lo; }
  constexpr Interval hull(Interval o) const { return {std::min(lo, o.lo), std::max(hi, o.hi)}; }
  constexpr bool contains(float v) const { return v >= lo && v <= hi; }
};

/// An axis-aligned box in scene metres; empty when lo > hi on either axis.
struct Box2 {
  Vec2 lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()};
  Vec2 hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()};

  static constexpr Box2 everywhere() {
    constexpr float inf = std::numeric_limits<float>::infinity();
    return {{-inf, -inf}, {inf, inf}};
  }
  static constexpr Box2 around(Vec2 c, float r) { return {{c.x - r, c.y - r}, {c.x + r, c.y + r}}; }
  static constexpr Box2 of_point(Vec2 p) { return {p, p}; }

  constexpr bool empty() const { return lo.x > hi.x || lo.y > hi.y; }
  constexpr bool contains(Vec2 p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y;
  }
  constexpr bool intersects(const Box2& o) const {
    return lo.x <= o.hi.x && o.lo.x <= hi.x && lo.y <= o.hi.y && o.lo.y <= hi.y;
  }
  constexpr Box2 united(const Box2& o) const {
    return {{std::min(lo.x, o.lo.x), std::min(lo.y, o.lo.y)},
            {std::max(hi.x, o.hi.x), std::max(hi.y, o.hi.y)}};
  }
  constexpr Box2 intersected(const Box2& o) const {
    return {{std::max(lo.x, o.lo.x), std::max(lo.y, o.lo.y)},
            {std::min(hi.x, o.hi.x), std::min(hi.y, o.hi.y)}};
  }
  constexpr Box2 expanded(float r) const { return {{lo.x - r, lo.y - r}, {hi.x + r, hi.y + r}}; }
  constexpr Box2 with(Vec2 p) const { return united(of_point(p)); }
  /// Whether every corner is a finite number (not a half-plane or the whole plane).
  bool is_finite() const {
    return std::isfinite(lo.x) && std::isfinite(lo.y) && std::isfinite(hi.x) && std::isfinite(hi.y);
  }
  constexpr Vec2 center() const { return {(lo.x + hi.x) * 0.5f, (lo.y + hi.y) * 0.5f}; }
  constexpr Vec2 size() const { return {hi.x - lo.x, hi.y - lo.y}; }
  /// Distance range from a point to any point of the box (0 when inside).
  Interval distance_range(Vec2 p) const {
    const float dx = std::max({lo.x - p.x, 0.0f, p.x - hi.x});
    const float dy = std::max({lo.y - p.y, 0.0f, p.y - hi.y});
    const float fx = std::max(std::abs(p.x - lo.x), std::abs(p.x - hi.x));
    const float fy = std::max(std::abs(p.y - lo.y), std::abs(p.y - hi.y));
    return {std::sqrt(dx * dx + dy * dy), std::sqrt(fx * fx + fy * fy)};
  }
};

}  // namespace terrain
