#!/usr/bin/env bash
# The black box end to end (docs/blackbox.md): ajard on simulated drivers records a whole procedure
# (blackbox_procedure.txt through ajarctl script); `ajarctl blackbox save` keeps it, `blackbox
# list` names it, `blackbox fetch` copies it (once whole, once cut short and resumed: the two copies
# are byte-identical); bad fetches are refused naming the field; `blackbox show` and `export --csv`
# read the copy; `ajarctl replay` of it against a fresh ajard reports no difference (exit 0), and
# against an ajard whose door width limit is 0.92 m exactly the one refusal that changed (exit 1).
#   blackbox_replay_test.sh AJARD AJARCTL BASE_CONFIG PROCEDURE
set -uo pipefail
ajard=$1 ajarctl=$2 base_config=$3 procedure=$4
# shellcheck source=ajard_process.sh
source "$(dirname "${BASH_SOURCE[0]}")/ajard_process.sh"
dir=$(mktemp -d "${TMPDIR:-/tmp}/ajar-blackbox-test.XXXXXX")
cleanup() {
  ajard_stop
  rm -rf "$dir"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
fail() {
  echo "FAIL: $*" >&2
  for log in "$dir"/*.log; do
    [[ -f "$log" ]] && { echo "---- $log" >&2; tail -n 30 "$log" >&2; }
  done
  exit 1
}

# start_ajard NAME EXTRA_YAML: ajard with the base config plus EXTRA_YAML, recording into
# $dir/NAME/recordings; sets port.
start_ajard() {
  local name=$1 extra=$2
  mkdir -p "$dir/$name"
  { cat "$base_config"; printf '%s\n' "$extra"; } >"$dir/$name/ajard.yaml"
  ajard_start "$ajard" "$dir/$name/ajard.yaml" "$dir/$name" "$dir/$name.log" ||
    fail "ajard ($name) did not start"
  port=$ajard_port
}
recorder_yaml() {
  printf 'recorder:\n  enabled: true\n  directory: %s\n' "$dir/$1/recordings"
}
ctl() { "$ajarctl" --connect "127.0.0.1:$port" "$@"; }

# An ajard without the recorder (no recorder.* keys): nothing to prove here; say so (ctest SKIP).
if ! "$ajard" --check-config "$base_config" 2>/dev/null | grep -q '^recorder:'; then
  echo "SKIP: this ajard has no recorder (no recorder.* config keys): the black box is not built in"
  exit 77
fi

# 1. Record the procedure.
start_ajard record "$(recorder_yaml record)"
ctl --frame base script "$procedure" >"$dir/procedure.out" 2>&1 ||
  fail "the procedure failed: $(cat "$dir/procedure.out")"
ctl --json blackbox save 600 >"$dir/saved.json" 2>"$dir/save.err" || fail "blackbox save: $(cat "$dir/save.err")"
# The recording of the procedure: the largest one saved (a save may also keep the file it starts).
name=$(python3 -c 'import json,sys; print(max((json.loads(l) for l in sys.stdin if l.strip()), key=lambda r: r["size_bytes"])["name"])' <"$dir/saved.json") ||
  fail "blackbox save printed no recording: $(cat "$dir/saved.json")"
[[ $name == saved/* ]] || fail "the saved recording is named '$name'"
ctl blackbox list >"$dir/list.out" || fail "blackbox list"
grep -q "^$name .*(saved)" "$dir/list.out" || fail "blackbox list does not show $name: $(cat "$dir/list.out")"

# 2. Fetch it whole, and cut short then resumed: the same bytes.
ctl blackbox fetch "$name" -o "$dir/whole.mcap" 2>"$dir/fetch.err" >/dev/null ||
  fail "blackbox fetch: $(cat "$dir/fetch.err")"
grep -q "bytes (100%)" "$dir/fetch.err" || fail "no progress on stderr: $(cat "$dir/fetch.err")"
size=$(stat -c %s "$dir/whole.mcap")
((size > 4096)) || fail "the recording has only $size bytes"
AJARCTL_FETCH_STOP_AFTER_BYTES=2000 ctl blackbox fetch "$name" -o "$dir/resumed.mcap" \
  >/dev/null 2>"$dir/cut.err" && fail "the cut-short fetch succeeded"
partial=$(stat -c %s "$dir/resumed.mcap")
((partial > 0 && partial < size)) || fail "the cut-short fetch left $partial of $size bytes"
ctl blackbox fetch "$name" -o "$dir/resumed.mcap" >/dev/null 2>"$dir/resume.err" ||
  fail "the resumed fetch: $(cat "$dir/resume.err")"
grep -q "resuming .* at $partial bytes" "$dir/resume.err" || fail "no resume line: $(cat "$dir/resume.err")"
cmp "$dir/whole.mcap" "$dir/resumed.mcap" || fail "the resumed copy differs from the whole one"

# 3. Bad fetches are refused naming the field (exit 1).
ctl blackbox fetch ../ajard.state -o "$dir/x" >/dev/null 2>"$dir/bad.err"
(($? == 1)) || fail "fetch of ../ajard.state did not exit 1"
grep -q "NO_SUCH_RECORDING (name)" "$dir/bad.err" || fail "fetch ../ajard.state: $(cat "$dir/bad.err")"
head -c $((size + 10)) /dev/zero >"$dir/longer.mcap"
ctl blackbox fetch "$name" -o "$dir/longer.mcap" >/dev/null 2>"$dir/bad.err"
(($? == 1)) || fail "fetch onto a longer file did not exit 1"
grep -q "REQUEST_OUT_OF_RANGE (offset)" "$dir/bad.err" || fail "fetch beyond the end: $(cat "$dir/bad.err")"
ajard_stop

# 4. Read it: the timeline and the loop trace.
"$ajarctl" blackbox show "$dir/whole.mcap" >"$dir/show.out" 2>&1 || fail "blackbox show: $(cat "$dir/show.out")"
for want in "-> MeasureDoorWidth" "<- Ack" "-> AlignBase" "motion_finished" "-> Engage" "open from"; do
  grep -q -- "$want" "$dir/show.out" || fail "the timeline has no '$want': $(head -40 "$dir/show.out")"
done
"$ajarctl" blackbox export "$dir/whole.mcap" --csv -o "$dir/loop.csv" 2>"$dir/export.err" ||
  fail "blackbox export: $(cat "$dir/export.err")"
head -1 "$dir/loop.csv" | grep -q "left.measured_rad" || fail "loop.csv header: $(head -1 "$dir/loop.csv")"
(($(wc -l <"$dir/loop.csv") > 10)) || fail "loop.csv has $(wc -l <"$dir/loop.csv") lines"

# 5. Replay against a fresh ajard: no difference.
start_ajard fresh "$(recorder_yaml fresh)"
ctl replay "$dir/whole.mcap" >"$dir/replay.out" 2>&1
rc=$?
((rc == 0)) || fail "replay against a fresh ajard exited $rc: $(cat "$dir/replay.out")"
grep -q "^no difference" "$dir/replay.out" || fail "replay: $(cat "$dir/replay.out")"
ajard_stop

# 6. Replay against an ajard whose door width limit is 0.92 m: exactly the first width's refusal.
sed 's/^  door_width_m: .*/  door_width_m: [0.6, 0.92]/' "$base_config" >"$dir/narrow-base.yaml"
grep -q "door_width_m: \[0.6, 0.92\]" "$dir/narrow-base.yaml" || fail "no door_width_m in $base_config"
base_config=$dir/narrow-base.yaml
start_ajard narrow "$(recorder_yaml narrow)"
ctl replay "$dir/whole.mcap" >"$dir/replay-narrow.out" 2>&1
rc=$?
((rc == 1)) || fail "replay against the narrow ajard exited $rc: $(cat "$dir/replay-narrow.out")"
(($(grep -c '^DIFFERENCE' "$dir/replay-narrow.out") == 1)) ||
  fail "expected exactly one difference: $(cat "$dir/replay-narrow.out")"
grep -q "^DIFFERENCE session .* MeasureDoorWidth .*another reply" "$dir/replay-narrow.out" ||
  fail "the difference is not the width: $(cat "$dir/replay-narrow.out")"
grep -q "replayed: Error WIDTH_OUT_OF_RANGE (width_m)" "$dir/replay-narrow.out" ||
  fail "not WIDTH_OUT_OF_RANGE: $(cat "$dir/replay-narrow.out")"
grep -q "^1 difference(s)" "$dir/replay-narrow.out" || fail "summary: $(cat "$dir/replay-narrow.out")"
echo "black box: recorded, saved, fetched (whole = resumed, $size bytes), shown, exported, replayed"
