#!/usr/bin/env bash
# Installs the Debian packages cutsim needs, only those that are missing (safe to run again).
# Needs root (or sudo) when something is missing.
set -euo pipefail
packages=(build-essential cmake ninja-build ccache pkg-config
          libeigen3-dev libcgal-dev libsuitesparse-dev libmetis-dev libopenblas-dev
          libgtest-dev libgmock-dev libbenchmark-dev nlohmann-json3-dev libcli11-dev
          python3-matplotlib python3-numpy python3-dev pybind11-dev python3-pytest)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "cutsim: installing missing packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
