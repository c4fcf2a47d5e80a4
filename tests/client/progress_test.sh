#!/usr/bin/env bash
# align and engage show progress while they wait: with wheels slowed to 0.1 rad/s the turn takes
# about a second, so `ajarctl align` must print at least one progress line (elapsed time, yaw still
# to go) between its Ack and its result, in text and in JSON.
#   progress_test.sh AJARD AJARCTL SOURCE_DIR
set -euo pipefail
ajard=$1 ajarctl=$2 src=$3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ajar-progress.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
sed -e 's/max_wheel_speed_rad_s: .*/max_wheel_speed_rad_s: 0.1/' -e 's/speedup: .*/speedup: 1.0/' \
  "$src/config/ajard.yaml" >"$tmp/slow.yaml"
grep -q "max_wheel_speed_rad_s: 0.1" "$tmp/slow.yaml"
cat >"$tmp/procedure.txt" <<'P'
reset --clear
measure width -0.435 -0.52 0.85 0.465 -0.52 0.85
measure handle 0.365 -0.52 0.80 0.245 -0.52 0.80
measure plane -0.0049 -0.22 0.835 -0.3049 -0.22 0.8457 -0.2549 -0.92 0.8432 0.265 -0.82 0.83
align
P
with=$src/tests/client/with_ajard.sh
text=$("$with" "$ajard" "$tmp/slow.yaml" "$ajarctl" --connect 127.0.0.1:@PORT@ script "$tmp/procedure.txt")
echo "$text" | grep '^align'
grep -Eq '^align: +[0-9.]+ s, turned [-+][0-9.]+ rad, [-+][0-9.]+ rad \(.* deg\) to go$' <<<"$text" ||
  { echo "FAIL: no align progress line"; exit 1; }
json=$("$with" "$ajard" "$tmp/slow.yaml" "$ajarctl" --json --connect 127.0.0.1:@PORT@ script "$tmp/procedure.txt")
grep -q '"type":"progress","command":"align","ok":true,"elapsed_s":.*"yaw_remaining_rad":' <<<"$json" ||
  { echo "FAIL: no JSON progress object"; echo "$json" | grep align; exit 1; }
echo "progress shown"
