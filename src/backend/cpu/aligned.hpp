#pragma once
// Arrays that start on a 64-byte cache line, so that a block of lanes at a multiple of its width is one
// aligned vector, not two lines' parts.
#include <cstddef>
#include <new>
#include <vector>

namespace mca::cpu {

inline constexpr std::size_t kCacheLine = 64;

template <class T>
struct LineAllocator {
  using value_type = T;
  LineAllocator() = default;
  template <class U>
  LineAllocator(const LineAllocator<U>&) {}
  T* allocate(std::size_t count) {
    return static_cast<T*>(::operator new(count * sizeof(T), std::align_val_t{kCacheLine}));
  }
  void deallocate(T* p, std::size_t) { ::operator delete(p, std::align_val_t{kCacheLine}); }
  template <class U>
  bool operator==(const LineAllocator<U>&) const { return true; }
};

template <class T>
using LineArray = std::vector<T, LineAllocator<T>>;

}  // namespace mca::cpu
