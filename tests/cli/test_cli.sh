#!/usr/bin/env bash
# End-to-end test of the `cutsim` program (CTest: cli.end_to_end): exit codes, output and error
# messages for good and bad mesh files, and --version.
# Environment: CUTSIM (the program), CUTSIM_TEST_DATA_DIR (tests/data), CUTSIM_DATA_DIR (data).
# Prints every failed check and exits non-zero if there was one.
set -uo pipefail

: "${CUTSIM:?set CUTSIM to the cutsim program}"
: "${CUTSIM_TEST_DATA_DIR:?set CUTSIM_TEST_DATA_DIR to tests/data}"
: "${CUTSIM_DATA_DIR:?set CUTSIM_DATA_DIR to data}"

failures=0
checks=0
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}

# run ARGS...: runs cutsim, leaving stdout, stderr and the exit code in $tmp/out, $tmp/err, $code.
run() {
  "$CUTSIM" "$@" >"$tmp/out" 2>"$tmp/err"
  code=$?
}

# expect_code N DESCRIPTION
expect_code() {
  checks=$((checks + 1))
  if [ "$code" -ne "$1" ]; then
    fail "$2: exit code $code, expected $1; stderr: $(cat "$tmp/err")"
    return 1
  fi
}

# json_info MESH KEY=VALUE...: `cutsim info --json MESH` prints one object with exactly these.
json_info() {
  local mesh="$1"
  shift
  run info "$mesh" --json
  expect_code 0 "info --json $mesh" || return
  checks=$((checks + 1))
  if ! python3 - "$tmp/out" "$@" <<'EOF'
import json, sys
text = open(sys.argv[1]).read()
lines = [l for l in text.splitlines() if l.strip()]
if len(lines) != 1:
    sys.exit(f"expected exactly one line of JSON, got {len(lines)}: {text!r}")
obj = json.loads(lines[0])
keys = ["vertices", "edges", "triangles", "boundary_edges", "components", "isolated_vertices"]
if not isinstance(obj, dict) or sorted(obj) != sorted(keys):
    sys.exit(f"expected an object with exactly the keys {keys}, got {lines[0]}")
for k in keys:
    if type(obj[k]) is not int:
        sys.exit(f"{k} is not an integer: {obj[k]!r}")
for pair in sys.argv[2:]:
    k, v = pair.split("=")
    if obj[k] != int(v):
        sys.exit(f"{k} = {obj[k]}, expected {v}")
EOF
  then
    fail "info --json $mesh: output $(cat "$tmp/out")"
  fi
  [ -s "$tmp/err" ] && fail "info --json $mesh wrote to stderr: $(cat "$tmp/err")"
}

# bad_file FILE LINE PHRASE: exit code 2, stderr starts with "PATH:LINE: " (or "PATH: " when
# LINE is empty) and contains PHRASE; nothing on stdout.
bad_file() {
  local path="$CUTSIM_TEST_DATA_DIR/bad/$1" prefix
  if [ -n "$2" ]; then prefix="$path:$2: "; else prefix="$path: "; fi
  for json in "" --json; do
    run info "$path" $json
    expect_code 2 "info $json $1" || continue
    checks=$((checks + 1))
    local err
    err="$(cat "$tmp/err")"
    if [[ "$err" != "$prefix"* ]]; then
      fail "info $json $1: stderr should start with '$prefix', got: $err"
    elif [[ "$err" != *"$3"* ]]; then
      fail "info $json $1: stderr should contain '$3', got: $err"
    elif [ "$(wc -l <"$tmp/err")" -ne 1 ]; then
      fail "info $json $1: expected exactly one line on stderr, got: $err"
    fi
    [ -s "$tmp/out" ] && fail "info $json $1 wrote to stdout: $(cat "$tmp/out")"
  done
}

# ---- good meshes ----
json_info "$CUTSIM_DATA_DIR/meshes/octahedron.off" vertices=6 edges=12 triangles=8 \
  boundary_edges=0 components=1 isolated_vertices=0
json_info "$CUTSIM_DATA_DIR/meshes/grid_10x10.obj" vertices=100 edges=261 triangles=162 \
  boundary_edges=36 components=1 isolated_vertices=0
json_info "$CUTSIM_DATA_DIR/meshes/two_components.obj" vertices=8 edges=10 triangles=4 \
  boundary_edges=8 components=2 isolated_vertices=0
json_info "$CUTSIM_TEST_DATA_DIR/good/isolated_vertex.obj" vertices=4 edges=3 triangles=1 \
  boundary_edges=3 components=1 isolated_vertices=1
json_info "$CUTSIM_TEST_DATA_DIR/good/all_forms.obj" vertices=6 triangles=4

# The report for a person: one aligned "label: value" line per count.
run info "$CUTSIM_DATA_DIR/meshes/hinge.obj"
if expect_code 0 "info hinge.obj"; then
  checks=$((checks + 1))
  for line in "vertices:          4" "edges:             5" "triangles:         2" \
    "boundary edges:    4" "components:        1" "isolated vertices: 0"; do
    grep -qxF "$line" "$tmp/out" || fail "info hinge.obj: no line '$line' in: $(cat "$tmp/out")"
  done
fi

# ---- bad meshes: exit code 2, "PATH:LINE: message" on stderr ----
bad_file malformed_number.obj 3 "malformed number"
bad_file truncated_faces.off 8 "expected 2 faces, found 1"
bad_file index_out_of_range.obj 5 "out of range"
bad_file negative_index.off 6 "negative vertex index"
bad_file quad_face.obj 5 "only triangles are supported"
bad_file repeated_vertex.obj 5 "repeats vertex"
bad_file nan_coordinate.obj 2 "NaN coordinate"
bad_file inf_coordinate.off 4 "infinite coordinate"
bad_file non_manifold_edge.obj 9 "non-manifold edge"
bad_file inconsistent_orientation.obj 7 "inconsistent orientation"
bad_file bowtie_vertex.obj 2 "bowtie vertex"
bad_file does_not_exist.obj "" "cannot open: No such file or directory"
bad_file unknown_extension.stl "" "unknown mesh file extension"
bad_file empty.obj "" "no vertices"

# ---- usage errors: CLI11's message, exit code 2 ----
for args in "" "info" "info a.obj b.obj" "info --no-such-option a.obj" "no-such-command"; do
  # shellcheck disable=SC2086 # split the arguments on purpose
  run $args
  expect_code 2 "usage error 'cutsim $args'" && { [ -s "$tmp/err" ] || fail "'cutsim $args': no message"; }
done

run info --help
expect_code 0 "info --help" && { grep -q -- "--json" "$tmp/out" || fail "info --help does not list --json"; }

# ---- components: every registered type, with its keys ----
run components
if expect_code 0 "components"; then
  for word in FastTriangularBendingSprings DihedralBending StretchSprings TriangularFEM \
              explicit-euler implicit-euler bdf2 newton cg cholmod youngModulus onSolveFailure \
              fixed tearing snapTolerance restScale "stiffness (number, required)" "areaWeights (choice: unsigned signed)"; do
    checks=$((checks + 1))
    grep -q -- "$word" "$tmp/out" || fail "components does not list $word"
  done
fi
# (the step hooks and the obstacle shapes, each kind alone too)
run components hooks
if expect_code 0 "components hooks"; then
  for word in "step hooks" "contact:" "thickness (number, required)" "selfContact (boolean)"; do
    checks=$((checks + 1))
    grep -q -- "$word" "$tmp/out" || fail "components hooks does not list $word"
  done
fi
run components obstacles
if expect_code 0 "components obstacles"; then
  for word in "obstacle shapes" "plane:" "sphere:" "box:" "capsule:" "mesh:" "normal (point, required)"; do
    checks=$((checks + 1))
    grep -q -- "$word" "$tmp/out" || fail "components obstacles does not list $word"
  done
  checks=$((checks + 1))
  ! grep -q "StretchSprings" "$tmp/out" || fail "components obstacles lists force fields too"
fi
run components magnets
expect_code 2 "components magnets" && { grep -q "forcefields, integrators, linearsolvers, constraints, actions, hooks, obstacles" "$tmp/err" || fail "components magnets: $(cat "$tmp/err")"; }

# ---- outputs never replace an input, nor a file this program did not write ----
# (run --html, view -o, import -o: the scene itself, its mesh, a file of the user's.)
w="$tmp/writes"
mkdir -p "$w"
small="$w/small.json"
cp "$CUTSIM_TEST_DATA_DIR/scenes/small.json" "$small"
sed -i 's|"file": "\([^"/]*\)"|"file": "'"$CUTSIM_TEST_DATA_DIR"'/scenes/\1"|' "$small"
before="$(md5sum <"$small")"
run run "$small" --out "$w/run" --html "$small" --quiet
expect_code 2 "run --html onto its own scene" && { grep -q "an input of this command: it is never replaced" "$tmp/err" || fail "run --html onto the scene: $(cat "$tmp/err")"; }
run run "$small" --out "$w/run" --html "$small" --force --quiet
expect_code 2 "run --html onto its own scene, --force"
checks=$((checks + 1))
[ "$(md5sum <"$small")" = "$before" ] || fail "the scene was changed by run --html onto it"
echo "my notes" >"$w/notes.html"
run run "$small" --out "$w/run" --html "$w/notes.html" --quiet
expect_code 2 "run --html onto a file of the user's" && { grep -q "was not written by this command" "$tmp/err" || fail "run --html onto notes: $(cat "$tmp/err")"; }
checks=$((checks + 1))
[ "$(cat "$w/notes.html")" = "my notes" ] || fail "run --html replaced a file of the user's"
run run "$small" --out "$w/run" --html "$w/page.html" --quiet
expect_code 0 "run --html onto a new file"
run run "$small" --out "$w/run" --html "$w/page.html" --quiet
expect_code 0 "run --html onto its own earlier page"
run view "$w/run" -o "$w/notes.html" --quiet
expect_code 2 "view -o onto a file of the user's"
run view "$w/run" -o "$w/page.html" --quiet
expect_code 0 "view -o onto a player page"
run view "$w/run" -o "$w/notes.html" --quiet --force
expect_code 0 "view -o --force onto a file of the user's"
scn="$CUTSIM_TEST_DATA_DIR/sofa-scenes/FastTriangularBendingSprings.scn"
cp "$scn" "$w/copy.scn"
run import "$w/copy.scn" -o "$w/copy.scn" --force
expect_code 2 "import -o onto its input, --force"
checks=$((checks + 1))
cmp -s "$scn" "$w/copy.scn" || fail "import -o replaced its input"
run import "$w/copy.scn" -o "$small"
expect_code 2 "import -o onto a scene it did not write"
run import "$scn" -o "$w/imported.json"
expect_code 0 "import -o onto a new file"
run import "$scn" -o "$w/imported.json"
expect_code 0 "import -o onto a scene it wrote"

# ---- a run that fails part-way says where what it made lies ----
cat >"$tmp/boom.json" <<'SCENE'
{"mesh": {"grid": {"nx": 5, "ny": 5}}, "mass": {"density": 0.001},
 "forceFields": [{"type": "StretchSprings", "stiffness": 1e9}], "solver": {"type": "explicit"},
 "gravity": [0, 0, -9.81], "constraints": [{"type": "fixed", "points": [0]}],
 "timeStep": 0.1, "duration": 100, "output": {"every": 1}}
SCENE
run run "$tmp/boom.json" --out "$tmp/boom" --quiet
if expect_code 1 "a run that blows up"; then
  checks=$((checks + 1))
  grep -q "the run stopped after step [0-9]* of 1000; what it made so far is in $tmp/boom: the CSV's rows in .steps.csv.tmp" "$tmp/err" &&
    [ -s "$tmp/boom/.steps.csv.tmp" ] && [ -s "$tmp/boom/surface.partial.pvd" ] ||
    fail "a failed run should say where its rows and frames are: $(cat "$tmp/err")"
fi

# ---- --version ----
run --version
if expect_code 0 "--version"; then
  checks=$((checks + 1))
  grep -Eq '^cutsim [0-9]+\.[0-9]+\.[0-9]+ \(Eigen [0-9.]+, CHOLMOD [0-9.]+\)$' "$tmp/out" ||
    fail "--version printed: $(cat "$tmp/out")"
fi

if [ "$failures" -ne 0 ]; then
  echo "cli.end_to_end: $failures of $checks checks failed" >&2
  exit 1
fi
echo "cli.end_to_end: all $checks checks passed"
