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
# Pictures without ParaView (Debian's python3 with matplotlib, installed by deps.sh).
if /usr/bin/python3 -c 'import matplotlib, numpy' 2>/dev/null; then
  /usr/bin/python3 "$root/scripts/render.py" "$out"
  echo "pictures: $out/render_frames.png (the surface at four times) and $out/render_series.png"
fi
echo "output written to $out (open $out/*.pvd in ParaView; per-step data in the CSV)"
