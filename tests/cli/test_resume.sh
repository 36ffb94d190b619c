#!/usr/bin/env bash
# Checkpoints and resume, end to end (CTest: cli.resume). Demo scenes (a progressive cut with
# CG, a notch torn by fracture under a grasp, the surgery incision with CHOLMOD, FEM and dihedral
# bending, a cloth falling on the ground and one draped over a ball and cut, with contact, the
# surgery flap lifted by forceps) and a SOFA scene are stopped at random steps (--stop-after, SIGINT) and resumed: the resumed run's
# folder must equal, file for file and byte for byte, that of the same run made without a stop.
# Also: writing checkpoints changes no output; a run resumed twice; damaged, truncated and foreign
# checkpoints and a folder missing a frame or its CSV are refused with clear messages.
# Environment: CUTSIM (the program), CUTSIM_DATA_DIR (data), CUTSIM_TEST_DATA_DIR (tests/data),
# CUTSIM_QUICK=1 for shorter runs (the sanitizer build), CUTSIM_SEED to replay a draw of the stop
# steps.
set -uo pipefail

: "${CUTSIM:?set CUTSIM to the cutsim program}"
: "${CUTSIM_DATA_DIR:?set CUTSIM_DATA_DIR to data}"
: "${CUTSIM_TEST_DATA_DIR:?set CUTSIM_TEST_DATA_DIR to tests/data}"

failures=0
checks=0
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
CUTSIM="$(cd "$(dirname "$CUTSIM")" && pwd)/$(basename "$CUTSIM")"
scenes="$(cd "$CUTSIM_DATA_DIR" && pwd)/scenes"
seed="${CUTSIM_SEED:-$(date +%s)}"
RANDOM=$seed
echo "stop steps drawn with CUTSIM_SEED=$seed"

fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}
check() {  # check DESCRIPTION COMMAND...
  local what="$1"
  shift
  checks=$((checks + 1))
  "$@" || fail "$what"
}
# The run's outputs without the checkpoint file (which a run without a stop does not write).
same_outputs() {  # same_outputs REF DIR
  diff -r -q -x checkpoint.ckpt "$1" "$2" >"$tmp/diff" 2>&1 || { head -5 "$tmp/diff" >&2; return 1; }
}
# A copy of a demo scene that lasts DURATION seconds.
shortened() {  # shortened NAME DURATION -> path
  local out="$tmp/scene_$1.json"
  sed -E "s/\"duration\": *[0-9.]+/\"duration\": $2/" "$scenes/$1.json" >"$out"
  echo "$out"
}

# name, duration (past the scene's last action), steps, and whether to also stop twice and
# write checkpoints along the way (the longest runs only once; under the sanitizers, fewer).
if [ "${CUTSIM_QUICK:-0}" = 1 ]; then
  cases=("hanging_cut 1.8 360 1" "tearing 0.8 160 1" "surgery_incision 1.35 270 0" "fold_ground 0.2 100 0")
else
  cases=("hanging_cut 4 800 1" "tearing 1.6 320 1" "surgery_incision 1.5 300 1" "fold_ground 0.5 250 1"
         "drape_cut 1.4 700 0" "surgery_flap 1.6 320 0")
fi

for c in "${cases[@]}"; do
  read -r name duration steps all <<<"$c"
  scene="$(shortened "$name" "$duration")"
  ref="$tmp/ref_$name"
  "$CUTSIM" run "$scene" --out "$ref" --quiet >/dev/null 2>"$tmp/err"
  code=$?
  check "$name: the run without a stop exits with 0 ($(head -3 "$tmp/err"))" [ "$code" -eq 0 ]

  # Stopped once at a random step, resumed to the end.
  s=$((1 + RANDOM % (steps - 1)))
  dir="$tmp/once_$name"
  "$CUTSIM" run "$scene" --out "$dir" --quiet --stop-after "$s" >/dev/null 2>"$tmp/err"
  code=$?
  check "$name: --stop-after $s exits with 0 ($(head -3 "$tmp/err"))" [ "$code" -eq 0 ]
  check "$name: the stop says how to resume" grep -q "resume with: cutsim resume $dir/checkpoint.ckpt" "$tmp/err"
  check "$name: the stopped run's CSV is marked partial" [ -f "$dir/steps.partial.csv" ] && [ ! -f "$dir/steps.csv" ]
  check "$name: the stopped run left its checkpoint" [ -s "$dir/checkpoint.ckpt" ]
  "$CUTSIM" resume "$dir/checkpoint.ckpt" --quiet >"$tmp/out" 2>"$tmp/err"
  code=$?
  check "$name: resume from step $s exits with 0 ($(head -3 "$tmp/err"))" [ "$code" -eq 0 ]
  check "$name: the summary says where it resumed" grep -q "resumed at step $s" "$tmp/out"
  check "$name: stopped at step $s and resumed, the outputs equal the run's without a stop" same_outputs "$ref" "$dir"

  [ "$all" = 1 ] || continue
  # Stopped twice (the second stop by the resumed run), then resumed to the end.
  s1=$((1 + RANDOM % (steps / 2)))
  s2=$((s1 + 1 + RANDOM % (steps - s1 - 1)))
  dir="$tmp/twice_$name"
  "$CUTSIM" run "$scene" --out "$dir" --quiet --stop-after "$s1" >/dev/null 2>&1
  "$CUTSIM" resume "$dir/checkpoint.ckpt" --quiet --stop-after "$s2" >/dev/null 2>"$tmp/err"
  check "$name: a resumed run stops again at $s2 ($(head -3 "$tmp/err"))" grep -q "after step $s2 " "$tmp/err"
  "$CUTSIM" resume "$dir/checkpoint.ckpt" --quiet >/dev/null 2>&1
  check "$name: stopped at $s1 and $s2, the outputs equal the run's without a stop" same_outputs "$ref" "$dir"

  # Checkpoints written along the way change nothing of the outputs.
  every=$((1 + RANDOM % 60))
  dir="$tmp/every_$name"
  "$CUTSIM" run "$scene" --out "$dir" --quiet --checkpoint-every "$every" >"$tmp/out" 2>&1
  check "$name: a run with --checkpoint-every $every writes the outputs of one without" same_outputs "$ref" "$dir"
  check "$name: the summary names the checkpoint" grep -q "checkpoint .*every $every steps" "$tmp/out"
done

# ---- SIGINT: the stop writes a checkpoint; resumed, the outputs are the uninterrupted run's ----
set -m  # the run in its own process group, as a terminal's foreground job (SIGINT not ignored)
name=hanging_cut
read -r _ duration _ <<<"${cases[0]}"
scene="$tmp/scene_$name.json"
dir="$tmp/sigint"
"$CUTSIM" run "$scene" --out "$dir" --quiet >/dev/null 2>"$tmp/err" &
pid=$!
for _ in $(seq 1 400); do
  [ -f "$dir/surface_000003.vtp" ] && break
  sleep 0.05
done
kill -INT "$pid" 2>/dev/null
wait "$pid"
code=$?
set +m
if [ "$code" -eq 130 ]; then
  check "SIGINT: the stop names the checkpoint" grep -q "resume with: cutsim resume" "$tmp/err"
  "$CUTSIM" resume "$dir/checkpoint.ckpt" --quiet >/dev/null 2>"$tmp/err"
  code=$?
  check "SIGINT: resume exits with 0 ($(head -3 "$tmp/err"))" [ "$code" -eq 0 ]
  check "SIGINT: stopped and resumed, the outputs equal the run's without a stop" same_outputs "$tmp/ref_$name" "$dir"
elif [ "$code" -ne 0 ]; then
  fail "SIGINT: the run ended with $code ($(head -3 "$tmp/err"))"
fi  # (0: the run ended before the signal came; nothing to resume)

# ---- SIGKILL: nothing is written at the end; resumed from the last periodic checkpoint ----
dir="$tmp/sigkill"
"$CUTSIM" run "$scene" --out "$dir" --quiet --checkpoint-every 25 >/dev/null 2>&1 &
pid=$!
for _ in $(seq 1 400); do
  [ -f "$dir/checkpoint.ckpt" ] && [ -f "$dir/surface_000006.vtp" ] && break
  sleep 0.05
done
kill -KILL "$pid" 2>/dev/null
wait "$pid" 2>/dev/null
if [ -f "$dir/.steps.csv.tmp" ]; then
  "$CUTSIM" resume "$dir/checkpoint.ckpt" --quiet >/dev/null 2>"$tmp/err"
  code=$?
  check "SIGKILL: resume from the last checkpoint exits with 0 ($(head -3 "$tmp/err"))" [ "$code" -eq 0 ]
  check "SIGKILL: killed and resumed, the outputs equal the run's without a stop" same_outputs "$tmp/ref_$name" "$dir"
fi  # (else the run ended before the signal came)

# ---- refusals ----
expect() {  # expect DESCRIPTION CODE PATTERN COMMAND...: the command fails with CODE, stderr matches PATTERN
  local what="$1" code="$2" pattern="$3"
  shift 3
  "$@" >/dev/null 2>"$tmp/err"
  local got=$?
  checks=$((checks + 1))
  if [ "$got" -ne "$code" ] || ! grep -qE -e "$pattern" "$tmp/err"; then
    fail "$what: expected exit $code and /$pattern/, got $got: $(head -3 "$tmp/err")"
  fi
}
scene="$tmp/scene_hanging_cut.json"
"$CUTSIM" run "$scene" --out "$tmp/good" --quiet --stop-after 20 >/dev/null 2>&1
ck="$tmp/good/checkpoint.ckpt"
size=$(stat -c %s "$ck")

cp -r "$tmp/good" "$tmp/damaged"
printf '\xff' | dd of="$tmp/damaged/checkpoint.ckpt" bs=1 seek=$((size / 2)) conv=notrunc status=none
expect "a damaged checkpoint" 2 "checkpoint.ckpt.*(checksum|damaged)" "$CUTSIM" resume "$tmp/damaged/checkpoint.ckpt"
cp -r "$tmp/good" "$tmp/truncated"
truncate -s $((size - 100)) "$tmp/truncated/checkpoint.ckpt"
expect "a truncated checkpoint" 2 "checkpoint.ckpt.*(truncated|ends)" "$CUTSIM" resume "$tmp/truncated/checkpoint.ckpt"
expect "a file that is not a checkpoint" 2 "scene_hanging_cut.json.*not" "$CUTSIM" resume "$scene"
expect "a missing checkpoint" 2 "nothing.ckpt" "$CUTSIM" resume "$tmp/nothing.ckpt"
expect "a folder given as the checkpoint" 2 "is a folder" "$CUTSIM" resume "$tmp/good"

cp -r "$tmp/good" "$tmp/noframe"
rm "$tmp/noframe/surface_000001.vtp"
expect "a folder missing a frame" 1 "frames of the run up to the checkpoint are missing \(surface_000001.vtp" \
  "$CUTSIM" resume "$tmp/noframe/checkpoint.ckpt"
cp -r "$tmp/good" "$tmp/nocsv"
rm "$tmp/nocsv/steps.partial.csv"
expect "a folder missing its CSV" 1 "no steps.csv, steps.partial.csv or .steps.csv.tmp there holds" \
  "$CUTSIM" resume "$tmp/nocsv/checkpoint.ckpt"
cp -r "$tmp/good" "$tmp/othercsv"
sed -i '3s/[0-9]/7/' "$tmp/othercsv/steps.partial.csv"
expect "a CSV changed since the checkpoint" 1 "holds the run's rows up to the checkpoint" \
  "$CUTSIM" resume "$tmp/othercsv/checkpoint.ckpt"
cp -r "$tmp/good" "$tmp/otherframe"
"$CUTSIM" run "$CUTSIM_TEST_DATA_DIR/scenes/small.json" --out "$tmp/small" --quiet >/dev/null 2>&1
cp "$tmp/small/surface_000002.vtp" "$tmp/otherframe/surface_000002.vtp"
expect "a frame another run wrote" 1 "surface_000002.vtp is not the frame the checkpoint's run wrote" \
  "$CUTSIM" resume "$tmp/otherframe/checkpoint.ckpt"
expect "--stop-after before the checkpoint" 2 "--stop-after: 5 is not after the checkpoint's step 20" \
  "$CUTSIM" resume "$ck" --stop-after 5
expect "--html onto the run's own files" 2 "--html: .*checkpoint.ckpt is one of the run's own files" \
  "$CUTSIM" run "$scene" --out "$tmp/html" --quiet --html "$tmp/html/checkpoint.ckpt"
expect "a file that is not a regular file" 2 "not a regular file" "$CUTSIM" resume /dev/zero

# ---- OBJ frames only, and what the run was asked for at its end (--html, --dump-final) ----
sed -E 's/"output": \{[^}]*\}/"output": {"every": 5, "vtk": false, "obj": true}/' \
  "$CUTSIM_TEST_DATA_DIR/scenes/small.json" >"$tmp/obj.json"
"$CUTSIM" run "$tmp/obj.json" --out "$tmp/obj_ref" --quiet --dump-final "$tmp/obj_ref_dump" >/dev/null 2>&1
"$CUTSIM" run "$tmp/obj.json" --out "$tmp/obj" --quiet --stop-after 12 --dump-final "$tmp/obj_dump" >/dev/null 2>&1
cp -r "$tmp/obj" "$tmp/obj_noframe"
"$CUTSIM" resume "$tmp/obj/checkpoint.ckpt" --quiet >/dev/null 2>"$tmp/err"
code=$?
check "OBJ frames only: resume exits with 0 ($(head -3 "$tmp/err"))" [ "$code" -eq 0 ]
check "OBJ frames only: stopped and resumed, the outputs equal the run's without a stop" same_outputs "$tmp/obj_ref" "$tmp/obj"
check "--dump-final given to the run is written by the resumed run" diff -r "$tmp/obj_ref_dump" "$tmp/obj_dump"
rm "$tmp/obj_noframe/frame_000001.obj"
expect "a folder missing an OBJ frame" 1 "missing \(frame_000001.obj" "$CUTSIM" resume "$tmp/obj_noframe/checkpoint.ckpt"
"$CUTSIM" run "$scene" --out "$tmp/page" --quiet --stop-after 30 --html >/dev/null 2>&1
"$CUTSIM" resume "$tmp/page/checkpoint.ckpt" --quiet >/dev/null 2>&1
check "--html given to the run: the resumed run writes the player" [ -s "$tmp/page/player.html" ]

# ---- a SOFA scene: its checkpoint holds its JSON translation ----
sofa="$CUTSIM_TEST_DATA_DIR/sofa-scenes/FastTriangularBendingSprings.scn"
"$CUTSIM" run "$sofa" --steps 40 --out "$tmp/sofa_ref" --quiet >/dev/null 2>&1
s=$((1 + RANDOM % 39))
"$CUTSIM" run "$sofa" --steps 40 --out "$tmp/sofa" --quiet --stop-after "$s" >/dev/null 2>&1
(cd / && "$CUTSIM" resume "$tmp/sofa/checkpoint.ckpt" --quiet >/dev/null 2>"$tmp/err")
code=$?
check "SOFA scene: resumed from step $s in another folder, exits with 0 ($(head -3 "$tmp/err"))" [ "$code" -eq 0 ]
check "SOFA scene: stopped at step $s and resumed, the outputs equal the run's without a stop" same_outputs "$tmp/sofa_ref" "$tmp/sofa"

echo "$checks checks, $failures failed"
[ "$failures" -eq 0 ]
