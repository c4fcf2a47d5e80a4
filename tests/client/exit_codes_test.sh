#!/usr/bin/env bash
# ajarctl's exit codes without a daemon: 0 for --help/--version, 2 for usage mistakes, 3 when
# nothing listens (a port that was just free; connection refused).
set -uo pipefail
ajarctl=$1
fail=0
expect() {
  local want=$1; shift
  "$ajarctl" "$@" >/dev/null 2>&1
  local got=$?
  if ((got != want)); then echo "FAIL: ajarctl $* exited $got, expected $want"; fail=1; fi
}
free_port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1]); s.close()')
expect 0 --help
expect 0 --version
expect 2
expect 2 frobnicate
expect 2 measure width 1 2 3
expect 2 measure plane 1 2 3 4 5 6
expect 2 measure width 1 2 3 4 5 nan
expect 2 --frame sideways status
expect 2 --connect nohostport status
expect 2 --timeout -1 status
expect 2 ping -n 0
expect 3 --connect "127.0.0.1:$free_port" --timeout 2 status
expect 3 --connect "127.0.0.1:$free_port" --timeout 2 measure width 1 0.4 0 1 -0.4 0
"$ajarctl" --help | grep -q "exit codes" || { echo "FAIL: --help does not document exit codes"; fail=1; }
exit $fail
