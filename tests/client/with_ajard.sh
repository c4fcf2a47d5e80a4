#!/usr/bin/env bash
# Runs one command against a private ajard: starts AJARD with CONFIG on 127.0.0.1 port 0 (the
# kernel picks a free port) and a fresh temporary state directory, waits for the port file, runs
# the command with every "@PORT@" in its arguments replaced by the port (also exported as
# AJAR_PORT), then stops ajard (also on failure or interrupt) and removes the temporary directory.
#   with_ajard.sh AJARD CONFIG COMMAND [ARGS...]
# Exit status: the command's; 99 when ajard did not come up (its log is printed).
set -uo pipefail
if (($# < 3)); then
  echo "usage: $0 AJARD CONFIG COMMAND [ARGS...]" >&2
  exit 2
fi
ajard=$1 config=$2
shift 2

dir=$(mktemp -d "${TMPDIR:-/tmp}/ajar-client-test.XXXXXX")
pid=""
cleanup() {
  if [[ -n "$pid" ]] && kill -0 "$pid" 2>/dev/null; then
    kill -TERM "$pid" 2>/dev/null
    for _ in $(seq 1 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.05; done
    kill -KILL "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
  fi
  rm -rf "$dir"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

"$ajard" --config "$config" --listen 127.0.0.1:0 --port-file "$dir/port" \
  --state-dir "$dir/state" >"$dir/ajard.log" 2>&1 &
pid=$!

for _ in $(seq 1 400); do
  [[ -s "$dir/port" ]] && break
  if ! kill -0 "$pid" 2>/dev/null; then break; fi
  sleep 0.05
done
if [[ ! -s "$dir/port" ]]; then
  echo "with_ajard.sh: ajard did not start (no port file); its log:" >&2
  cat "$dir/ajard.log" >&2
  exit 99
fi
port=$(cat "$dir/port")
export AJAR_PORT=$port

args=()
for a in "$@"; do args+=("${a//@PORT@/$port}"); done
"${args[@]}"
rc=$?
if ((rc != 0)); then
  echo "with_ajard.sh: command exited $rc; ajard's log:" >&2
  tail -n 50 "$dir/ajard.log" >&2
fi
exit $rc
