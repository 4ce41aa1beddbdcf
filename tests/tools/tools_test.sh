#!/usr/bin/env bash
# The command-line tools on the bundled lab session, whole and damaged:
#   - avatar-replay reproduces every recorded result (exit 0), and on a copy
#     with one altered log line reports that record as damaged, compares the
#     others and exits 1;
#   - avatar-analyze prints every iteration (exit 0), and on the damaged copy
#     names the damaged record on standard error, analyses the rest, exits 1;
#   - avatar-render --scorpion renders exactly what --config data/config/scorpion.xml
#     renders (the built-in calibration is the sample's).
#
#   tools_test.sh SOURCE_DIR BUILD_DIR WORK_DIR
set -euo pipefail

src=$1 build=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
replay=$build/tools/avatar-replay/avatar-replay
analyze=$build/tools/avatar-analyze/avatar-analyze
render=$build/tools/avatar-render/avatar-render

# --- the whole session
"$replay" --session "$src/data/sessions/lab" --report "$work/report.txt" >"$work/replay.out" ||
  fail "avatar-replay on the lab session exited $?: $(cat "$work/replay.out")"
grep -q '^summary: 3 records, 3 iterations replayed: 3 identical, 0 different, 0 damaged, 0 failed' \
  "$work/replay.out" || fail "avatar-replay summary: $(tail -1 "$work/replay.out")"
grep -q '^iteration 2 (group 1 member 1): identical$' "$work/report.txt" || fail "report lacks iteration 2"

"$analyze" --session "$src/data/sessions/lab" >"$work/analyze.out" 2>"$work/analyze.err" ||
  fail "avatar-analyze on the lab session exited $?: $(cat "$work/analyze.err")"
[ "$(grep -c '^iteration [0-9]' "$work/analyze.out")" = 3 ] || fail "avatar-analyze did not print 3 iterations"
grep -Eq '^  sample +stereo,whole +vision ' "$work/analyze.out" || fail "avatar-analyze printed no stereo sample"

# --- one record damaged: its line altered, so its checksum no longer matches
cp -r "$src/data/sessions/lab" "$work/damaged"
sed -i '3s/leftCrc=[0-9a-f]\{8\} /leftCrc=00000000 /' "$work/damaged/session.log"
set +e
"$replay" --session "$work/damaged" >"$work/replay-damaged.out" 2>&1
rc=$?
set -e
[ $rc = 1 ] || fail "avatar-replay on a damaged session exited $rc, not 1"
grep -q "^DAMAGED: $work/damaged/session.log:3: line checksum mismatch" "$work/replay-damaged.out" ||
  fail "avatar-replay did not name the damaged line: $(cat "$work/replay-damaged.out")"
grep -q '2 iterations replayed: 2 identical, 0 different, 1 damaged' "$work/replay-damaged.out" ||
  fail "avatar-replay summary on the damaged session: $(tail -1 "$work/replay-damaged.out")"

set +e
"$analyze" --session "$work/damaged" >"$work/analyze-damaged.out" 2>"$work/analyze-damaged.err"
rc=$?
set -e
[ $rc = 1 ] || fail "avatar-analyze on a damaged session exited $rc, not 1"
grep -q "^avatar-analyze: damaged record: $work/damaged/session.log:3: line checksum mismatch" \
  "$work/analyze-damaged.err" || fail "avatar-analyze did not name the damaged line: $(cat "$work/analyze-damaged.err")"
[ "$(grep -c '^iteration [0-9]' "$work/analyze-damaged.out")" = 2 ] || fail "avatar-analyze did not analyse the other 2"

# --- the built-in Scorpion calibration is the sample's
"$render" --scorpion --scene "$src/data/scenes/lab.xml" --out "$work/scorpion" --no-preview --supersampling 1 \
  --no-noise >"$work/scorpion.out"
"$render" --config "$src/data/config/scorpion.xml" --scene "$src/data/scenes/lab.xml" --out "$work/sample" \
  --no-preview --supersampling 1 --no-noise >"$work/sample.out"
diff <(grep '^  [a-z]' "$work/scorpion.out" | grep -v 'scene file') \
     <(grep '^  [a-z]' "$work/sample.out" | grep -v 'scene file') ||
  fail "--scorpion and --config data/config/scorpion.xml render differently"
cmp "$work/scorpion/L_00001_00000_1280x960_16b_1c_BG_le.raw" "$work/sample/L_00001_00000_1280x960_16b_1c_BG_le.raw" ||
  fail "--scorpion and the sample configuration give different images"
echo "PASS: avatar-replay, avatar-analyze and avatar-render behave as documented"
