#!/usr/bin/env bash
# ajarctl drive --for and approach against the real ajard (run by with_ajard.sh, port in $1).
# A daemon whose RobotModel has no drive limits (max_linear_speed_m_s 0: driving not implemented,
# protocol.md 5.22) must refuse with NOT_SUPPORTED: ajarctl then exits 1 with the daemon's sentence.
# Otherwise: drive moves the base and comes to rest; approach from 1.2 m ends at the standoff.
#   drive_e2e_test.sh AJARCTL PORT
set -uo pipefail
ajarctl=$1 port=$2
A=("$ajarctl" --connect "127.0.0.1:$port")
fail() { echo "FAIL: $*" >&2; exit 1; }
json() { python3 -c "import json,sys; v=json.loads(sys.stdin.readlines()[-1]); print($1)"; }

max=$("${A[@]}" --json model | json 'v["robot_model"]["max_linear_speed_m_s"]') || fail "model"
if [[ $max == 0 || $max == 0.0 ]]; then
  out=$("${A[@]}" drive --linear 0.1 --for 0.5 2>&1); rc=$?
  ((rc == 1)) || fail "drive on a daemon that does not drive: exit $rc, want 1: $out"
  [[ $out == *NOT_SUPPORTED* ]] || fail "drive: no NOT_SUPPORTED in: $out"
  out=$("${A[@]}" approach 0.75 2>&1); rc=$?
  ((rc == 1)) || fail "approach on a daemon that does not drive: exit $rc, want 1: $out"
  [[ $out == *NOT_SUPPORTED* ]] || fail "approach: no NOT_SUPPORTED in: $out"
  echo "PASS (the daemon does not drive yet: refusals checked)"
  exit 0
fi

out=$("${A[@]}" --json drive --linear 0.1 --for 0.5 2>&1) || fail "drive --for: $out"
moved=$(json 'v["moved_m"] if v["type"] == "drive_result" and v["ok"] else -1' <<<"$out")
python3 -c "import sys; sys.exit(0 if $moved > 0.01 else 1)" || fail "drive moved $moved m: $out"

out=$("${A[@]}" --json --frame base script <<'SCRIPT' 2>&1
reset --clear
measure width 1.2 0.45 0.3 1.2 -0.45 0.3
approach 1.0 --wait-timeout 60
SCRIPT
) || fail "approach script: $out"
distance=$(json 'v["door_distance_m"] if v["type"] == "approach_result" and v["ok"] else -1' <<<"$out")
python3 -c "import sys; sys.exit(0 if abs($distance - 1.0) < 0.01 else 1)" ||
  fail "approach ended $distance m from the door, want 1.0: $out"
echo "PASS (drive moved $moved m; approach ended $distance m from the door)"
