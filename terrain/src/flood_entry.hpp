// The entry of a priority-flood's queue (drainage.cpp; the erosion's flood keeps eight-byte
// float entries of its own, erosion.cpp's FloodCell): lowest value first, then the earliest
// pushed. The sequence number is unique, so the order is total and no result depends
// on the heap's implementation.
#pragma once

#include <cstdint>

namespace terrain {

struct FloodEntry {
  double value = 0.0;
  std::uint64_t sequence = 0;
  std::int32_t cell = 0;
  bool operator>(const FloodEntry& other) const {
    if (value != other.value) return value > other.value;
    return sequence > other.sequence;
  }
};

}  // namespace terrain
