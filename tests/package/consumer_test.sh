#!/usr/bin/env bash
# The CMake package and the relocatable install, as a host GUI team and an operator meet them:
#   1. `cmake --install BUILD --prefix /usr` into a staging directory (DESTDIR), as packaging does;
#   2. tests/consumer (find_package(ajar 0.1), ajar::client) configured and built against it, and
#      the same source built with `pkg-config ajar`;
#   3. find_package(ajar 0.2) must be refused (0.x: the minor version is the compatibility line);
#   4. the STAGED ajard (card simulator found relative to itself) runs the staged sim example
#      config; both consumers ping it and read its status; the staged ajarctl passes the
#      conformance suite against it with the staged golden vectors (found relative to ajarctl).
#   consumer_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(realpath "$1") src=$(realpath "$2")
tmp=$(mktemp -d "${TMPDIR:-/tmp}/ajar-consumer.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
stage=$tmp/stage
root=$stage/usr

DESTDIR=$stage cmake --install "$build" --prefix /usr >"$tmp/install.log"
echo "staged install: $(find "$stage" -type f | wc -l) files"

launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S "$src/tests/consumer" -B "$tmp/build" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$root" "${launcher[@]}" >"$tmp/configure.log"
grep -q "^ajar_DIR:PATH=$root/" "$tmp/build/CMakeCache.txt" ||
  { echo "FAIL: find_package(ajar) did not use the staged install"; grep ajar_DIR "$tmp/build/CMakeCache.txt"; exit 1; }
cmake --build "$tmp/build" >"$tmp/build.log" || { cat "$tmp/build.log"; exit 1; }

pc_dir=$(dirname "$(find "$root" -name ajar.pc)")
pc_flags=$(PKG_CONFIG_PATH=$pc_dir pkg-config --cflags --libs ajar)
echo "pkg-config ajar: $pc_flags"
# shellcheck disable=SC2086
${launcher:+ccache} g++ -O1 -o "$tmp/consumer-pc" "$src/tests/consumer/consumer.cpp" $pc_flags

mkdir "$tmp/too-new"
cat >"$tmp/too-new/CMakeLists.txt" <<'CM'
cmake_minimum_required(VERSION 3.25)
project(too_new NONE)
find_package(ajar 0.2 QUIET)
if(ajar_FOUND)
  message(FATAL_ERROR "find_package(ajar 0.2) accepted version ${ajar_VERSION}")
endif()
CM
cmake -S "$tmp/too-new" -B "$tmp/too-new/b" -DCMAKE_PREFIX_PATH="$root" >/dev/null

out=$("$src/tests/client/with_ajard.sh" "$root/sbin/ajard" "$root/share/ajar/examples/ajard.sim.yaml" \
  bash -c '"$1" "127.0.0.1:$AJAR_PORT" && "$2" "127.0.0.1:$AJAR_PORT" &&
           "$3" --connect "127.0.0.1:$AJAR_PORT" --json status' _ \
  "$tmp/build/ajar-consumer" "$tmp/consumer-pc" "$root/bin/ajarctl")
echo "$out"
[[ $(grep -c '^ajar-consumer (ajar .*): pong in .* ms, state ' <<<"$out") == 2 ]] ||
  { echo "FAIL: both consumers should report a pong and a state"; exit 1; }
grep -q '"type":"status","command":"status","ok":true' <<<"$out" || { echo "FAIL: staged ajarctl status"; exit 1; }

# The staged ajarctl holds the staged ajard to the protocol with the staged golden vectors (no
# --vectors: found relative to ajarctl).
vec=$("$src/tests/client/with_ajard.sh" "$root/sbin/ajard" "$root/share/ajar/examples/ajard.sim.yaml" \
  "$root/bin/ajarctl" --connect 127.0.0.1:@PORT@ conformance) || { echo "$vec" | grep -v ^PASS; exit 1; }
grep -q "vectors: found in $root/share/ajar/vectors" <<<"$vec" ||
  { echo "FAIL: staged ajarctl does not default to the staged vectors:"; echo "$vec" | head; exit 1; }
tail -n 1 <<<"$vec"
echo "consumer test passed"
