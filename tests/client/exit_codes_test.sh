#!/usr/bin/env bash
# ajarctl's exit codes without a daemon: 0 for --help/--version, 2 for usage mistakes, 3 when
# nothing listens (a port that was just free; connection refused). A usage mistake's message names
# the argument it is about; likewise for ajar-console and ajar-armsim when given (their --help
# keeps its layout: the man page of ajar-armsim is made from it).
# Usage: exit_codes_test.sh AJARCTL [AJAR_CONSOLE AJAR_ARMSIM]
set -uo pipefail
ajarctl=$1
console=${2:-}
armsim=${3:-}
fail=0
expect() {
  local want=$1; shift
  "$ajarctl" "$@" >/dev/null 2>&1
  local got=$?
  if ((got != want)); then echo "FAIL: ajarctl $* exited $got, expected $want"; fail=1; fi
}
# names WORD PROGRAM ARGS...: PROGRAM ARGS exits 2 and its message names WORD.
names() {
  local word=$1; shift
  local text
  text=$("$@" 2>&1 >/dev/null)
  local got=$?
  if ((got != 2)); then echo "FAIL: $* exited $got, expected 2"; fail=1; fi
  if ! grep -qF -- "$word" <<<"$text"; then
    echo "FAIL: $* does not name $word: $text"
    fail=1
  fi
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
# simulate and conformance (their own parsers); a negative seed is no whole number.
names --seed "$ajarctl" simulate x.yaml --seed -3
names --seeds "$ajarctl" simulate x.yaml --seeds 0
names --plane-points "$ajarctl" simulate x.yaml --plane-points 2
names --trace "$ajarctl" simulate x.yaml --trace
names --frobnicate "$ajarctl" simulate x.yaml --frobnicate
names SCENARIO "$ajarctl" simulate
names --vectors "$ajarctl" --connect 127.0.0.1:1 conformance --vectors
names --frobnicate "$ajarctl" --connect 127.0.0.1:1 conformance --frobnicate
if [[ -n $console ]]; then
  names --frobnicate "$console" --frobnicate
  names --connect "$console" --connect
  names --fps "$console" --fps 100
  names --source "$console" --source webcam
  help=$("$console" --help) || { echo "FAIL: ajar-console --help"; fail=1; }
  [[ $(head -n 1 <<<"$help") == "usage: ajar-console [options]" ]] ||
    { echo "FAIL: ajar-console --help: no usage line first"; fail=1; }
  grep -qx '  --connect HOST:PORT   ajard to connect to (default 127.0.0.1:7450)' <<<"$help" ||
    { echo "FAIL: ajar-console --help: an option is not one line in its column"; fail=1; }
  grep -qx '  --help, --version' <<<"$help" || { echo "FAIL: ajar-console --help"; fail=1; }
  if awk 'length > 100 { exit 1 }' <<<"$help"; then :; else
    echo "FAIL: ajar-console --help has lines over 100 characters"; fail=1
  fi
fi
if [[ -n $armsim ]]; then
  names --frobnicate "$armsim" --frobnicate
  names --task-ms "$armsim" --task-ms abc
  names --silent-ms "$armsim" --silent-ms 4000000
  names --fault "$armsim" --fault explode
  "$armsim" --help | grep -q -- '--fault WORD' || { echo "FAIL: ajar-armsim --help"; fail=1; }
fi
exit $fail
