// Global operator new and delete that count the bytes they hand out (malloc_usable_size, so
// unsized deletes count right), for bench::heap_peak_since_reset. Relaxed atomics: a counter, not
// a synchronisation point.
#include "heap_peak.hpp"

#include <malloc.h>

#include <atomic>
#include <cstdlib>
#include <new>

namespace {

std::atomic<std::size_t> held{0};
std::atomic<std::size_t> peak{0};
std::atomic<std::size_t> baseline{0};

void* counted_allocation(std::size_t size, std::size_t alignment) {
  void* p = nullptr;
  if (alignment <= alignof(std::max_align_t)) {
    p = std::malloc(size == 0 ? 1 : size);
  } else if (posix_memalign(&p, alignment, size == 0 ? 1 : size) != 0) {
    p = nullptr;
  }
  if (p == nullptr) throw std::bad_alloc();
  const std::size_t now =
      held.fetch_add(malloc_usable_size(p), std::memory_order_relaxed) + malloc_usable_size(p);
  std::size_t top = peak.load(std::memory_order_relaxed);
  while (now > top && !peak.compare_exchange_weak(top, now, std::memory_order_relaxed)) {
  }
  return p;
}

void counted_release(void* p) noexcept {
  if (p == nullptr) return;
  held.fetch_sub(malloc_usable_size(p), std::memory_order_relaxed);
  std::free(p);
}

}  // namespace

namespace bench {

void reset_heap_peak() {
  const std::size_t now = held.load(std::memory_order_relaxed);
  baseline.store(now, std::memory_order_relaxed);
  peak.store(now, std::memory_order_relaxed);
}

std::size_t heap_peak_since_reset() {
  return peak.load(std::memory_order_relaxed) - baseline.load(std::memory_order_relaxed);
}

}  // namespace bench

void* operator new(std::size_t size) {
  return counted_allocation(size, 0);
}
void* operator new[](std::size_t size) {
  return counted_allocation(size, 0);
}
void* operator new(std::size_t size, std::align_val_t a) {
  return counted_allocation(size, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t size, std::align_val_t a) {
  return counted_allocation(size, static_cast<std::size_t>(a));
}
void operator delete(void* p) noexcept {
  counted_release(p);
}
void operator delete[](void* p) noexcept {
  counted_release(p);
}
void operator delete(void* p, std::size_t) noexcept {
  counted_release(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  counted_release(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  counted_release(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  counted_release(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  counted_release(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  counted_release(p);
}
