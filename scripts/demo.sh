#!/usr/bin/env bash
# Installs what is missing, builds cutsim (Release) and runs the default demo.
# Usage: scripts/demo.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/deps.sh"
"$root/scripts/build.sh" release cutsim
cutsim="$root/build/release/src/cutsim"
out="$root/out/demo"
mkdir -p "$out"
# The demo: load the demo cloth, report its topology, and evaluate the bending springs of the
# one-hinge mesh folded against its rest shape. (The animated scenes come with `cutsim run`.)
echo "== cutsim info data/meshes/grid_10x10.obj"
"$cutsim" info "$root/data/meshes/grid_10x10.obj" | tee "$out/info.txt"
"$cutsim" info --json "$root/data/meshes/grid_10x10.obj" > "$out/info.json"
if "$cutsim" eval --help >/dev/null 2>&1; then
  echo "== cutsim eval (SOFA reference case: cylinder patch)"
  "$cutsim" eval --rest "$root/tests/data/sofa-reference/cylinder_patch_rest.obj" \
                 --current "$root/tests/data/sofa-reference/cylinder_patch_deformed.obj" \
                 --bending-stiffness 2.5 > "$out/eval_cylinder_patch.json"
  python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print('energy', d['energy'], 'active springs', d['active_springs'])" \
    "$out/eval_cylinder_patch.json" 2>/dev/null || true
fi
echo "output written to $out"
