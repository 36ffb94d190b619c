#!/usr/bin/env bash
# Formats the C++ sources with the project's .clang-format (Debian's clang-format), or with
# --check says which files are not formatted (exit 1) and changes nothing (CI runs it).
# Usage: scripts/format.sh [--check]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
command -v clang-format >/dev/null 2>&1 || { echo "scripts/format.sh: clang-format is missing (scripts/deps.sh installs it)" >&2; exit 2; }
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h' | grep -v '^viewer/node_modules/')
else
  mapfile -t files < <(find base topology forcefields src python tests benchmarks study fuzz examples \
                            -name '*.cpp' -o -name '*.hpp' -o -name '*.h' | sort)
fi
if [ "${1:-}" = "--check" ]; then
  if ! clang-format --dry-run -Werror "${files[@]}" 2>/tmp/cutsim-format.$$; then
    grep -o '^[^:]*:[0-9]*:[0-9]*: error' /tmp/cutsim-format.$$ | cut -d: -f1 | sort -u |
      sed 's/^/not formatted: /' >&2
    rm -f /tmp/cutsim-format.$$
    echo "scripts/format.sh: run scripts/format.sh to format them ($(clang-format --version))" >&2
    exit 1
  fi
  rm -f /tmp/cutsim-format.$$
  echo "formatting: ${#files[@]} files as .clang-format asks"
else
  clang-format -i "${files[@]}"
  clang-format -i "${files[@]}"  # a second pass: clang-format 14 settles a few long literals only then
fi
