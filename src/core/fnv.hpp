#pragma once
// FNV-1a over bytes, the one hash behind state_hash and model_fingerprint. Callers feed values field by
// field: the bytes of a whole struct would include its padding, which holds no state.
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace mca {

struct Fnv1a {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) {
      h ^= c[k];
      h *= 1099511628211ull;
    }
  }
  // A value without padding (a number, or a struct of numbers that fills its size).
  template <class T>
  void pod(const T& v) {
    static_assert(std::has_unique_object_representations_v<T> || std::is_floating_point_v<T>,
                  "hash structs with padding field by field");
    bytes(&v, sizeof v);
  }
};

}  // namespace mca
