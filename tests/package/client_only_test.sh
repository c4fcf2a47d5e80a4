#!/usr/bin/env bash
# The client-only build a host GUI team makes: -DAJAR_CLIENT_ONLY=ON with yaml-cpp and spdlog made
# unfindable (CMAKE_DISABLE_FIND_PACKAGE_*) must configure, never look for libserial or libsystemd,
# build ajar::client, and install the find_package(ajar) files (checked by building
# tests/consumer against that install).
# The build directory is BUILD_DIR-client-only, a sibling of BUILD_DIR at the same depth and kept
# between runs: its compile commands are then those of BUILD_DIR's core, protocol, security and
# client to the letter (ccache makes paths relative), so with ccache on (scripts/cmake-common.sh)
# a CI run compiles them once, not twice.
#   client_only_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(realpath "$1")
tmp=$(realpath "$2")-client-only
rm -rf "$tmp/prefix" "$tmp/consumer"
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
# The same generator as BUILD_DIR (Ninja and Make write different compile commands): a tree left
# from another generator is started afresh.
generator=$(sed -n 's/^CMAKE_GENERATOR:INTERNAL=//p' "$(realpath "$2")/CMakeCache.txt")
if [[ -f $tmp/CMakeCache.txt ]] && ! grep -qx "CMAKE_GENERATOR:INTERNAL=$generator" "$tmp/CMakeCache.txt"; then
  rm -rf "$tmp"
fi
mkdir -p "$tmp"
cmake -S "$src" -B "$tmp" -G "$generator" -DCMAKE_BUILD_TYPE=Release -DAJAR_CLIENT_ONLY=ON \
  -DCMAKE_DISABLE_FIND_PACKAGE_yaml-cpp=ON -DCMAKE_DISABLE_FIND_PACKAGE_spdlog=ON \
  -DCMAKE_INSTALL_PREFIX="$tmp/prefix" "${launcher[@]}" >"$tmp/configure.log" ||
  { cat "$tmp/configure.log"; exit 1; }
if grep -Eq '^(LIBSERIAL|LIBSYSTEMD|spdlog|yaml-cpp)_' "$tmp/CMakeCache.txt"; then
  echo "FAIL: the client-only build looked for a daemon dependency:"
  grep -E '^(LIBSERIAL|LIBSYSTEMD|spdlog|yaml-cpp)_' "$tmp/CMakeCache.txt"
  exit 1
fi
cmake --build "$tmp" -j2 >"$tmp/build.log" || { tail -50 "$tmp/build.log"; exit 1; }
for t in ajard ajar_daemon ajar_drivers ajarctl; do
  if grep -q "/$t\.dir\$" "$tmp/CMakeFiles/TargetDirectories.txt"; then
    echo "FAIL: the client-only build has target $t"; exit 1
  fi
done
cmake --install "$tmp" >/dev/null
cmake -S "$src/tests/consumer" -B "$tmp/consumer" -DCMAKE_PREFIX_PATH="$tmp/prefix" \
  "${launcher[@]}" >/dev/null
cmake --build "$tmp/consumer" >/dev/null
echo "client-only build passed: $(find "$tmp/prefix" -name 'libajar_*.a' -printf '%f ')"
