#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, AddressSanitizer + UndefinedBehaviorSanitizer) in
# build/fuzz and runs each of them for SECONDS (default 60) from its seed corpus.
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
#   targets: fuzz_mesh_reader fuzz_scene_reader fuzz_topology_ops (default: all three)
# New interesting inputs go to build/fuzz/corpus/<target>/ (never into fuzz/corpus/); crashes to
# build/fuzz/artifacts/<target>/ (replay one with: build/fuzz/fuzz/<target> FILE). A long run:
#   scripts/fuzz.sh 3600
# Needs clang++ with libFuzzer (Debian: clang-14, libclang-rt-14-dev); CUTSIM_JOBS sets -j.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(fuzz_mesh_reader fuzz_scene_reader fuzz_topology_ops)
build="$root/build/fuzz"

if [ ! -f "$build/build.ninja" ]; then
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCUTSIM_FUZZ=ON -DCUTSIM_BUILD_TESTS=OFF -DCUTSIM_BUILD_BENCHMARKS=OFF \
    -DCUTSIM_BUILD_EXAMPLES=OFF -DCUTSIM_NATIVE=OFF
fi
cmake --build "$build" -j "${CUTSIM_JOBS:-2}" --target "${targets[@]}"

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
status=0
for t in "${targets[@]}"; do
  mkdir -p "$build/corpus/$t" "$build/artifacts/$t"
  echo "== $t: $seconds s"
  if ! "$build/fuzz/$t" -max_total_time="$seconds" -timeout=25 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$build/artifacts/$t/" \
      "$build/corpus/$t" "$root/fuzz/corpus/$t" 2>"$build/$t.log"; then
    echo "$t FAILED: see $build/$t.log and $build/artifacts/$t/" >&2
    status=1
  fi
  grep -E "^stat::(number_of_executed_units|average_exec_per_sec|new_units_added|peak_rss_mb)" \
    "$build/$t.log" || true
done
exit $status
