#!/usr/bin/env bash
# Installs what is missing, builds and runs the whole test suite (CTest).
# Usage: scripts/test.sh [release|debug|sanitize]   (default: release)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
config="${1:-release}"
"$root/scripts/deps.sh"
"$root/scripts/build.sh" "$config"
cd "$root/build/$config"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
ctest --output-on-failure --parallel "${CUTSIM_JOBS:-$(nproc)}"
