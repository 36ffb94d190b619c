#!/usr/bin/env bash
# Configures (once) and builds cutsim. Usage: scripts/build.sh [release|debug|sanitize] [targets...]
# Build trees: build/release, build/debug, build/sanitize. Incremental on later runs.
# The sanitizers' build keeps line tables only (-g1: file and line in their reports, about a fifth
# less compile time on the CGAL-heavy files than -g). Flags are set when a tree is first
# configured: remove build/sanitize for a tree made before to take them.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
config="${1:-release}"; shift || true
case "$config" in
  release)  flags=(-DCMAKE_BUILD_TYPE=Release) ;;
  debug)    flags=(-DCMAKE_BUILD_TYPE=Debug) ;;
  sanitize) flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" -DCUTSIM_SANITIZE=ON -DCUTSIM_NATIVE=OFF -DCUTSIM_BUILD_BENCHMARKS=OFF -DCUTSIM_BUILD_EXAMPLES=OFF -DCUTSIM_PYTHON=OFF) ;;
  *) echo "scripts/build.sh: unknown configuration '$config' (release, debug, sanitize)" >&2; exit 2 ;;
esac
build="$root/build/$config"
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" "${generator[@]}" "${flags[@]}" >/dev/null
fi
jobs="${CUTSIM_JOBS:-$(nproc)}"
if [ $# -gt 0 ]; then
  cmake --build "$build" --parallel "$jobs" --target "$@"
else
  cmake --build "$build" --parallel "$jobs"
fi
