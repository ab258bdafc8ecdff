#pragma once
// The CUDA device for DeviceBackend (device_backend.hpp): device arrays, kernel launches as grids of one
// thread per element, and the device-wide primitives from CUB (CUDA toolkit) with the results of their
// host twins in host_device.hpp (integer scans and stable radix sorts, the max and min of values: none
// depends on the order of evaluation; the max and min of a launch are its own, run_reduce_kernel). Everything goes on the default stream in order; the primitives
// leave their results on the device and keep their scratch memory between calls, so only download waits
// for the device. Compiled by nvcc with --fmad=false (no fused multiply-add, IEEE division and square
// root), so a thread computes the CPU's bits.
#include <cub/block/block_scan.cuh>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cuda_runtime.h>
// CUDA-OpenGL interop (the draw list written into the renderer's buffers): its header wants GL's types.
#include <GL/gl.h>
#include <cuda_gl_interop.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "backend/cuda/device_memory.hpp"
#include "backend/cuda/profile.hpp"
#include "render/draw_list.hpp"
#include "core/environment.hpp"
#include "mca/error.hpp"

namespace mca::gpu {

inline void cuda_check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw Error(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

// After a launch: the launch's own error; and with MCA_CUDA_SYNC=1, the kernel's, waited for (a kernel that
// faults is otherwise reported by the next call that waits for the device, under that call's name).
inline void launched(const std::string& name) {
  cuda_check(cudaGetLastError(), ("launching " + name).c_str());
  static const bool wait = cuda_sync_requested();  // (checked with the others by Engine::check_environment)
  if (wait) cuda_check(cudaDeviceSynchronize(), name.c_str());
}

template <class K>
__global__ void run_kernel(K k, std::size_t n) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) k(i);
}

// kernel(phase, k) for each phase in turn, the block's threads taking k = 0 .. size(phase) - 1 between
// them; a barrier after each phase (its writes to global memory are then seen by the block's threads).
template <class K>
__global__ void run_block_kernel(K k) {
  for (int phase = 0; phase < K::kPhases; ++phase) {
    const std::size_t n = k.size(phase);
    for (std::size_t i = threadIdx.x; i < n; i += blockDim.x) k(phase, i);
    __syncthreads();
  }
}

template <class T>
__global__ void fill_kernel(T* p, std::size_t n, T value) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) p[i] = value;
}

// kernel(i) for each thread i < n, each giving a Reduced (device_kernels.hpp): the largest of the floats
// (each taken as 0 where not > 0, NaN included) and the smallest of the indices, over the warp by its
// reduce instructions (sm_80 on), over the block through shared memory, then one atomic each per block into
// *max_to and *min_to: the bits of non-negative floats order as unsigned integers do, so an integer
// atomicMax gives the largest float exactly, in any order of the blocks.
template <class K>
__device__ __forceinline__ void reduce_thread(const K& k, std::size_t n, float* max_to, std::uint32_t* min_to) {
  constexpr unsigned kWarps = 256 / 32;
  __shared__ unsigned warp_max[kWarps], warp_min[kWarps];
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  float m = 0.0f;
  unsigned low = 0xffffffffu;
  if (i < n) {
    const auto r = k(i);
    m = r.max > 0.0f ? r.max : 0.0f;
    low = r.min;
  }
  unsigned bits = __reduce_max_sync(0xffffffffu, __float_as_uint(m));
  low = __reduce_min_sync(0xffffffffu, low);
  const unsigned warp = threadIdx.x / 32, lane = threadIdx.x % 32;
  if (lane == 0) {
    warp_max[warp] = bits;
    warp_min[warp] = low;
  }
  __syncthreads();
  if (threadIdx.x == 0) {
    for (unsigned w = 1; w < blockDim.x / 32; ++w) {
      bits = bits > warp_max[w] ? bits : warp_max[w];
      low = low < warp_min[w] ? low : warp_min[w];
    }
    if (max_to && bits) atomicMax(reinterpret_cast<unsigned*>(max_to), bits);
    if (min_to && low != 0xffffffffu) atomicMin(reinterpret_cast<unsigned*>(min_to), low);
  }
}
template <class K>
__global__ void run_reduce_kernel(K k, std::size_t n, float* max_to, std::uint32_t* min_to) {
  reduce_thread(k, n, max_to, min_to);
}
// The same for a kernel that asks for MinBlocks blocks of 256 threads on a multiprocessor at once (the
// compiler then keeps its registers to what that leaves).
template <int MinBlocks, class K>
__global__ void __launch_bounds__(256, MinBlocks) run_bounded_reduce_kernel(K k, std::size_t n, float* max_to,
                                                                              std::uint32_t* min_to) {
  reduce_thread(k, n, max_to, min_to);
}

// The small primitives in one block, one launch each (a step's breaks and their ends, a projectile's
// candidates: tens to hundreds of elements, where CUB's several launches and host calls cost more than the
// work). A stable sort's order and a scan's sums are unique, so these give CUB's results (and the host
// twins').
constexpr unsigned kSmallSort = 1024, kSmallScanThreads = 1024, kSmallScanItems = 4;
// Stable sort of n <= kSmallSort (key, value) pairs by key, in place: each element's place is the number
// of keys below its own plus the number of equal keys before it.
template <class Key>
__global__ void __launch_bounds__(kSmallSort) small_sort_kernel(Key* keys, std::uint32_t* values, unsigned n) {
  __shared__ Key k[kSmallSort];
  __shared__ std::uint32_t v[kSmallSort];
  const unsigned t = threadIdx.x;
  if (t < n) {
    k[t] = keys[t];
    v[t] = values[t];
  }
  __syncthreads();
  if (t >= n) return;
  const Key mine = k[t];
  unsigned place = 0;
  for (unsigned i = 0; i < n; ++i) place += k[i] < mine || (k[i] == mine && i < t);
  keys[place] = mine;
  values[place] = v[t];
}
// out[k] = in[0] + ... + in[k - 1] for k = 0 .. n, n <= kSmallScanThreads * kSmallScanItems.
static __global__ void __launch_bounds__(kSmallScanThreads) small_scan_kernel(const std::uint32_t* in, std::uint32_t* out, unsigned n) {
  using Scan = cub::BlockScan<std::uint32_t, kSmallScanThreads>;
  __shared__ typename Scan::TempStorage temp;
  const unsigned first = threadIdx.x * kSmallScanItems;
  std::uint32_t item[kSmallScanItems], sum = 0;
  for (unsigned j = 0; j < kSmallScanItems; ++j) {
    item[j] = first + j < n ? in[first + j] : 0u;
    sum += item[j];
  }
  std::uint32_t before = 0, total = 0;
  Scan(temp).ExclusiveSum(sum, before, total);
  for (unsigned j = 0; j < kSmallScanItems; ++j) {
    if (first + j < n) out[first + j] = before;
    before += item[j];
  }
  if (threadIdx.x == 0) out[n] = total;
}

struct CudaDevice {
  static constexpr const char* kName = "cuda";
  static constexpr unsigned kBlock = 256;

  // A renderer's buffer for the draw list (render::DrawTarget), registered with CUDA (interop): the
  // kernels write it on the GPU, with no copy through the host. Needs the renderer's GL context current
  // and on this GPU (NVIDIA's OpenGL; Mesa's llvmpipe, say, cannot share its buffers). The registration
  // is kept with the buffer (DrawTarget::shared), which releases it before replacing or deleting it.
  struct GlRegistration final : render::DrawTarget::Shared {
    cudaGraphicsResource* resource = nullptr;
    ~GlRegistration() override {
      if (resource) cudaGraphicsUnregisterResource(resource);
    }
  };
  static cudaGraphicsResource* registered(render::DrawTarget& t, render::DrawTarget::Which which) {
    auto* r = dynamic_cast<GlRegistration*>(t.shared(which).get());
    return r ? r->resource : nullptr;
  }
  // Buffer `which` of the target, holding at least `bytes`, registered and mapped: its device address
  // (null, and why, where CUDA cannot share it).
  static void* map_gl(render::DrawTarget& t, render::DrawTarget::Which which, std::size_t bytes, std::string& why) {
    const auto fail = [&](const char* what, cudaError_t e) -> void* {
      why = std::string("CUDA cannot share the renderer's OpenGL buffers (") + what + ": " + cudaGetErrorString(e) +
            "); the draw list is copied through the host";
      cudaGetLastError();  // cleared: the step goes on
      return nullptr;
    };
    t.reserve(which, bytes);
    if (!registered(t, which)) {
      auto r = std::make_unique<GlRegistration>();
      const cudaError_t e = cudaGraphicsGLRegisterBuffer(&r->resource, t.buffer(which), cudaGraphicsRegisterFlagsWriteDiscard);
      if (e != cudaSuccess) {
        r->resource = nullptr;
        return fail("cudaGraphicsGLRegisterBuffer", e);
      }
      t.shared(which) = std::move(r);
    }
    cudaGraphicsResource* resource = registered(t, which);
    cudaError_t e = cudaGraphicsMapResources(1, &resource, 0);
    if (e != cudaSuccess) return fail("cudaGraphicsMapResources", e);
    void* p = nullptr;
    std::size_t size = 0;
    e = cudaGraphicsResourceGetMappedPointer(&p, &size, resource);
    if (e != cudaSuccess) {
      cudaGraphicsUnmapResources(1, &resource, 0);
      return fail("cudaGraphicsResourceGetMappedPointer", e);
    }
    return p;
  }
  // Unmapped: the kernels that wrote it are done before OpenGL draws from it (CUDA orders the graphics work
  // issued after the unmap after the stream's work before it).
  static void unmap_gl(render::DrawTarget& t, render::DrawTarget::Which which) {
    cudaGraphicsResource* resource = registered(t, which);
    cuda_check(cudaGraphicsUnmapResources(1, &resource, 0), "cudaGraphicsUnmapResources");
  }

  template <class T>
  class Buffer {
   public:
    Buffer() = default;
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;
    Buffer(Buffer&& o) noexcept
        : p_(std::exchange(o.p_, nullptr)), n_(std::exchange(o.n_, 0)), cap_(std::exchange(o.cap_, 0)) {}
    Buffer& operator=(Buffer&& o) noexcept {
      std::swap(p_, o.p_);
      std::swap(n_, o.n_);
      std::swap(cap_, o.cap_);
      return *this;
    }
    ~Buffer() {
      if (p_) cudaFree(p_);
      DeviceMemory::remove(cap_ * sizeof(T));
    }
    T* data() { return p_; }
    const T* data() const { return p_; }
    std::size_t size() const { return n_; }
    // Discards the contents; memory is allocated only when the buffer grows past what it has held (the lists
    // that change size every step reuse theirs), and then by grown_capacity (cudaMalloc and cudaFree wait
    // for the device). A GPU without the memory gives out_of_device_memory's error.
    void resize(std::size_t n) {
      if (n > cap_) {
        const std::size_t cap = grown_capacity(cap_, n), bytes = bytes_of<T>(cap);
        DeviceMemory::remove(cap_ * sizeof(T));
        const cudaError_t freed = p_ ? cudaFree(p_) : cudaSuccess;
        p_ = nullptr;
        n_ = cap_ = 0;
        cuda_check(freed, "cudaFree");
        if (const cudaError_t e = cudaMalloc(reinterpret_cast<void**>(&p_), bytes); e != cudaSuccess) {
          p_ = nullptr;
          if (e != cudaErrorMemoryAllocation) cuda_check(e, "cudaMalloc");
          cudaGetLastError();  // (not a sticky error: the device goes on)
          std::size_t free = 0, total = 0;
          if (cudaMemGetInfo(&free, &total) != cudaSuccess) {
            cudaGetLastError();
            free = total = 0;  // (unknown)
          }
          throw out_of_device_memory(bytes, free, total);
        }
        DeviceMemory::add(bytes);
        cap_ = cap;
      }
      n_ = n;
    }

   private:
    T* p_ = nullptr;
    std::size_t n_ = 0, cap_ = 0;
  };

  template <class T>
  static void upload(Buffer<T>& b, const T* src, std::size_t n) {
    b.resize(n);
    if (n) cuda_check(cudaMemcpy(b.data(), src, n * sizeof(T), cudaMemcpyHostToDevice), "upload");
  }
  template <class T, class A>
  static void upload(Buffer<T>& b, const std::vector<T, A>& src) {
    upload(b, src.data(), src.size());
  }
  // A small copy (the step's status) goes through page-locked memory, the quickest way back.
  template <class T>
  static void download(T* dst, const Buffer<T>& b, std::size_t n, std::size_t offset = 0) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes <= kStaging) return download_then(dst, b, n, offset, [] {});
    const auto t0 = std::chrono::steady_clock::now();
    cuda_check(cudaMemcpy(dst, b.data() + offset, bytes, cudaMemcpyDeviceToHost), "download");
    read_done(t0, timing().pending.size());
  }
  // A small download with after() launching more work behind the copy, before the host waits for the copy
  // (not for that work): the device is not idle while the host reads and decides what to launch next.
  template <class T, class F>
  static void download_then(T* dst, const Buffer<T>& b, std::size_t n, std::size_t offset, F&& after) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes > kStaging) throw std::logic_error("download_then: more than the staging memory holds");
    const std::size_t before = timing().pending.size();  // the launches timed before the copy (done after it)
    if (bytes) {
      const Staging& staging = staging_memory();
      cuda_check(cudaMemcpyAsync(staging.memory, b.data() + offset, bytes, cudaMemcpyDeviceToHost), "download");
      cuda_check(cudaEventRecord(staging.copied), "download");
      after();
      const auto t0 = std::chrono::steady_clock::now();
      cuda_check(cudaEventSynchronize(staging.copied), "download");
      std::memcpy(static_cast<void*>(dst), staging.memory, bytes);
      read_done(t0, before);
    } else {  // (no copy, so no wait: nothing launched is known to have run)
      after();
      read_done(std::chrono::steady_clock::now(), 0);
    }
  }
  template <class T>
  static void fill(Buffer<T>& b, const T& value) {
    const std::size_t n = b.size();
    if (n == 0) return;
    fill_kernel<<<static_cast<unsigned>((n + kBlock - 1) / kBlock), kBlock>>>(b.data(), n, value);
    launched("fill");
  }
  // to[0 .. n - 1] = from[0 .. n - 1], both on the device.
  template <class T>
  static void copy(T* to, const T* from, std::size_t n) {
    if (n) cuda_check(cudaMemcpyAsync(to, from, n * sizeof(T), cudaMemcpyDeviceToDevice), "copy");
  }

  template <class K>
  static void launch(std::size_t n, const K& kernel) {
    if (n == 0) return;
    static const std::string name = DeviceProfile::name_of<K>();
    timed(name, [&] { run_kernel<<<static_cast<unsigned>((n + kBlock - 1) / kBlock), kBlock>>>(kernel, n); });
    launched(name);
  }

  // kernel(phase, k) for its phases in turn (host_device.hpp): one block of kBlock threads.
  template <class K>
  static void launch_block(const K& kernel) {
    static const std::string name = DeviceProfile::name_of<K>();
    timed(name, [&] { run_block_kernel<<<1, kBlock>>>(kernel); });
    launched(name);
  }

  // kernel(k) for k < n (as launch), each giving a Reduced: *max_to becomes the largest of it and theirs
  // (each taken as 0 where not > 0), *min_to the smallest (null: not wanted). Blocks of kBlock threads.
  template <class K>
  static void launch_reduce(std::size_t n, const K& kernel, float* max_to, std::uint32_t* min_to) {
    static_assert(kBlock == 256, "run_reduce_kernel's shared arrays hold 8 warps");
    if (n == 0) return;
    static const std::string name = DeviceProfile::name_of<K>();
    const unsigned blocks = static_cast<unsigned>((n + kBlock - 1) / kBlock);
    timed(name, [&] {
      if constexpr (requires { kernel.sm_blocks; }) {  // the blocks it asks for on a multiprocessor: 2, 3 or 4
        if (kernel.sm_blocks == 2) run_bounded_reduce_kernel<2><<<blocks, kBlock>>>(kernel, n, max_to, min_to);
        else if (kernel.sm_blocks == 4) run_bounded_reduce_kernel<4><<<blocks, kBlock>>>(kernel, n, max_to, min_to);
        else run_bounded_reduce_kernel<3><<<blocks, kBlock>>>(kernel, n, max_to, min_to);
      } else
        run_reduce_kernel<<<blocks, kBlock>>>(kernel, n, max_to, min_to);
    });
    launched(name);
  }

  // out[k] = in[0] + ... + in[k - 1] for k = 0 .. n (out[n]: the total); in and out are different arrays.
  static void exclusive_scan(const std::uint32_t* in, std::uint32_t* out, std::size_t n) {
    if (n <= std::size_t{kSmallScanThreads} * kSmallScanItems) {
      static const std::string small = "scan, one block";
      timed(small, [&] { small_scan_kernel<<<1, kSmallScanThreads>>>(in, out, static_cast<unsigned>(n)); });
      launched(small);
      return;
    }
    cuda_check(cudaMemsetAsync(out, 0, sizeof(std::uint32_t)), "scan");
    std::size_t bytes = 0;
    cuda_check(cub::DeviceScan::InclusiveSum(nullptr, bytes, in, out + 1, n), "scan");
    static const std::string name = "scan";
    timed(name, [&] { cuda_check(cub::DeviceScan::InclusiveSum(scratch(bytes), bytes, in, out + 1, n), "scan"); });
  }
  // A stable radix sort of (keys, values) by the key's low key_bits bits (every key is below 2^key_bits).
  template <class Key>
  static void stable_sort_by_key(Key* keys, std::uint32_t* values, std::size_t n, int key_bits) {
    if (n == 0) return;
    if (n <= kSmallSort) {
      static const std::string small = "sort, one block";
      timed(small, [&] { small_sort_kernel<<<1, kSmallSort>>>(keys, values, static_cast<unsigned>(n)); });
      launched(small);
      return;
    }
    Sorted& o = sorted();
    o.keys.resize(n * sizeof(Key));
    o.values.resize(n);
    Key* keys_out = reinterpret_cast<Key*>(o.keys.data());
    std::size_t bytes = 0;
    cuda_check(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys, keys_out, values, o.values.data(), n, 0, key_bits),
               "sort");
    void* temp = scratch(bytes);
    static const std::string name = "sort";
    timed(name, [&] {
      cuda_check(cub::DeviceRadixSort::SortPairs(temp, bytes, keys, keys_out, values, o.values.data(), n, 0, key_bits), "sort");
    });
    cuda_check(cudaMemcpyAsync(keys, keys_out, n * sizeof(Key), cudaMemcpyDeviceToDevice), "sort");
    cuda_check(cudaMemcpyAsync(values, o.values.data(), n * sizeof(std::uint32_t), cudaMemcpyDeviceToDevice), "sort");
  }
  // The profile (MCA_PROFILE): the device's time of each launch and primitive, from CUDA events around it,
  // read at the next copy to the host (which waits for them).
  static void print_profile(const char* backend, std::int64_t steps, std::int64_t rebuilds) {
    Timing& t = timing();
    if (!t.profile.on()) return;
    if (cudaDeviceSynchronize() == cudaSuccess) t.resolve(t.pending.size());
    t.profile.print(backend, steps, rebuilds);
  }

 private:
  struct Timing {
    DeviceProfile profile;
    std::vector<cudaEvent_t> pool;
    std::vector<std::pair<const std::string*, std::pair<cudaEvent_t, cudaEvent_t>>> pending;
    cudaEvent_t event() {
      if (pool.empty()) {
        cudaEvent_t e = nullptr;
        cuda_check(cudaEventCreate(&e), "cudaEventCreate");
        return e;
      }
      const cudaEvent_t e = pool.back();
      pool.pop_back();
      return e;
    }
    // The first `done` launches timed, which have run (those after them may still run: they stay pending).
    void resolve(std::size_t done) {
      for (std::size_t k = 0; k < done; ++k) {
        const auto& [name, ev] = pending[k];
        float ms = 0;
        if (cudaEventElapsedTime(&ms, ev.first, ev.second) == cudaSuccess) profile.add(*name, 1e-3 * ms);
        pool.push_back(ev.first);
        pool.push_back(ev.second);
      }
      pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(done));
    }
  };
  static Timing& timing() {
    static thread_local Timing t;  // (per host thread, as the staging memory)
    return t;
  }
  // A copy to the host, waited for since `since`, is done: counted with the wait, and the launches timed
  // before it (the first `before` of those pending) resolved (MCA_PROFILE).
  static void read_done(std::chrono::steady_clock::time_point since, std::size_t before) {
    Timing& t = timing();
    if (t.profile.on()) {
      t.profile.read();
      t.profile.waited(std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count());
      t.resolve(before);
    }
  }
  template <class F>
  static void timed(const std::string& name, F&& f) {
    Timing& t = timing();
    if (!t.profile.on()) return f();
    const cudaEvent_t a = t.event(), b = t.event();
    cuda_check(cudaEventRecord(a), "cudaEventRecord");
    f();
    cuda_check(cudaEventRecord(b), "cudaEventRecord");
    t.pending.push_back({&name, {a, b}});
  }

  // Page-locked memory for small copies, and the event that marks a copy done: per host thread (Python steps
  // simulations in threads of their own, the interpreter's lock released).
  static constexpr std::size_t kStaging = 4096;
  struct Staging {
    void* memory = nullptr;
    cudaEvent_t copied = nullptr;
    Staging() {
      cuda_check(cudaMallocHost(&memory, kStaging), "cudaMallocHost");
      cuda_check(cudaEventCreateWithFlags(&copied, cudaEventDisableTiming), "cudaEventCreate");
    }
    Staging(const Staging&) = delete;
    Staging& operator=(const Staging&) = delete;
    ~Staging() {
      if (copied) cudaEventDestroy(copied);
      if (memory) cudaFreeHost(memory);
    }
  };
  static const Staging& staging_memory() {
    static thread_local const Staging s;
    return s;
  }

  // The primitives' scratch memory and the sort's output, per host thread, grown as needed and kept.
  struct Sorted {
    Buffer<unsigned char> keys;
    Buffer<std::uint32_t> values;
  };
  static Sorted& sorted() {
    static thread_local Sorted s;
    return s;
  }
  static void* scratch(std::size_t bytes) {
    static thread_local Buffer<unsigned char> b;
    b.resize(bytes ? bytes : 1);
    return b.data();
  }
};

}  // namespace mca::gpu
