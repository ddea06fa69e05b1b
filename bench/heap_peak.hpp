// The peak of heap bytes a piece of work holds beyond what was held when it started: the
// benchmarks' measure of a computation's memory, independent of the allocator's policies (the
// process's resident set also counts pages earlier benchmarks freed and the allocator kept).
// Counts every global operator new and delete of the binary it is linked into (heap_peak.cpp).
#pragma once

#include <cstddef>

namespace bench {

/// Starts a measurement: the peak is reset to the bytes held now.
void reset_heap_peak();

/// The most bytes held at once since reset_heap_peak, less those held when it was called.
std::size_t heap_peak_since_reset();

}  // namespace bench
