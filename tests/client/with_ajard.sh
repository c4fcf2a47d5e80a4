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

# shellcheck source=ajard_process.sh
source "$(dirname "${BASH_SOURCE[0]}")/ajard_process.sh"

dir=$(mktemp -d "${TMPDIR:-/tmp}/ajar-client-test.XXXXXX")
cleanup() {
  ajard_stop
  rm -rf "$dir"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

if ! ajard_start "$ajard" "$config" "$dir" "$dir/ajard.log"; then
  echo "with_ajard.sh: ajard did not start (no port file); its log:" >&2
  cat "$dir/ajard.log" >&2
  exit 99
fi
port=$ajard_port
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
