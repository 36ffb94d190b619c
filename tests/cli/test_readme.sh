#!/usr/bin/env bash
# The README's commands, as written (CTest: cli.readme): every line of its "Using the program"
# block that starts with build/release/src/cutsim runs, in order, in a scratch folder that sees the
# repository's data/ and tests/ and the program at build/release/src/cutsim, and exits with 0.
# Environment: CUTSIM (the program), CUTSIM_SOURCE_DIR (the repository).
set -uo pipefail

: "${CUTSIM:?set CUTSIM to the cutsim program}"
: "${CUTSIM_SOURCE_DIR:?set CUTSIM_SOURCE_DIR to the repository}"

failures=0
checks=0
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
ln -s "$CUTSIM_SOURCE_DIR/data" "$tmp/data"
ln -s "$CUTSIM_SOURCE_DIR/tests" "$tmp/tests"
mkdir -p "$tmp/build/release/src"
ln -s "$(cd "$(dirname "$CUTSIM")" && pwd)/$(basename "$CUTSIM")" "$tmp/build/release/src/cutsim"

# The block after "## Using the program", up to its closing fence.
mapfile -t commands < <(awk '/^## Using the program/ {section = 1} section && /^```sh/ {block = 1; next}
                              block && /^```/ {exit} block && /^build\/release\/src\/cutsim / {print}' \
                          "$CUTSIM_SOURCE_DIR/README.md")
if [ "${#commands[@]}" -lt 10 ]; then
  echo "FAIL: found ${#commands[@]} commands in README.md's \"Using the program\" block" >&2
  exit 1
fi
cd "$tmp" || exit 1
for line in "${commands[@]}"; do
  checks=$((checks + 1))
  command="${line%%#*}"  # (the comment after the command)
  bash -c "$command" </dev/null >out.txt 2>err.txt
  code=$?
  if [ "$code" -ne 0 ]; then
    echo "FAIL: $command: exit code $code; stderr: $(tail -5 err.txt)" >&2
    failures=$((failures + 1))
  fi
done
checks=$((checks + 1))
[ -s out/tearing/player.png ] || { echo "FAIL: view --png wrote no out/tearing/player.png" >&2; failures=$((failures + 1)); }

if [ "$failures" -ne 0 ]; then
  echo "cli.readme: $failures of $checks checks failed" >&2
  exit 1
fi
echo "cli.readme: all $checks commands of the README ran"
