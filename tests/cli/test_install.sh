#!/usr/bin/env bash
# Installs the built libraries into a temporary prefix, then configures, builds and runs the
# example in examples/find_package against them with find_package(cutsim): the CMake package works.
# Env: CUTSIM_BUILD_DIR (the build tree), CUTSIM_SOURCE_DIR.
set -euo pipefail
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cmake --install "$CUTSIM_BUILD_DIR" --prefix "$tmp/prefix" > "$tmp/install.log"
test -f "$tmp/prefix/lib/cmake/cutsim/cutsimConfig.cmake" || { echo "no cutsimConfig.cmake installed"; exit 1; }
cmake -S "$CUTSIM_SOURCE_DIR/examples/find_package" -B "$tmp/example" -DCMAKE_PREFIX_PATH="$tmp/prefix" \
      -DCMAKE_BUILD_TYPE=Release > "$tmp/configure.log" 2>&1 || { cat "$tmp/configure.log"; exit 1; }
cmake --build "$tmp/example" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; exit 1; }
out=$("$tmp/example/hinge_energy")
echo "$out"
python3 - "$out" <<'PY'
import sys
e = float(sys.argv[1].split(":")[-1])
expected = 0.00111018549377  # the spec's hinge H folded by 0.1 rad
assert abs(e - expected) < 1e-12, f"energy {e} != {expected}"
print("installed package OK")
PY
