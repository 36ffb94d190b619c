#!/usr/bin/env bash
# End-to-end test of `cutsim eval`: SOFA's measured outputs reproduced through the command line,
# the JSON keys, and exit code 2 with a "PATH: message" line for bad input.
# Environment: CUTSIM (the program), CUTSIM_TEST_DATA_DIR (tests/data).
set -uo pipefail

: "${CUTSIM:?set CUTSIM to the cutsim program}"
: "${CUTSIM_TEST_DATA_DIR:?set CUTSIM_TEST_DATA_DIR to tests/data}"

ref="$CUTSIM_TEST_DATA_DIR/sofa-reference"
bad="$CUTSIM_TEST_DATA_DIR/bad"
failures=0
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}

run() {
  "$CUTSIM" eval "$@" >"$tmp/out" 2>"$tmp/err"
  code=$?
}

# SOFA's numbers, through the command line.
for case in cylinder_patch grid7x6_alt_jitter; do
  k=$(python3 -c "import json; print(repr(json.load(open('$ref/$case.json'))['bendingStiffness']))")
  run --rest "$ref/${case}_rest.obj" --current "$ref/${case}_deformed.obj" --bending-stiffness "$k"
  if [ "$code" -ne 0 ]; then
    fail "eval $case: exit code $code: $(cat "$tmp/err")"
    continue
  fi
  python3 - "$tmp/out" "$ref/$case.json" <<'PY' || fail "eval $case: output differs from SOFA's"
import json, sys
lines = [l for l in open(sys.argv[1]).read().splitlines() if l.strip()]
assert len(lines) == 1, "expected one line of JSON"
out, ref = json.loads(lines[0]), json.load(open(sys.argv[2]))
for key in ["energy", "active_springs", "forces", "degenerate_hinges", "signed_fallbacks",
            "bending_stiffness", "min_dist_validity", "area_weights"]:
    assert key in out, "missing key " + key
scale = max(abs(c) for f in ref["force"] for c in f)
err = max(abs(a - b) for fo, fr in zip(out["forces"], ref["force"]) for a, b in zip(fo, fr))
assert len(out["forces"]) == len(ref["force"]), "vertex count"
assert err <= 1e-10 * scale, f"force error {err} (scale {scale})"
assert abs(out["energy"] - ref["potential_energy"]) <= 1e-10 * abs(ref["potential_energy"])
assert out["degenerate_hinges"] == 0 and out["area_weights"] == "unsigned"
PY
done

# Signed weights: a flat jittered grid is force-free at rest.
run --rest "$ref/grid7x6_alt_jitter_rest.obj" --current "$ref/grid7x6_alt_jitter_rest.obj" \
  --area-weights signed
[ "$code" -eq 0 ] || fail "eval signed: exit code $code"
python3 -c "
import json, sys
o = json.load(open('$tmp/out'))
assert max(abs(c) for f in o['forces'] for c in f) < 1e-12 and o['area_weights'] == 'signed'
" || fail "eval signed: rest forces not zero"

# bad ARGS... -- PREFIX: exit code 2, stderr starts with PREFIX, nothing on stdout.
bad() {
  local prefix="${*: -1}"
  run "${@:1:$#-1}"
  if [ "$code" -ne 2 ]; then
    fail "eval ${*:1:$#-1}: exit code $code, expected 2"
  elif [[ "$(cat "$tmp/err")" != "$prefix"* ]]; then
    fail "eval ${*:1:$#-1}: stderr should start with '$prefix': $(cat "$tmp/err")"
  elif [ -s "$tmp/out" ]; then
    fail "eval ${*:1:$#-1}: wrote to stdout"
  fi
}
cyl_rest="$ref/cylinder_patch_rest.obj"
cyl_cur="$ref/cylinder_patch_deformed.obj"
bad --rest "$cyl_rest" --current "$ref/grid7x6_alt_jitter_rest.obj" "$ref/grid7x6_alt_jitter_rest.obj: "
sed 's/^f \([0-9]*\) \([0-9]*\) \([0-9]*\)$/f \1 \3 \2/' "$cyl_cur" >"$tmp/flipped.obj"
bad --rest "$cyl_rest" --current "$tmp/flipped.obj" "$tmp/flipped.obj: "
bad --rest "$cyl_rest" --current "$cyl_cur" --bending-stiffness -1 "bendingStiffness: "
bad --rest "$cyl_rest" --current "$cyl_cur" --bending-stiffness nan "bendingStiffness: "
bad --rest "$cyl_rest" --current "$cyl_cur" --min-dist-validity inf "minDistValidity: "
bad --rest "$cyl_rest" --current "$cyl_cur" --area-weights other "areaWeights: "
bad --rest "$bad/non_manifold_edge.obj" --current "$bad/non_manifold_edge.obj" "$bad/non_manifold_edge.obj:9: "
bad --rest "$tmp/missing.obj" --current "$cyl_cur" "$tmp/missing.obj: "

# A current file with vertices only is accepted.
grep '^v ' "$cyl_cur" >"$tmp/vertices_only.obj"
run --rest "$cyl_rest" --current "$tmp/vertices_only.obj"
[ "$code" -eq 0 ] || fail "eval with a vertices-only current file: exit code $code: $(cat "$tmp/err")"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) of cutsim eval failed" >&2
  exit 1
fi
echo "cutsim eval: all checks passed"
