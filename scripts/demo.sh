#!/usr/bin/env bash
# Installs what is missing, builds cutsim (Release) and runs the default demo scene: a cloth
# hanging from two corners is cut across while it hangs, and the cut opens under gravity.
# Usage: scripts/demo.sh [SCENE.json]   (default: data/scenes/hanging_cut.json)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scene="${1:-$root/data/scenes/hanging_cut.json}"
"$root/scripts/deps.sh"
"$root/scripts/build.sh" release cutsim
name="$(basename "$scene" .json)"
out="$root/out/$name"
"$root/build/release/src/cutsim" run "$scene" --out "$out" --dump-final "$out/final"
echo "output written to $out (open $out/*.pvd in ParaView; per-step data in the CSV)"
