#pragma once
// The device memory the CUDA backend's arrays hold, counted the same way by both devices (cuda_device.cuh,
// host_device.hpp), so the emulation's figure is the GPU's but for what only the GPU has (the scratch memory
// of CUB's sorts and scans and the sorts' output, kept per host thread); and the error for an allocation
// that does not fit, which says what to do.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "mca/error.hpp"

namespace mca::gpu {

// The elements a device array of capacity `cap` holds after being asked for `n`: its capacity where n
// fits, else n, and where it held some before, at least half as much again (a list growing a little every
// step, as the contact list when links break, is not allocated anew every step).
constexpr std::size_t grown_capacity(std::size_t cap, std::size_t n) {
  return n <= cap ? cap : cap ? std::max(n, cap + cap / 2) : n;
}
// The bytes of `n` elements of T; an mca::Error where they do not fit in a size_t (never for a model whose
// sizes were checked as it was built).
template <class T>
std::size_t bytes_of(std::size_t n) {
  if (n > SIZE_MAX / sizeof(T))
    throw Error("a device array of " + std::to_string(n) + " elements of " + std::to_string(sizeof(T)) +
                " bytes: more bytes than an address holds");
  return n * sizeof(T);
}

// The bytes held by every device array of the process (all its simulations, as on one GPU), and the most
// held at once.
class DeviceMemory {
 public:
  static void add(std::size_t bytes) {
    raise_peak(held_.fetch_add(bytes) + bytes);
  }
  // add(bytes) where what is held stays within `limit`, in one atomic step (threads growing arrays at once
  // cannot pass it together); false, counting nothing, where it would not.
  static bool add_within(std::size_t bytes, std::size_t limit) {
    std::size_t held = held_.load();
    do {
      if (bytes > limit || held > limit - bytes) return false;
    } while (!held_.compare_exchange_weak(held, held + bytes));
    raise_peak(held + bytes);
    return true;
  }
  static void remove(std::size_t bytes) { held_.fetch_sub(bytes); }
  static std::size_t held() { return held_.load(); }
  static std::size_t peak() { return peak_.load(); }
  // The peak starts again from what is held now.
  static void reset_peak() { peak_.store(held_.load()); }

 private:
  static void raise_peak(std::size_t now) {
    std::size_t peak = peak_.load();
    while (now > peak && !peak_.compare_exchange_weak(peak, now)) {
    }
  }
  static inline std::atomic<std::size_t> held_{0}, peak_{0};
};

// The memory of the GPU the host emulation plays, in bytes: MCA_EMULATED_GPU_MEMORY_MB (a number of MB,
// 1e6 bytes), where set (none where not: the host's memory is the limit); an mca::Error naming the
// variable for a value that is not a number from 0.001 to 1e9.
std::optional<std::size_t> emulated_gpu_memory();

// A device array the GPU's memory cannot hold (mca info catches it to describe the scene on the CPU).
class DeviceMemoryFull : public Error {
 public:
  using Error::Error;
};

// The error for `asked` more bytes that the device could not give, with `free` of `total` bytes free
// (total 0: not known) and DeviceMemory::held() held by mca's arrays; `emulated`: the GPU is the host
// emulation's (MCA_EMULATED_GPU_MEMORY_MB).
DeviceMemoryFull out_of_device_memory(std::size_t asked, std::size_t free, std::size_t total, bool emulated = false);

}  // namespace mca::gpu
