#pragma once
// The CUDA backend's profile, where MCA_PROFILE is set: the time of each kernel and device-wide primitive
// (summed by name over the run), the launches and the reads of the device per step; printed to stderr when
// the backend is destroyed, as the CPU backend's pass profile. The device measures its own times (CUDA
// events around each launch on a GPU; the wall clock in the host emulation).
#include <cxxabi.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <typeinfo>
#include <utility>
#include <vector>

#include "backend/cuda/device_memory.hpp"
#include "core/environment.hpp"
#include "core/text.hpp"

namespace mca::gpu {

class DeviceProfile {
 public:
  bool on() const { return on_; }
  // A kernel's name from its type (mca::gpu::ManyBodyKernel: "ManyBodyKernel").
  template <class K>
  static std::string name_of() {
    int status = 0;
    std::unique_ptr<char, void (*)(void*)> full(abi::__cxa_demangle(typeid(K).name(), nullptr, nullptr, &status), std::free);
    std::string s = status == 0 && full ? full.get() : typeid(K).name();
    const std::size_t colon = s.rfind("::");
    return colon == std::string::npos ? s : s.substr(colon + 2);
  }
  void add(const std::string& name, double seconds) {
    Entry& e = entries_[name];
    e.seconds += seconds;
    ++e.calls;
  }
  void read() { ++reads_; }
  // The time the host spent waiting for a copy from the device (the rest of a step it spends issuing work:
  // where that wait is short, the step is bound by the host's launches, not by the device).
  void waited(double seconds) { waited_ += seconds; }
  // Prints the table for `steps` steps of a backend called `backend`, and starts again.
  void print(const char* backend, std::int64_t steps, std::int64_t rebuilds) {
    if (!on_ || steps == 0 || entries_.empty()) return;
    std::vector<std::pair<std::string, Entry>> rows(entries_.begin(), entries_.end());
    std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.second.seconds > b.second.seconds; });
    double total = 0;
    std::int64_t calls = 0;
    for (const auto& r : rows) {
      total += r.second.seconds;
      calls += r.second.calls;
    }
    const double per = 1.0 / static_cast<double>(steps);
    std::fprintf(stderr, "%s profile over %lld steps: %.1f us/step on the device in %.1f launches, %.2f reads of the device\n",
                 backend, static_cast<long long>(steps), 1e6 * total * per, static_cast<double>(calls) * per,
                 static_cast<double>(reads_) * per);
    for (const auto& [name, e] : rows)
      std::fprintf(stderr, "  %-28s %9.2f us/step %8.2f us/call %7.2f calls/step %5.1f %%\n", name.c_str(), 1e6 * e.seconds * per,
                   1e6 * e.seconds / static_cast<double>(e.calls), static_cast<double>(e.calls) * per,
                   total > 0 ? 100 * e.seconds / total : 0.0);
    std::fprintf(stderr, "  the host waited %.1f us/step for the device at its reads\n", 1e6 * waited_ * per);
    std::fprintf(stderr, "  contact lists rebuilt %lld times\n", static_cast<long long>(rebuilds));
    std::fprintf(stderr, "  device arrays: %s held, %s at the most (all simulations of the process)\n",
                 text::human_bytes(static_cast<double>(DeviceMemory::held())).c_str(),
                 text::human_bytes(static_cast<double>(DeviceMemory::peak())).c_str());
    entries_.clear();
    reads_ = 0;
    waited_ = 0;
  }

 private:
  struct Entry {
    double seconds = 0;
    std::int64_t calls = 0;
  };
  bool on_ = profile_requested();
  std::map<std::string, Entry> entries_;
  std::int64_t reads_ = 0;
  double waited_ = 0;
};

}  // namespace mca::gpu
