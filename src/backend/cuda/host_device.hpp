#pragma once
// The host emulation of the CUDA backend's device: buffers in host memory, a kernel launch as a loop over
// the thread indices in order, and the device-wide primitives (scan, stable sort by key, max, min) as their
// serial twins, which give the same results as the CUDA ones (integer scans and sorts, and the max and
// min of values, do not depend on the order of evaluation). DeviceBackend<HostDevice> runs every line of
// the CUDA backend's step logic on a machine without a GPU; CI checks it bit for bit against the CPU.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <utility>
#include <vector>

namespace mca::gpu {

struct HostDevice {
  static constexpr const char* kName = "cuda-emulation";

  // A device array. The step logic reads and writes it only through kernels and the copies below, as it
  // must a CUDA device array.
  template <class T>
  class Buffer {
   public:
    T* data() { return v_.empty() ? nullptr : v_.data(); }
    const T* data() const { return v_.empty() ? nullptr : v_.data(); }
    std::size_t size() const { return v_.size(); }
    // Discards the contents.
    void resize(std::size_t n) {
      v_.clear();
      v_.resize(n);
    }

   private:
    std::vector<T> v_;
  };

  template <class T>
  static void upload(Buffer<T>& b, const T* src, std::size_t n) {
    b.resize(n);
    if (n) std::memcpy(static_cast<void*>(b.data()), src, n * sizeof(T));
  }
  template <class T, class A>
  static void upload(Buffer<T>& b, const std::vector<T, A>& src) {
    upload(b, src.data(), src.size());
  }
  template <class T>
  static void download(T* dst, const Buffer<T>& b, std::size_t n, std::size_t offset = 0) {
    if (n) std::memcpy(static_cast<void*>(dst), b.data() + offset, n * sizeof(T));
  }
  template <class T>
  static void fill(Buffer<T>& b, const T& value) {
    for (std::size_t k = 0; k < b.size(); ++k) b.data()[k] = value;
  }
  template <class T>
  static void copy(Buffer<T>& to, const Buffer<T>& from, std::size_t n) {
    if (n) std::memcpy(static_cast<void*>(to.data()), from.data(), n * sizeof(T));
  }

  // kernel(k) for k = 0 .. n - 1.
  template <class K>
  static void launch(std::size_t n, const K& kernel) {
    for (std::size_t k = 0; k < n; ++k) kernel(k);
  }

  // out[k] = in[0] + ... + in[k - 1]; returns the total. in and out may be the same array.
  static std::uint32_t exclusive_scan(const std::uint32_t* in, std::uint32_t* out, std::size_t n) {
    std::uint32_t sum = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint32_t x = in[k];
      out[k] = sum;
      sum += x;
    }
    return sum;
  }
  // Sorts (keys, values) by key, keeping the order of equal keys.
  static void stable_sort_by_key(std::uint64_t* keys, std::uint32_t* values, std::size_t n) {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> kv(n);
    for (std::size_t k = 0; k < n; ++k) kv[k] = {keys[k], values[k]};
    std::stable_sort(kv.begin(), kv.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t k = 0; k < n; ++k) {
      keys[k] = kv[k].first;
      values[k] = kv[k].second;
    }
  }
  // The largest of n floats that are >= 0 or NaN-free (0 for none).
  static float max_of(const float* x, std::size_t n) {
    float m = 0;
    for (std::size_t k = 0; k < n; ++k)
      if (x[k] > m) m = x[k];
    return m;
  }
  // The smallest of n values (UINT32_MAX for none).
  static std::uint32_t min_of(const std::uint32_t* x, std::size_t n) {
    std::uint32_t m = UINT32_MAX;
    for (std::size_t k = 0; k < n; ++k) m = std::min(m, x[k]);
    return m;
  }
};

}  // namespace mca::gpu
