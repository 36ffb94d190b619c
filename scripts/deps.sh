#!/usr/bin/env bash
# Installs what cutsim needs, only what is missing (safe to run again): Debian's packages (needs
# root, or sudo, when something is missing) and the player's npm packages (viewer/, pinned by
# viewer/package-lock.json: three.js, the esbuild bundler, and playwright-core with pngjs for the
# browser test, which drives Debian's chromium; no browser is downloaded).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
packages=(build-essential cmake ninja-build ccache pkg-config clang-format-14
          libeigen3-dev libcgal-dev libsuitesparse-dev libmetis-dev libopenblas-dev
          libgtest-dev libgmock-dev libbenchmark-dev libtbb-dev nlohmann-json3-dev libcli11-dev libpugixml-dev zlib1g-dev
          python3-matplotlib python3-numpy python3-dev pybind11-dev python3-pytest python3-distributed
          chromium)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# Node.js and npm: Debian's, unless the machine has them already (from any source).
command -v node >/dev/null 2>&1 || missing+=(nodejs)
command -v npm >/dev/null 2>&1 || missing+=(npm)
if [ ${#missing[@]} -gt 0 ]; then
  echo "cutsim: installing missing packages: ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# The player's packages, again whenever the lockfile changed.
viewer="$root/viewer"
if [ ! -f "$viewer/node_modules/.package-lock.json" ] ||
   [ "$viewer/package-lock.json" -nt "$viewer/node_modules/.package-lock.json" ]; then
  echo "cutsim: installing the player's npm packages (viewer/package-lock.json)"
  (cd "$viewer" && npm ci --no-audit --no-fund --loglevel=error)
fi
