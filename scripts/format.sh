#!/usr/bin/env bash
# Formats the C++ sources with the project's .clang-format (Debian's clang-format), or with
# --check says which files are not formatted (exit 1) and changes nothing (CI runs it).
# Usage: scripts/format.sh [--check]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
# Version 14 (Debian 12's): another version formats some lines differently.
format=clang-format-14
command -v "$format" >/dev/null 2>&1 || format=clang-format
command -v "$format" >/dev/null 2>&1 || { echo "scripts/format.sh: clang-format 14 is missing (scripts/deps.sh installs it)" >&2; exit 2; }
case "$("$format" --version)" in
  *"version 14."*) ;;
  *) echo "scripts/format.sh: $("$format" --version) is not version 14, which the tree is formatted with" >&2; exit 2 ;;
esac
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h' | grep -v '^viewer/node_modules/')
else
  mapfile -t files < <(find base topology forcefields src python tests benchmarks study fuzz examples \
                            -name '*.cpp' -o -name '*.hpp' -o -name '*.h' | sort)
fi
if [ "${1:-}" = "--check" ]; then
  report=$(mktemp)
  trap 'rm -f "$report"' EXIT
  if ! "$format" --dry-run -Werror "${files[@]}" 2>"$report"; then
    { grep -o '^[^:]*:[0-9]*:[0-9]*: error' "$report" || cat "$report"; } | cut -d: -f1 | sort -u |
      sed 's/^/not formatted: /' >&2
    echo "scripts/format.sh: run scripts/format.sh to format them ($("$format" --version))" >&2
    exit 1
  fi
  echo "formatting: ${#files[@]} files as .clang-format asks"
else
  "$format" -i "${files[@]}"
  "$format" -i "${files[@]}"  # a second pass: clang-format 14 settles a few long literals only then
fi
