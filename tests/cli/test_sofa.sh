#!/usr/bin/env bash
# End-to-end test of SOFA's scenes through the command line (CTest: cli.sofa): `cutsim run X.scn`
# and `cutsim run` of its `cutsim import` give byte-identical output; `cutsim regress` writes a
# reference that it then passes against, and prints SOFA's metrics against SOFA's own reference;
# bad scenes exit with code 2 naming the scene's line.
# Environment: CUTSIM (the program), CUTSIM_TEST_DATA_DIR (tests/data).
set -uo pipefail

: "${CUTSIM:?set CUTSIM to the cutsim program}"
: "${CUTSIM_TEST_DATA_DIR:?set CUTSIM_TEST_DATA_DIR to tests/data}"

failures=0
checks=0
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
CUTSIM="$(cd "$(dirname "$CUTSIM")" && pwd)/$(basename "$CUTSIM")"
cp -r "$CUTSIM_TEST_DATA_DIR/sofa-scenes" "$tmp/sofa"
cd "$tmp"

fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}
check() {
  local what="$1"
  shift
  checks=$((checks + 1))
  "$@" || fail "$what"
}

# ---- run the .scn, and its import ----
check "run the SOFA scene" "$CUTSIM" run sofa/FastTriangularBendingSprings.scn --steps 20 --out scn --quiet > run_scn.txt 2> run_scn.err
mkdir -p json
check "import it" "$CUTSIM" import sofa/FastTriangularBendingSprings.scn -o json/ftbs.json --steps 20 > import.txt 2> import.err
check "import says what it wrote" grep -q "wrote json/ftbs.json" import.txt
check "the JSON lists what was ignored" grep -q '"ignored"' json/ftbs.json
check "run the imported JSON" "$CUTSIM" run json/ftbs.json --out json_out --quiet > run_json.txt 2> run_json.err
check "the same files" diff <(cd scn && ls) <(cd json_out && ls)
for f in scn/*; do
  check "byte-identical $(basename "$f")" cmp -s "$f" "json_out/$(basename "$f")"
done
check "--steps is for SOFA scenes" bash -c "! '$CUTSIM' run json/ftbs.json --steps 3 --quiet > /dev/null 2>&1"

# ---- regress ----
cat > sofa/ftbs.regression-tests <<'LIST'
# scene steps epsilon mecaInMapping dumpOnlyLastStep
FastTriangularBendingSprings.scn 30 1e-4 0 1
LIST
check "regress --write" "$CUTSIM" regress sofa/ftbs.regression-tests --write --refs refs > write.txt 2> write.err
check "the reference is named as SOFA names it" test -f refs/FastTriangularBendingSprings.scn.reference_0_defoDOF_mstate.txt.gz
check "regress passes against what it wrote" "$CUTSIM" regress sofa/ftbs.regression-tests --refs refs > pass.txt 2> pass.err
check "it prints the metrics" grep -q "pass  legacy" pass.txt
# SOFA's own reference of the FEM scene (docs/sofa.md).
grep TriangularFEMForceFieldOptim sofa/RegressionStateScenes.regression-tests > sofa/fem.regression-tests
check "SOFA's own reference passes at SOFA's threshold" "$CUTSIM" regress sofa/fem.regression-tests > sofa.txt 2> sofa.err
check "SOFA's reference: the FEM scene's metrics" grep -q "TriangularFEMForceFieldOptim.scn: pass  legacy .*largest point difference" sofa.txt
"$CUTSIM" regress sofa/RegressionStateScenes.regression-tests > missing.txt 2> missing.err
check "a missing reference: exit code 2" test $? -eq 2
check "a missing reference: the list's line" grep -q "RegressionStateScenes.regression-tests:4: no reference" missing.err
check "a missing reference: the other scene is still compared" grep -q "TriangularFEMForceFieldOptim.scn: pass" missing.txt

# ---- import into a folder that does not exist yet ----
check "import into a new folder" "$CUTSIM" import sofa/FastTriangularBendingSprings.scn -o new/deeper/ftbs.json > /dev/null 2>&1
check "its mesh path is relative to it" grep -q '"file": "../../sofa/mesh/triangleGrid_10_10.obj"' new/deeper/ftbs.json
check "and it runs" "$CUTSIM" run new/deeper/ftbs.json --out new_out --quiet > /dev/null 2>&1

# ---- bad scenes: exit code 2, the scene's line ----
sed 's/template="Vec3"/template="Vec2d"/' sofa/FastTriangularBendingSprings.scn > sofa/vec2.scn
"$CUTSIM" run sofa/vec2.scn --quiet > /dev/null 2> vec2.err
check "Vec2: exit code 2" test $? -eq 2
check "Vec2: the line" grep -q "vec2.scn:24: .*template \"Vec2d\" is not supported" vec2.err
printf '<Node name="root">\n  <MechanicalObject\n</Node>\n' > sofa/broken.scn
"$CUTSIM" import sofa/broken.scn -o broken.json > /dev/null 2> broken.err
check "malformed XML: exit code 2" test $? -eq 2
check "malformed XML: line and column" grep -qE "broken.scn:[0-9]+:[0-9]+: malformed XML" broken.err
check "nothing written for a bad scene" test ! -e broken.json

echo "$checks checks, $failures failed"
[ "$failures" -eq 0 ]
