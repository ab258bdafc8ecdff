#!/usr/bin/env bash
# The CUDA backend on a GPU machine: bitwise against the CPU, two CUDA runs equal, compute-sanitizer on a
# short scene, the benchmarks. Such a machine has the NVIDIA driver but none of the Debian libraries mca
# links, so the programs travel as a bundle built here:
#
#   scripts/gpu_check.sh --bundle FILE.tar.xz   on the build machine (after the release build): mca,
#                                               mca_tests, every library ldd lists, ld-linux-x86-64.so.2
#                                               and the cow, bunny and armadillo models, compressed (about
#                                               20 MB;
#                                               gpu_bundle.tar.xz at the repository root is ignored by git:
#                                               carry it)
#   scripts/gpu_check.sh FILE.tar.xz OUT        on the GPU machine, in the repository root: unpacks it,
#                                               runs the checks, writes logs and OUT/summary.txt (under 4
#                                               minutes); exits 0 only when every CudaDevice test ran and
#                                               passed and a checkpoint resumed across backends gave the
#                                               same bits (3 when the tests were skipped: no GPU)
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ "${1:-}" == "--bundle" ]]; then
  file=${2:?usage: scripts/gpu_check.sh --bundle FILE.tar.xz}
  build=build/release
  [[ -x $build/mca && -x $build/tests/mca_tests ]] || { echo "gpu_check: build first (cmake --build --preset release)" >&2; exit 2; }
  stage=$(mktemp -d)
  trap 'rm -rf "$stage"' EXIT
  dir=$stage/bundle
  mkdir -p "$dir/lib" "$dir/models"
  cp "$build/mca" "$build/tests/mca_tests" "$dir/"
  for exe in "$build/mca" "$build/tests/mca_tests"; do
    ldd "$exe" | awk '/=> \// {print $3} /^\t\/lib64\// {print $1}' | while read -r lib; do
      cp -L "$lib" "$dir/lib/"
    done
  done
  cp -L /lib64/ld-linux-x86-64.so.2 "$dir/lib/"
  # The device's copy bandwidth (the ceiling in docs/benchmarks.md), built with nvcc ($NVCC, else CUDA's).
  "${NVCC:-/usr/local/cuda/bin/nvcc}" -O2 -arch=sm_80 -o "$dir/copy_bandwidth" scripts/copy_bandwidth.cu
  # libepoxy opens OpenGL and EGL at run time (ldd does not list them): bring GLVND's vendor-neutral
  # dispatchers, which then load the GPU machine's own driver (NVIDIA's EGL), never Mesa's.
  for lib in libEGL.so.1 libGLdispatch.so.0 libOpenGL.so.0 libGL.so.1 libGLX.so.0; do
    cp -L "/usr/lib/x86_64-linux-gnu/$lib" "$dir/lib/" ||
      echo "gpu_check: no $lib here (Debian's libglvnd0 and libegl1): the zero-copy test will be skipped" >&2
  done
  for m in cow.off bunny00.off armadillo.off; do
    cp -L "${HOME}/.cache/mca/models/$m" "$dir/models/" 2>/dev/null ||
      echo "gpu_check: no $m in ~/.cache/mca/models (scripts/get_models.sh): its checks will be skipped" >&2
  done
  tar -cJf "$file.tmp" -C "$stage" bundle
  mv "$file.tmp" "$file"
  ls -la "$file"
  exit 0
fi

bundle=${1:?usage: scripts/gpu_check.sh FILE.tar.xz OUT (or --bundle FILE.tar.xz)}
out=${2:?usage: scripts/gpu_check.sh FILE.tar.xz OUT}
mkdir -p "$out"
out=$(cd "$out" && pwd)
unpacked=$(mktemp -d)
trap 'rm -rf "$unpacked"' EXIT
tar -xJf "$bundle" -C "$unpacked"
dir=$unpacked/bundle
# The bundle's libraries first, then the driver's own where the machine keeps them apart.
libpath=$dir/lib
for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib /usr/lib/x86_64-linux-gnu; do
  [[ -d $d ]] && libpath=$libpath:$d
done
# GLVND finds NVIDIA's EGL through a vendor file; some machines keep it outside GLVND's search path.
if [[ -z ${__EGL_VENDOR_LIBRARY_FILENAMES:-} ]]; then
  for f in /usr/share/glvnd/egl_vendor.d/10_nvidia.json /etc/glvnd/egl_vendor.d/10_nvidia.json \
    /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json; do
    if [[ -f $f ]]; then export __EGL_VENDOR_LIBRARY_FILENAMES=$f; break; fi
  done
fi
# A bundled program runs through the bundle's loader: "${loader[@]}" PROGRAM ARGS (also under timeout and
# compute-sanitizer, which cannot call a function).
loader=("$dir/lib/ld-linux-x86-64.so.2" --library-path "$libpath")
run() { "${loader[@]}" "$@"; }
export MCA_MESH_PATH="$dir/models"
export MCA_SCENES="$PWD/scenes"  # the tests' scene files, from this copy of the repository
summary="$out/summary.txt"
: >"$summary"
note() { echo "$*" | tee -a "$summary"; }

note "gpu_check $(date -u +%FT%TZ) on $(hostname)"
nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.sm,clocks.mem --format=csv,noheader 2>&1 | tee -a "$summary" || true
note "EGL vendor file: ${__EGL_VENDOR_LIBRARY_FILENAMES:-none found}; driver libraries: $( (ldconfig -p 2>/dev/null | grep -oE '(libcuda|libEGL_nvidia)\.so[^ ]*' | sort -u | tr '\n' ' ') || true)"
run "$dir/mca" info --json >"$out/info.json" 2>&1 || true
note "mca info: $(grep -oE '"(backend|cuda_device)": *"[^"]*"' "$out/info.json" | tr '\n' ' ' || echo '?')"

# 1. The device against the CPU, bit for bit (the first differing field, step and index where not), two
#    CUDA runs equal, and momentum and energy on the device: the CudaDevice tests.
set +e
timeout 150 "${loader[@]}" "$dir/mca_tests" \
  --gtest_filter='CudaDevice.*' >"$out/tests.log" 2>&1
tests_rc=$?
set -e
passed=$(grep -c '^\[       OK \] .*ms)$' "$out/tests.log" || true)
failed=$(grep -c '^\[  FAILED  \] .*ms)$' "$out/tests.log" || true)
skipped=$(grep -c '^\[  SKIPPED \] .*ms)$' "$out/tests.log" || true)
note "CudaDevice tests: exit $tests_rc; $passed passed, $failed failed, $skipped skipped"
grep -E 'equal bit for bit|differs|SKIPPED|Failure' "$out/tests.log" | head -20 | tee -a "$summary" || true

# 1b. The draw list written by CUDA into the renderer's OpenGL buffers (zero copy): needs the driver's
#     OpenGL (EGL); reported apart, a machine without it skips the test.
set +e
timeout 60 "${loader[@]}" "$dir/mca_tests" \
  --gtest_filter='CudaDeviceGl.*' >"$out/tests_gl.log" 2>&1
note "CudaDeviceGl test (zero-copy drawing): exit $?; $(grep -cE '^\[       OK \] .*ms\)$' "$out/tests_gl.log") passed, $(grep -cE '^\[  SKIPPED \] .*ms\)$' "$out/tests_gl.log") skipped"
grep -E 'no OpenGL|cannot share|differs|Failure' "$out/tests_gl.log" | head -5 | tee -a "$summary"
set -e

# 1c. A run checkpointed on one backend resumes on the other with the same bits: 6,000 steps of the default
#     scene straight on each, and each one's run continued on the other from its first checkpoint (frame 1,
#     step 4,845; the last one, of the finished run, removed).
hash_of() { (grep -o '"state_hash": *"[^"]*"' "$1/summary.json" 2>/dev/null || true) | cut -d'"' -f4; }
resume_ok=1
for pair in "cpu cuda" "cuda cpu"; do
  set -- $pair
  d=$unpacked/resume_$1
  set +e
  timeout 60 "${loader[@]}" "$dir/mca" run --steps 6000 --checkpoint-every 1 \
    --no-vtk -q --backend "$1" --out "$d" >>"$out/resume.log" 2>&1
  cp -r "$d" "${d}_resumed" 2>/dev/null
  rm -f "${d}_resumed/summary.json" "$(ls "${d}_resumed"/checkpoints/*.mcack 2>/dev/null | sort | tail -1)"
  timeout 60 "${loader[@]}" "$dir/mca" resume "${d}_resumed" --backend "$2" \
    >>"$out/resume.log" 2>&1
  set -e
  straight=$(hash_of "$d") resumed=$(hash_of "${d}_resumed")
  [[ -n $straight && $straight == "$resumed" ]] || resume_ok=0
  note "6,000 steps on $1: state_hash ${straight:-none}; continued on $2 from $1's checkpoint at step 4,845: ${resumed:-none}"
done
[[ $(hash_of "$unpacked/resume_cpu") == "$(hash_of "$unpacked/resume_cuda")" ]] || resume_ok=0
note "resume across backends: $([[ $resume_ok == 1 ]] && echo "the same bits" || echo "DIFFERENT (resume.log)")"

# 2. compute-sanitizer on a short run of the default scene (out-of-bounds accesses, races in shared use).
if command -v compute-sanitizer >/dev/null; then
  set +e
  timeout 60 compute-sanitizer --tool memcheck --error-exitcode 9 "${loader[@]}" \
    "$dir/mca" run --backend cuda --steps 200 --no-vtk -q --out "$unpacked/sanitized" >"$out/memcheck.log" 2>&1
  note "compute-sanitizer memcheck: exit $? ($(tail -1 "$out/memcheck.log"))"
  # Shared memory's races in the one-block kernels (small sorts and scans, the projectile pass's end): their
  # own test, then a run (its progress in the log: how far it came).
  timeout 60 compute-sanitizer --tool racecheck --error-exitcode 9 "${loader[@]}" \
    "$dir/mca_tests" --gtest_filter='CudaDevice.TheSortsScansAndBlockLaunchesAreTheirSerialResults' >"$out/racecheck.log" 2>&1
  note "compute-sanitizer racecheck, the one-block primitives' test: exit $? ($(tail -1 "$out/racecheck.log"))"
  # (MCA_CUDA_SYNC=1: each launch waited for, so a kernel that fails is named; an earlier 100-step run under
  # racecheck ended with exit 11 and no message.)
  MCA_CUDA_SYNC=1 timeout 90 compute-sanitizer --tool racecheck --error-exitcode 9 "${loader[@]}" \
    "$dir/mca" run --backend cuda --steps 100 --no-vtk --out "$unpacked/racechecked" >"$out/racecheck_run.log" 2>&1
  note "compute-sanitizer racecheck, 100 steps of the default scene: exit $? ($(tail -1 "$out/racecheck_run.log"))"
  # Device memory read before it is written (the emulation fills fresh arrays with 0xFF bytes, a GPU leaves
  # what was there), on the first steps of the default scene.
  MCA_CUDA_SYNC=1 timeout 60 compute-sanitizer --tool initcheck --error-exitcode 9 "${loader[@]}" \
    "$dir/mca" run --backend cuda --steps 60 --no-vtk -q --out "$unpacked/initchecked" >"$out/initcheck.log" 2>&1
  note "compute-sanitizer initcheck, 60 steps of the default scene: exit $? ($(tail -1 "$out/initcheck.log"))"
  set -e
else
  note "compute-sanitizer: not on this machine"
fi

note "(${SECONDS} s so far)"
# 3. The benchmarks on the device (contacts and breaking active; floors 4 G automaton-steps/s for wall_357k,
#    5 G for wall_2m), the device's time per kernel (MCA_PROFILE), and the CPU's on this machine's cores.
set +e
timeout 120 "${loader[@]}" "$dir/mca" bench wall_357k wall_2m --backend cuda \
  --repeats 5 --steps 1000 >"$out/bench_cuda.txt" 2>&1
note "bench cuda (exit $?):"
grep -E 'wall_357k|wall_2m|machine' "$out/bench_cuda.txt" | tail -4 | tee -a "$summary"
# The same with the links and automata kernels apart (MCA_CUDA_LATTICE=split), the fused kernel's A/B,
# and with the fused kernel's registers bounded for 2 and 4 blocks a multiprocessor (the default: 3).
for how in split fused:2 fused:4; do
  MCA_CUDA_LATTICE=$how timeout 90 "${loader[@]}" "$dir/mca" bench wall_357k wall_2m --backend cuda \
    --repeats 3 --steps 1000 >"$out/bench_cuda_${how/:/}.txt" 2>&1
  note "bench cuda, MCA_CUDA_LATTICE=$how (exit $?):"
  grep -E 'wall_357k|wall_2m' "$out/bench_cuda_${how/:/}.txt" | tail -2 | tee -a "$summary"
done
MCA_PROFILE=1 timeout 60 "${loader[@]}" "$dir/mca" bench wall_357k --backend cuda \
  --repeats 1 --steps 200 >"$out/profile_cuda.txt" 2>&1
note "profile cuda, wall_357k (exit $?; the whole table in profile_cuda.txt):"
grep -A14 'profile over' "$out/profile_cuda.txt" | tee -a "$summary"
# (Where the host waits little for the device at its reads, a step is bound by the host's launches.)
grep -E 'host waited|device arrays|automaton-steps/s' "$out/profile_cuda.txt" | tee -a "$summary"
# The armadillo drawn as triangles, 100 steps per frame (floor 60 frames/s), and as cubes.
timeout 90 "${loader[@]}" "$dir/mca" bench --render armadillo_surface \
  armadillo_cubes --backend cuda --steps 100 --frames 10 >"$out/bench_render.txt" 2>&1
note "bench render cuda (exit $?):"
tail -5 "$out/bench_render.txt" | tee -a "$summary"
# The ceiling: the device's copy bandwidth; and the three lattice kernels through Nsight Compute (DRAM and
# L2 traffic, occupancy), where ncu is on the machine.
run "$dir/copy_bandwidth" >"$out/copy_bandwidth.txt" 2>&1
note "$(cat "$out/copy_bandwidth.txt")"
if command -v ncu >/dev/null; then
  timeout 120 ncu --clock-control none --kernel-name-base demangled -k 'regex:ManyBodyKernel|FusedLatticeKernel' \
    --launch-skip 20 --launch-count 2 --section SpeedOfLight --section MemoryWorkloadAnalysis --section Occupancy \
    "${loader[@]}" "$dir/mca" bench wall_357k --backend cuda --repeats 1 \
    --steps 40 >"$out/ncu.txt" 2>&1
  note "ncu, wall_357k's lattice kernels (exit $?; the whole report in ncu.txt):"
  grep -E 'run_(bounded_)?(reduce_)?kernel|Duration|DRAM Throughput|Memory Throughput|L2 Hit Rate|Achieved Occupancy|Mem Busy' \
    "$out/ncu.txt" | sed 's/^ *//' | tee -a "$summary"
else
  note "ncu: not on this machine"
fi
timeout 60 "${loader[@]}" "$dir/mca" bench wall_357k --backend cpu \
  --repeats 3 --steps 20 >"$out/bench_cpu.txt" 2>&1
note "bench cpu (exit $?):"
tail -2 "$out/bench_cpu.txt" | tee -a "$summary"
note "gpu_check took ${SECONDS} s"
set -e
if [[ $tests_rc -ne 0 ]]; then exit "$tests_rc"; fi
if [[ $skipped -ne 0 ]]; then
  note "NOT CHECKED: $skipped CudaDevice tests were skipped (see tests.log: no GPU, or no models)"
  exit 3
fi
if [[ $resume_ok -ne 1 ]]; then exit 4; fi
note "every CudaDevice test ran and passed; a checkpoint resumed across backends gave the same bits"
