#pragma once
// The host emulation of the CUDA backend's device: buffers in host memory, a kernel launch as a loop over
// the thread indices in order, and the device-wide primitives (scan, stable sort by key, the max and min of
// a launch) as their serial twins, which give the same results as the CUDA ones (integer scans and sorts,
// and the max and min of values, do not depend on the order of evaluation). The primitives' results stay in
// "device" arrays: the step logic reads them only through download, as it must on a GPU. DeviceBackend<HostDevice>
// runs every line of the CUDA backend's step logic on a machine without a GPU; CI checks it bit for bit
// against the CPU.
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <utility>
#include <vector>

#include "backend/cuda/device_memory.hpp"
#include "backend/cuda/profile.hpp"
#include "render/draw_list.hpp"

namespace mca::gpu {

struct HostDevice {
  static constexpr const char* kName = "cuda-emulation";

  // A device array. The step logic reads and writes it only through kernels and the copies below, as it
  // must a CUDA device array. Its memory is counted as a CUDA device array's (DeviceMemory, with the
  // capacity of grown_capacity), and where MCA_EMULATED_GPU_MEMORY_MB is set, growing past it is refused
  // as a full GPU refuses it.
  template <class T>
  class Buffer {
   public:
    Buffer() = default;
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;
    Buffer(Buffer&& o) noexcept : v_(std::move(o.v_)), cap_(std::exchange(o.cap_, 0)) { o.v_.clear(); }
    Buffer& operator=(Buffer&& o) noexcept {
      std::swap(v_, o.v_);
      std::swap(cap_, o.cap_);
      return *this;
    }
    ~Buffer() { DeviceMemory::remove(cap_ * sizeof(T)); }
    // Null until memory is first held, as a CUDA device array's (an emptied one keeps its address there).
    T* data() { return cap_ ? v_.data() : nullptr; }
    const T* data() const { return cap_ ? v_.data() : nullptr; }
    std::size_t size() const { return v_.size(); }
    // Discards the contents: what it then holds is bytes of 0xFF (a NaN in a float or double, 0xffffffff
    // in an index), as arbitrary as a GPU's fresh or reused memory, so that a kernel reading an element
    // before one is written there gives a different result here than on the CPU (the emulation zeroed it,
    // and such a read would have passed every test here and failed on a GPU).
    void resize(std::size_t n) {
      if (n > cap_) {
        const std::size_t cap = grown_capacity(cap_, n), bytes = bytes_of<T>(cap);
        DeviceMemory::remove(cap_ * sizeof(T));
        cap_ = 0;
        v_ = {};
        const std::size_t gpu = emulated_gpu_memory().value_or(SIZE_MAX);  // (none set: no limit)
        if (!DeviceMemory::add_within(bytes, gpu))
          throw out_of_device_memory(bytes, gpu - std::min(gpu, DeviceMemory::held()), gpu, true);
        cap_ = cap;
      }
      v_.clear();
      v_.resize(n);
      if (n) std::memset(static_cast<void*>(v_.data()), 0xFF, n * sizeof(T));
    }

   private:
    std::vector<T> v_;
    std::size_t cap_ = 0;  // the elements a CUDA device array would hold
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
    ++reads;
    profile().read();
    if (n) std::memcpy(static_cast<void*>(dst), b.data() + offset, n * sizeof(T));
  }
  // download (of a few values), with after() launching more work behind the copy, before the host waits
  // for it (on a GPU: the device is not idle while the host reads and decides what to launch next).
  template <class T, class F>
  static void download_then(T* dst, const Buffer<T>& b, std::size_t n, std::size_t offset, F&& after) {
    download(dst, b, n, offset);
    after();
  }
  template <class T>
  static void fill(Buffer<T>& b, const T& value) {
    for (std::size_t k = 0; k < b.size(); ++k) b.data()[k] = value;
  }
  // to[0 .. n - 1] = from[0 .. n - 1], both on the device.
  template <class T>
  static void copy(T* to, const T* from, std::size_t n) {
    if (n) std::memcpy(static_cast<void*>(to), from, n * sizeof(T));
  }

  // kernel(k) for k = 0 .. n - 1, in order; in reverse order where `reverse` is set (tests: a CUDA grid
  // runs its threads in no order, so no launch may depend on one).
  template <class K>
  static void launch(std::size_t n, const K& kernel) {
    static const std::string name = DeviceProfile::name_of<K>();
    timed(name, [&] {
      if (reverse)
        for (std::size_t k = n; k-- > 0;) kernel(k);
      else
        for (std::size_t k = 0; k < n; ++k) kernel(k);
    });
  }

  // kernel(phase, k) for each phase in turn (K::kPhases of them), k = 0 .. kernel.size(phase) - 1 in each
  // (in reverse order where `reverse` is set): on a GPU one block, a barrier between phases.
  template <class K>
  static void launch_block(const K& kernel) {
    static const std::string name = DeviceProfile::name_of<K>();
    timed(name, [&] {
      for (int phase = 0; phase < K::kPhases; ++phase) {
        const std::size_t n = kernel.size(phase);
        if (reverse)
          for (std::size_t k = n; k-- > 0;) kernel(phase, k);
        else
          for (std::size_t k = 0; k < n; ++k) kernel(phase, k);
      }
    });
  }

  // kernel(k) for k = 0 .. n - 1 (as launch), each giving a Reduced: *max_to becomes the largest of it and
  // theirs (each taken as 0 where not > 0), *min_to the smallest (null: not wanted).
  template <class K>
  static void launch_reduce(std::size_t n, const K& kernel, float* max_to, std::uint32_t* min_to) {
    static const std::string name = DeviceProfile::name_of<K>();
    timed(name, [&] {
      float m = max_to ? *max_to : 0.0f;
      std::uint32_t low = min_to ? *min_to : UINT32_MAX;
      const auto take = [&](std::size_t k) {
        const auto r = kernel(k);
        if (r.max > m) m = r.max;
        low = std::min(low, r.min);
      };
      if (reverse)
        for (std::size_t k = n; k-- > 0;) take(k);
      else
        for (std::size_t k = 0; k < n; ++k) take(k);
      if (max_to) *max_to = m;
      if (min_to) *min_to = low;
    });
  }

  // out[k] = in[0] + ... + in[k - 1] for k = 0 .. n: out[n] is the total (out holds n + 1 values; in and
  // out are different arrays).
  static void exclusive_scan(const std::uint32_t* in, std::uint32_t* out, std::size_t n) {
    static const std::string name = "scan";
    timed(name, [&] {
      std::uint32_t sum = 0;
      for (std::size_t k = 0; k < n; ++k) {
        out[k] = sum;
        sum += in[k];
      }
      out[n] = sum;
    });
  }
  // Sorts (keys, values) by key, keeping the order of equal keys; every key is below 2^key_bits.
  template <class Key>
  static void stable_sort_by_key(Key* keys, std::uint32_t* values, std::size_t n, int key_bits) {
    static const std::string name = "sort";
    timed(name, [&] {
      std::vector<std::pair<Key, std::uint32_t>> kv(n);
      for (std::size_t k = 0; k < n; ++k) {
        if (key_bits < static_cast<int>(8 * sizeof(Key)) && keys[k] >> key_bits)
          throw std::logic_error("stable_sort_by_key: a key has more than the bits given");
        kv[k] = {keys[k], values[k]};
      }
      std::stable_sort(kv.begin(), kv.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      for (std::size_t k = 0; k < n; ++k) {
        keys[k] = kv[k].first;
        values[k] = kv[k].second;
      }
    });
  }
  // A renderer's buffer for the draw list (render::DrawTarget), holding at least `bytes`, mapped for the
  // kernels to write: its memory is the host's, so it is mapped into host memory (null, and why, where it
  // cannot be: never here).
  static void* map_gl(render::DrawTarget& t, render::DrawTarget::Which which, std::size_t bytes, std::string& /*why*/) {
    t.reserve(which, bytes);
    return t.map(which, bytes);
  }
  static void unmap_gl(render::DrawTarget& t, render::DrawTarget::Which which) { t.unmap(which); }

  // Counted (per host thread): the copies from the device to the host (each a wait for the device on a
  // GPU); and whether launches run their threads backwards.
  static inline thread_local std::size_t reads = 0;
  static inline bool reverse = false;

  // The profile (MCA_PROFILE): the wall time of each launch and primitive.
  static DeviceProfile& profile() {
    static thread_local DeviceProfile p;  // (per host thread: Python steps simulations in threads of their own)
    return p;
  }
  static void print_profile(const char* backend, std::int64_t steps, std::int64_t rebuilds) {
    profile().print(backend, steps, rebuilds);
  }

 private:
  template <class F>
  static void timed(const std::string& name, F&& f) {
    if (!profile().on()) return f();
    const auto t0 = std::chrono::steady_clock::now();
    f();
    profile().add(name, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
};

}  // namespace mca::gpu
