#!/usr/bin/env bash
# The bash completion script, loaded into bash and driven as bash drives it (COMP_WORDS/COMP_CWORD)
# with the ajarctl built here.
#   completion_test.sh AJARCTL COMPLETION_SCRIPT
set -euo pipefail
ajarctl=$(realpath "$1") script=$(realpath "$2")
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ajar-completion.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
ln -s "$ajarctl" "$tmp/ajarctl"
touch "$tmp/left-hinge.yaml"
cd "$tmp"
complete_line() {  # words of the line; the last one is the word being completed
  bash -c 'source "$1"; shift; COMP_WORDS=("$@"); COMP_CWORD=$((${#COMP_WORDS[@]} - 1));
           _ajarctl; printf "%s\n" "${COMPREPLY[@]}"' _ "$script" "$@" | sort | tr '\n' ' '
}
fail=0
expect() {  # expect "WANTED REPLIES" WORD...
  local want=$1; shift
  local got; got=$(complete_line "$@")
  if [[ "$got" != "$want" ]]; then echo "FAIL: ajarctl ${*:2} <TAB>: got '$got', want '$want'"; fail=1; fi
}
expect "status " ./ajarctl sta
expect "--json " ./ajarctl --js
expect "engage estop " ./ajarctl e
expect "handle " ./ajarctl --json measure h
expect "--no-wait " ./ajarctl align --no
expect "base camera " ./ajarctl --frame ""
expect "left-hinge.yaml " ./ajarctl simulate le
expect "conformance contact " ./ajarctl help con
exit $fail
