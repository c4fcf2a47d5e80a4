# Sourced by scripts/build and scripts/test: CMake arguments every build of Ajar shares.
# Compilation goes through ccache when it is installed (scripts/install-deps installs it), with
# paths made relative to the checkout so that a fresh clone on the same machine reuses the cache.
# AJAR_NO_CCACHE=1 turns it off.
ajar_cmake_common=()
if [[ "${AJAR_NO_CCACHE:-0}" != 1 ]] && command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
  ajar_cmake_common+=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
