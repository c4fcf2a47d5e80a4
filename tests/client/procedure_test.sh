#!/usr/bin/env bash
# The whole door procedure through `ajarctl --json script` on one controller session, then the
# JSON checked field by field. procedure.txt ends with one deliberate refusal (--keep-going), so
# ajarctl must exit 1 (the daemon refused), not 0, 2 or 3.
#   procedure_test.sh AJARCTL PORT SCRIPT CHECKER
set -uo pipefail
ajarctl=$1 port=$2 script=$3 checker=$4
out=$("$ajarctl" --connect "127.0.0.1:$port" --json --frame base --keep-going script "$script")
rc=$?
if ((rc != 1)); then
  echo "ajarctl exited $rc, expected 1 (one deliberate refusal); output:" >&2
  echo "$out" >&2
  exit 1
fi
printf '%s\n' "$out" | python3 "$checker"
