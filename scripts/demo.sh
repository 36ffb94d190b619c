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
# The run, and its player: one HTML page that plays it back in any browser, offline.
"$root/build/release/src/cutsim" run "$scene" --out "$out" --dump-final "$out/final" --html "$out/player.html"
# Pictures without a browser (Debian's python3 with matplotlib, installed by deps.sh).
pictures=""
if /usr/bin/python3 -c 'import matplotlib, numpy' 2>/dev/null; then
  /usr/bin/python3 "$root/scripts/render.py" "$out" >/dev/null
  pictures="$out/render_frames.png (the surface at four times) and $out/render_series.png"
fi
echo
echo "watch the run: open $out/player.html in a browser (play, scrub, orbit; strain colours, cut lips, plots)"
[ -n "$pictures" ] && echo "pictures:      $pictures"
echo "ParaView:      $out/surface.pvd (and borders.pvd, springs.pvd); per-step data in $out/steps.csv"
