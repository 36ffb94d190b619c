#!/usr/bin/env bash
# The accuracy study: builds cutsim_study (Release), runs it, plots its CSV files into docs/study/
# and regenerates docs/study.md.
#
#   study/run_study.sh [--quick | --full]     (default --quick: about 2-3 minutes on 2 cores; --full: about 8-9)
#
# Needs python3 with matplotlib: installed with apt-get (python3-matplotlib) if missing.
# Environment: CUTSIM_STUDY_BUILD (build tree, default build/study), JOBS (default 2).
set -euo pipefail
mode=--quick
case "${1:-}" in
  --quick | "") mode=--quick ;;
  --full) mode=--full ;;
  *) echo "usage: $0 [--quick | --full]" >&2; exit 2 ;;
esac
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${CUTSIM_STUDY_BUILD:-$root/build/study}"
jobs="${JOBS:-2}"
data="$build/study-data-${mode#--}"

# A Python with matplotlib: the first python3 on PATH, else Debian's (where apt-get installs it).
py=""
for candidate in python3 /usr/bin/python3; do
  if command -v "$candidate" >/dev/null && "$candidate" -c 'import matplotlib' 2>/dev/null; then
    py="$candidate"
    break
  fi
done
if [ -z "$py" ]; then
  echo "run_study: installing python3-matplotlib with apt-get" >&2
  if [ "$(id -u)" = 0 ]; then
    apt-get install -y python3-matplotlib
  else
    sudo apt-get install -y python3-matplotlib
  fi
  py=/usr/bin/python3
fi

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCUTSIM_BUILD_BENCHMARKS=OFF \
    -DCUTSIM_BUILD_EXAMPLES=OFF
fi
cmake --build "$build" --target cutsim_study -j "$jobs"

mkdir -p "$data"
"$build/study/cutsim_study" "$mode" --out "$data" | tee "$data/log.txt"
"$py" "$root/study/report.py" --data "$data" --docs "$root/docs" --mode "${mode#--}"
echo "run_study: wrote $root/docs/study.md and $root/docs/study/*.png"
