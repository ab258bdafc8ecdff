#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/CMakeLists.txt, into build/fuzz) and runs each for SECONDS
# (default 60). See fuzz/README.md.
#
#   scripts/fuzz.sh [-p] [-s] [SECONDS] [TARGET...]
#
#   SECONDS   how long each target runs (default 60; e.g. 600 for ten minutes)
#   TARGET    scene, mesh or both (default: both, one after the other)
#   -p        run the targets in parallel (one core each) instead of one after the other
#   -s        stop a target at its first finding (plain libFuzzer). Without it a target runs in libFuzzer's
#             fork mode (-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1): it keeps fuzzing for
#             the whole time after a finding, so that a known bug (in assimp, say) does not end the run.
#
# Each target works on a scratch corpus, build/fuzz/corpus/<target>/, kept between runs and topped up
# from fuzz/seeds/<target>/ (which is only read). Crashes, leaks, timeouts and out-of-memory inputs are
# written to build/fuzz/findings/<target>/; the log of the last run is build/fuzz/logs/<target>.log.
# Exit status: 0 when nothing was found, 1 on a finding, 2 on a usage or set-up error.
# MCA_FUZZ_CXX names another clang++ with libFuzzer (default clang++-14).
# MCA_FUZZ_RUNS=N runs each target for N inputs from a fixed random seed instead of for SECONDS, as CI does
# (.ci/run); a finding then counts only if it fails again when replayed alone (see below).
# The mesh target runs without leak detection: assimp leaks on some refused files (fuzz/findings/);
# MCA_FUZZ_LEAKS=1 turns it on.
set -euo pipefail
cd "$(dirname "$0")/.."

parallel=0
stop=0
while [[ "${1:-}" == -* ]]; do
  case "$1" in
    -p) parallel=1 ;;
    -s) stop=1 ;;
    *)
      echo "usage: scripts/fuzz.sh [-p] [-s] [SECONDS] [scene] [mesh]" >&2
      exit 2
      ;;
  esac
  shift
done
seconds=60
if [[ $# -gt 0 && "$1" =~ ^[0-9]+$ ]]; then
  seconds=$1
  shift
fi
targets=("$@")
[[ ${#targets[@]} -eq 0 ]] && targets=(scene mesh)
for t in "${targets[@]}"; do
  case "$t" in
    scene | mesh) ;;
    *)
      echo "usage: scripts/fuzz.sh [-p] [-s] [SECONDS] [scene] [mesh]" >&2
      exit 2
      ;;
  esac
done

CXX=${MCA_FUZZ_CXX:-clang++-14}
missing() {
  echo "fuzz.sh: $1" >&2
  echo "fuzz.sh: install the fuzzing toolchain: apt-get install clang-14 libfuzzer-14-dev" >&2
  exit 2
}
command -v "$CXX" > /dev/null || missing "$CXX not found"
command -v cmake > /dev/null || { echo "fuzz.sh: cmake not found (apt-get install cmake ninja-build)" >&2; exit 2; }
# libFuzzer and the sanitizer runtimes: link a trivial target the way the real ones are linked.
probe_dir=$(mktemp -d)
trap 'rm -rf "$probe_dir"' EXIT
printf '#include <cstddef>\n#include <cstdint>\nextern "C" int LLVMFuzzerTestOneInput(const std::uint8_t*, std::size_t) { return 0; }\n' \
  > "$probe_dir/probe.cpp"
if ! "$CXX" -fsanitize=fuzzer,address,undefined "$probe_dir/probe.cpp" -o "$probe_dir/probe" 2> "$probe_dir/err"; then
  sed 's/^/  /' "$probe_dir/err" >&2
  missing "$CXX cannot link a libFuzzer target (-fsanitize=fuzzer,address,undefined): libFuzzer is missing"
fi

build=build/fuzz
generator=()
if [[ ! -f "$build/CMakeCache.txt" ]] && command -v ninja > /dev/null; then generator=(-G Ninja); fi
echo "== configuring and building $build"
cmake -S fuzz -B "$build" "${generator[@]}" -DCMAKE_CXX_COMPILER="$CXX" > "$probe_dir/cmake.log" 2>&1 ||
  { cat "$probe_dir/cmake.log" >&2; echo "fuzz.sh: configuring fuzz/ failed" >&2; exit 2; }
grep -i 'warning' -A2 "$probe_dir/cmake.log" || true
cmake --build "$build" -j "$(nproc)"

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
if command -v llvm-symbolizer-14 > /dev/null; then export ASAN_SYMBOLIZER_PATH=${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer-14)}; fi

# Runs one target; writes its summary to $build/logs/<target>.summary and returns 1 on a finding.
run_target() {
  local t=$1 bin=$build/fuzz_$1
  local corpus=$build/corpus/$t findings=$build/findings/$t log=$build/logs/$t.log
  mkdir -p "$corpus" "$findings" "$build/logs"
  local summary=$build/logs/$t.summary
  if [[ ! -x "$bin" ]]; then
    echo "$t: not built (fuzz_$t missing; for mesh: src/mesh/mesh.cpp with read_mesh_memory is needed): skipped" \
      | tee "$summary"
    return 0
  fi
  # Seeds are copied into the scratch corpus (never the other way: libFuzzer writes into its first
  # corpus folder, which must not be fuzz/seeds).
  cp -f fuzz/seeds/"$t"/* "$corpus"/
  local args=(-timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048
              -print_final_stats=1 -close_fd_mask=1 -artifact_prefix="$findings/")
  if [[ -n "${MCA_FUZZ_RUNS:-}" ]]; then
    args+=(-runs="$MCA_FUZZ_RUNS" -seed=1)
  else
    args+=(-max_total_time="$seconds")
    [[ $stop -eq 0 ]] && args+=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
  fi
  local asan=$ASAN_OPTIONS
  if [[ "$t" == mesh && "${MCA_FUZZ_LEAKS:-0}" != 1 ]]; then
    args+=(-detect_leaks=0)
    asan=${asan//detect_leaks=1/detect_leaks=0}
  fi
  case "$t" in
    scene) args+=(-max_len=16384 -dict=fuzz/scene.dict) ;;
    mesh) args+=(-max_len=32768) ;;
  esac
  local before after rc=0
  before=$(find "$findings" -maxdepth 1 -type f | wc -l)
  local marker=$build/logs/$t.start
  touch "$marker"
  local how="$seconds s"
  [[ -n "${MCA_FUZZ_RUNS:-}" ]] && how="$MCA_FUZZ_RUNS inputs (seed 1)"
  echo "== $t: fuzzing for $how (log: $log)"
  ASAN_OPTIONS=$asan "$bin" "${args[@]}" "$corpus" > "$log" 2>&1 || rc=$?
  local execs eps cov corp last
  # Plain mode ends with stat:: lines; fork mode prints "#EXECS: cov: N ft: N corp: N exec/s N
  # oom/timeout/crash: a/b/c time: Ns job: N ..." after each job.
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  eps=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  last=$(grep -E '^#[0-9]+: cov: ' "$log" | tail -1 || true)
  if [[ -z "$execs" && -n "$last" ]]; then
    execs=$(sed -E 's/^#([0-9]+):.*/\1/' <<< "$last")
    local secs
    secs=$(sed -nE 's/.* time: ([0-9]+)s.*/\1/p' <<< "$last")
    [[ -n "$secs" && "$secs" -gt 0 ]] && eps=$((execs / secs))
  fi
  # A fixed-seed run (CI) counts only what fails again when replayed alone. An input that passes alone
  # (three tries) failed on heap state earlier inputs left: assimp is not instrumented, so an input that
  # corrupts its heap goes unseen until ASan trips over the damage later (fuzz/findings/README.md,
  # "not reproducible alone"). Such inputs are kept in $findings/unreproduced/ and reported, not counted;
  # mca's own code is instrumented and fails on the input that does the damage.
  local unreproduced=""
  if [[ -n "${MCA_FUZZ_RUNS:-}" ]]; then
    local fresh f k again=0
    fresh=$(find "$findings" -maxdepth 1 -type f -newer "$marker" 2> /dev/null | sort)
    if [[ -n "$fresh" ]]; then
      local replay_args=(-timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048)
      [[ " ${args[*]} " == *" -detect_leaks=0 "* ]] && replay_args+=(-detect_leaks=0)
      while IFS= read -r f; do
        for k in 1 2 3; do
          ASAN_OPTIONS=$asan "$bin" "${replay_args[@]}" -artifact_prefix="$build/logs/$t.replay-" "$f" \
            > "$log.replay" 2>&1 || again=1
        done
      done <<< "$fresh"
      if [[ $again -eq 0 ]]; then
        mkdir -p "$findings/unreproduced"
        mv $fresh "$findings/unreproduced/"
        unreproduced=$fresh
        rc=0
      fi
    fi
  fi
  after=$(find "$findings" -maxdepth 1 -type f | wc -l)
  cov=$(grep -oE 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -1 || true)
  corp=$(grep -oE 'corp: [0-9]+(/[0-9]+[a-zA-Z]*)?' "$log" | tail -1 || true)
  {
    echo "$t: ${execs:-?} executions, ${eps:-?} exec/s, ${cov:-cov: ?}, ${corp:-corp: ?} (exit status $rc)"
    grep -oE 'oom/timeout/crash: [0-9]+/[0-9]+/[0-9]+' "$log" | tail -1 | sed "s/^/$t: /" || true
    if [[ $rc -ne 0 || $after -gt $before ]]; then
      local new
      new=$(find "$findings" -type f -newer "$marker" 2> /dev/null | sort || true)
      echo "$t: FOUND something: $(grep -c . <<< "$new") new file(s) in $findings/ ($(sed -E 's|.*/||; s|-.*||' <<< "$new" |
        sort | uniq -c | awk '{printf "%s%s %s", (NR > 1 ? ", " : ""), $1, $2}'))"
      head -10 <<< "$new" | sed 's/^/  /'
      [[ $(grep -c . <<< "$new") -gt 10 ]] && echo "  ..."
      grep -E '^==[0-9]+== ?ERROR|runtime error:|^fuzz_[a-z]+:|deadly signal|out-of-memory|terminate called' \
        "$log" | sed -E 's/^==[0-9]+== ?//; s/ on (unknown )?address.*//; s/ \(pc 0x.*//' | sort | uniq -c | sort -rn |
        head -8 | sed 's/^/  /' || true
      echo "  reproduce: $bin <input>   (full report in $log)"
    else
      echo "$t: nothing found"
    fi
    if [[ -n "$unreproduced" ]]; then
      echo "$t: not counted: $(grep -c . <<< "$unreproduced") input(s) failed in the run but pass when replayed alone (heap state left by earlier inputs; see fuzz/findings/README.md), kept in $findings/unreproduced/:"
      grep -E '^==[0-9]+== ?ERROR|CHECK failed|runtime error:|deadly signal' "$log" | head -3 | sed 's/^/  /' || true
    fi
  } > "$summary"
  cat "$summary"
  [[ $rc -eq 0 && $after -eq $before ]]
}

status=0
if [[ $parallel -eq 1 ]]; then
  pids=()
  for t in "${targets[@]}"; do
    run_target "$t" & pids+=($!)
  done
  for p in "${pids[@]}"; do wait "$p" || status=1; done
else
  for t in "${targets[@]}"; do run_target "$t" || status=1; done
fi

echo "== summary"
for t in "${targets[@]}"; do cat "$build/logs/$t.summary"; done
exit $status
