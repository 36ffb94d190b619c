#!/usr/bin/env bash
# End-to-end test of `cutsim run` (CTest: cli.run): a small scene run twice gives byte-identical
# output; --dump-final's files agree with `cutsim eval` on them; progress and summary; bad scenes
# exit with code 2 and a "PATH:LINE: /pointer: message" line.
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
scene="$(cd "$CUTSIM_TEST_DATA_DIR" && pwd)/scenes/small.json"
CUTSIM="$(cd "$(dirname "$CUTSIM")" && pwd)/$(basename "$CUTSIM")"

fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}

check() {  # check DESCRIPTION COMMAND...: counts a check, reports it if the command fails
  local what="$1"
  shift
  checks=$((checks + 1))
  "$@" || fail "$what"
}

# ---- the same scene twice: byte-identical files ----
"$CUTSIM" run "$scene" --out "$tmp/a" --dump-final "$tmp/da" --quiet >"$tmp/out_a" 2>"$tmp/err_a"
code=$?
check "run exits with 0 (got $code; stderr: $(cat "$tmp/err_a"))" [ "$code" -eq 0 ]
"$CUTSIM" run "$scene" --out "$tmp/b" --dump-final "$tmp/db" --quiet >"$tmp/out_b" 2>"$tmp/err_b"
check "second run exits with 0" [ $? -eq 0 ]
check "--quiet prints nothing on stderr" [ ! -s "$tmp/err_a" ]
check "output identical from run to run" diff -r "$tmp/a" "$tmp/b"
check "--dump-final identical from run to run" diff -r "$tmp/da" "$tmp/db"
for f in steps.csv surface.pvd springs.pvd surface_000000.vtp surface_000006.vtp \
         springs_000006.vtp frame_000006.obj; do
  check "output has $f" [ -s "$tmp/a/$f" ]
done
check "no frame beyond the last" [ ! -e "$tmp/a/surface_000007.vtp" ]
check "no temporary file left" [ -z "$(find "$tmp/a" -name '.*')" ]
check "steps.csv has a row per step and a header" [ "$(wc -l <"$tmp/a/steps.csv")" -eq 32 ]
check "the summary names the steps" grep -q "^steps *30 " "$tmp/out_a"
check "the summary gives the final counts" grep -q "^final .* points, .* triangles" "$tmp/out_a"

# ---- --dump-final agrees with `cutsim eval` ----
for f in final_rest.obj final.obj final_forces.json; do
  check "--dump-final wrote $f" [ -s "$tmp/da/$f" ]
done
# The dump's forces against a from-scratch `eval` on its meshes (to 1e-9 of the largest force).
compare_dump_with_eval() {
  local dump="$1" what="$2"
  read -r k eps weights < <(python3 -c '
import json, sys
j = json.load(open(sys.argv[1]))
print(repr(j["bending_stiffness"]), repr(j["min_dist_validity"]), j["area_weights"])' \
    "$dump/final_forces.json")
  "$CUTSIM" eval --rest "$dump/final_rest.obj" --current "$dump/final.obj" \
    --bending-stiffness "$k" --min-dist-validity "$eps" --area-weights "$weights" >"$tmp/eval.json" \
    2>"$tmp/eval_err"
  check "$what: eval on the dumped meshes exits with 0 ($(cat "$tmp/eval_err"))" [ $? -eq 0 ]
  checks=$((checks + 1))
  if ! python3 - "$tmp/eval.json" "$dump/final_forces.json" <<'PY'
import json, sys
e = json.load(open(sys.argv[1]))
d = json.load(open(sys.argv[2]))
if e["active_springs"] != d["active_springs"]:
    sys.exit(f"active springs: eval {e['active_springs']}, dump {d['active_springs']}")
if len(e["forces"]) != len(d["forces"]):
    sys.exit(f"forces: eval has {len(e['forces'])}, dump {len(d['forces'])}")
scale = max([1.0] + [abs(c) for f in d["forces"] for c in f])
worst = max(abs(a - b) for fe, fd in zip(e["forces"], d["forces"]) for a, b in zip(fe, fd))
if worst > 1e-9 * scale:
    sys.exit(f"forces differ by {worst} (scale {scale})")
if abs(e["energy"] - d["energy"]) > 1e-9 * max(1.0, abs(d["energy"])):
    sys.exit(f"energy: eval {e['energy']}, dump {d['energy']}")
if d["active_springs"] == 0:
    sys.exit("no active spring: the comparison would prove nothing")
PY
  then
    fail "$what: final_forces.json disagrees with cutsim eval"
  fi
}
compare_dump_with_eval "$tmp/da" "small.json"

# The same after cuts with snapTolerance 0 (no crossing merged into a vertex: the cuts' points
# closest to the mesh's, the hinges most sensitive to rounding).
python3 - "$scene" "$tmp/snap0.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
for a in s["timeline"]:
    if a["action"] == "cut":
        a["snapTolerance"] = 0
json.dump(s, open(sys.argv[2], "w"))
PY
"$CUTSIM" run "$tmp/snap0.json" --out "$tmp/s0" --dump-final "$tmp/ds0" --quiet >/dev/null 2>"$tmp/err_s0"
check "the snap-0 run exits with 0 ($(cat "$tmp/err_s0"))" [ $? -eq 0 ]
compare_dump_with_eval "$tmp/ds0" "small.json with snapTolerance 0"

# ---- progress lines when stderr is not a terminal; default output folder ----
(cd "$tmp" && "$CUTSIM" run "$scene" >"$tmp/out_c" 2>"$tmp/err_c")
check "run without --out exits with 0" [ $? -eq 0 ]
check "default output folder out/<scene name>" [ -s "$tmp/out/small/steps.csv" ]
check "plain progress lines (0 % .. 100 %)" \
  [ "$(grep -c '%  t = ' "$tmp/err_c")" -eq 11 ]
check "default output identical to --out's" diff -r "$tmp/a" "$tmp/out/small"

# ---- bad scenes: exit code 2, "PATH:LINE: " ----
# bad FILE LINE POINTER
bad() {
  local path="$CUTSIM_TEST_DATA_DIR/scenes/bad/$1"
  "$CUTSIM" run "$path" --out "$tmp/bad" >"$tmp/out_bad" 2>"$tmp/err_bad"
  local c=$?
  check "$1: exit code 2 (got $c)" [ "$c" -eq 2 ]
  local err
  err="$(cat "$tmp/err_bad")"
  checks=$((checks + 1))
  [[ "$err" == "$path:$2: $3"* ]] || fail "$1: stderr should start with '$path:$2: $3', got: $err"
  check "$1: one line on stderr" [ "$(wc -l <"$tmp/err_bad")" -eq 1 ]
  check "$1: nothing on stdout" [ ! -s "$tmp/out_bad" ]
}
bad unknown_key.json 5 "/solver/iteration: unknown key"
bad wrong_type.json 5 "/forceFields/0/bendingStiffness: expected a number"
bad missing_mesh.json 3 "/mesh: mesh file \"no_such_mesh.obj\" not found"
bad negative_stiffness.json 7 "/forceFields/1/bendingStiffness: must be >= 0"
bad negative_time_step.json 4 "/timeStep: must be > 0"
bad negative_action_time.json 8 "/timeline/1/at: an action cannot happen at a negative time"
bad action_after_duration.json 6 "/timeline/0/at: time 0.2 is after the end"
bad cut_misses_surface.json 9 "/timeline/0/polyline/2: the cut misses the surface"
bad unknown_action.json 7 "/timeline/0/action: unknown action \"explode\""
bad unknown_force_field.json 4 "/forceFields/0/type: unknown force field type"
bad invalid_json.json 4 "invalid JSON"
check "no output folder for bad scenes" [ ! -e "$tmp/bad" ]

"$CUTSIM" run "$tmp/no_such_scene.json" >/dev/null 2>"$tmp/err_missing"
check "a missing scene file exits with 2" [ $? -eq 2 ]
check "a missing scene file is named" grep -q "^$tmp/no_such_scene.json: " "$tmp/err_missing"

# ---- what a run will make is checked before it starts ----
python3 - "$scene" "$tmp/long.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["timeStep"] = 1e-4
s["duration"] = 2000  # 2e7 steps
s["timeline"] = []
json.dump(s, open(sys.argv[2], "w"))
PY
"$CUTSIM" run "$tmp/long.json" --out "$tmp/long" >/dev/null 2>"$tmp/err_long"
check "a run of 2e7 steps is refused with 2" [ $? -eq 2 ]
check "it says why and what to do" grep -q "^$tmp/long.json: the run would take 20000000 steps and write .* --allow-long" "$tmp/err_long"
check "no output folder for a refused run" [ ! -e "$tmp/long" ]
touch "$tmp/a_file"
"$CUTSIM" run "$scene" --out "$tmp/dumpfile" --dump-final "$tmp/a_file" >/dev/null 2>"$tmp/err_dump"
check "--dump-final into a file is refused before the run" [ $? -eq 2 ]
check "the file is named" grep -q "^--dump-final: $tmp/a_file is a file, not a folder" "$tmp/err_dump"
# A bad thread count (CUTSIM_THREADS) is refused before the run: a scene with contact.
CUTSIM_THREADS=two "$CUTSIM" run "$CUTSIM_DATA_DIR/scenes/fold_ground.json" --out "$tmp/threads" >/dev/null 2>"$tmp/err_threads"
check "a bad CUTSIM_THREADS exits with 2" [ $? -eq 2 ]
check "it names CUTSIM_THREADS and its value" grep -q 'CUTSIM_THREADS: must be a whole number in \[1, 256\].*"two"' "$tmp/err_threads"
check "no output folder for it" [ ! -e "$tmp/threads" ]
# And for a scene without contact (the springs' passes and CG use the setting too).
CUTSIM_THREADS=0 "$CUTSIM" run "$CUTSIM_DATA_DIR/scenes/hanging.json" --out "$tmp/threads2" >/dev/null 2>"$tmp/err_threads2"
check "a bad CUTSIM_THREADS exits with 2 without contact" [ $? -eq 2 ]
check "it names CUTSIM_THREADS and its value without contact" grep -q 'CUTSIM_THREADS: must be a whole number in \[1, 256\].*"0"' "$tmp/err_threads2"
check "no output folder for it without contact" [ ! -e "$tmp/threads2" ]
check "nothing ran" [ ! -e "$tmp/dumpfile" ]
# A re-run into a folder removes the earlier run's files, keeps the user's, and says so.
mkdir -p "$tmp/rerun" && touch "$tmp/rerun/surface_000999.vtp" "$tmp/rerun/notes.txt"
"$CUTSIM" run "$scene" --out "$tmp/rerun" >/dev/null 2>"$tmp/err_rerun"
check "a re-run succeeds" [ $? -eq 0 ]
check "the earlier run's frame is gone" [ ! -e "$tmp/rerun/surface_000999.vtp" ]
check "the user's file stays" [ -e "$tmp/rerun/notes.txt" ]
check "the re-run says so" grep -q "^note: removed 1 files of an earlier run" "$tmp/err_rerun"

# ---- SIGINT and SIGTERM stop a run cleanly between two steps, its outputs marked partial ----
python3 - "$scene" "$tmp/endless.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["duration"] = 1000  # 10^5 steps: stopped long before its end
s["output"] = {"every": 20}
s["timeline"] = []
json.dump(s, open(sys.argv[2], "w"))
PY
set -m  # job control: a background job does not start with SIGINT ignored
for sig in INT TERM; do
  out="$tmp/stopped_$sig"
  "$CUTSIM" run "$tmp/endless.json" --out "$out" --quiet >/dev/null 2>"$tmp/err_$sig" &
  pid=$!
  # Stopped once a few frames are out.
  for _ in $(seq 1 600); do
    [ -e "$out/surface_000003.vtp" ] && break
    sleep 0.1
  done
  kill -s "$sig" "$pid"
  wait "$pid"
  code=$?
  want=$([ "$sig" = INT ] && echo 130 || echo 143)
  check "SIG$sig: ended by the signal, status $want (got $code; $(cat "$tmp/err_$sig"))" [ "$code" -eq "$want" ]
  check "SIG$sig: it says where it stopped" grep -q "^cutsim: stopped by SIG$sig after step [0-9]* of 100000 .* are marked partial" "$tmp/err_$sig"
  check "SIG$sig: nothing is named as a finished run's" test ! -e "$out/steps.csv" -a ! -e "$out/surface.pvd"
  check "SIG$sig: no temporary file or lock is left" [ -z "$(ls -A "$out" | grep -E '^\.')" ]
  step=$(sed -n "s/^cutsim: stopped by SIG$sig after step \([0-9]*\) .*/\1/p" "$tmp/err_$sig")
  check "SIG$sig: steps.partial.csv has the header and a row for steps 0 to $step" \
    [ "$(wc -l <"$out/steps.partial.csv")" -eq $((step + 2)) ]
  listed=$(grep -c "<DataSet" "$out/surface.partial.pvd")
  written=$(ls "$out" | grep -c "^surface_.*\.vtp$")
  check "SIG$sig: surface.partial.pvd lists every frame written ($listed of $written)" [ "$listed" -eq "$written" ]
  last_csv=$(tail -1 "$out/steps.partial.csv" | cut -d, -f1)
  last_pvd=$(grep "<DataSet" "$out/surface.partial.pvd" | tail -1 | sed 's/.*timestep="\([^"]*\)".*/\1/')
  check "SIG$sig: the last frame is the last step's (t = $last_csv, frame at $last_pvd)" \
    python3 -c 'import sys; a, b = map(float, sys.argv[1:]); sys.exit(abs(a - b) > 1e-12 * max(1, abs(a)))' "$last_csv" "$last_pvd"
done
set +m
"$CUTSIM" run "$scene" --out "$tmp/stopped_INT" --quiet >/dev/null 2>&1
check "a re-run into a stopped run's folder removes its partial files" \
  test ! -e "$tmp/stopped_INT/steps.partial.csv" -a -e "$tmp/stopped_INT/steps.csv"

# ---- the demo scenes load (validation only: a run of each is too long for a test) ----
# (tests/core/test_scene.cpp loads them; here: they are valid JSON files)
for f in "$CUTSIM_DATA_DIR"/scenes/*.json; do
  check "$f is valid JSON" python3 -c 'import json, sys; json.load(open(sys.argv[1]))' "$f"
done

echo "$checks checks, $failures failed"
[ "$failures" -eq 0 ]
