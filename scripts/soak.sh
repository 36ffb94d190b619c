#!/usr/bin/env bash
# The soak run (not part of CI): random topology operations with injected failures, validated
# after every operation. Usage: scripts/soak.sh [OPS] [sanitize|release] [more cutsim_soak options]
# Default: 1000000 operations under the sanitizers (AddressSanitizer and UBSan). See docs/robustness.md.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ops="${1:-1000000}"; shift || true
config="${1:-sanitize}"; shift || true
"$root/scripts/deps.sh"
"$root/scripts/build.sh" "$config" cutsim_soak
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
exec "$root/build/$config/tests/cutsim_soak" --ops "$ops" "$@"
