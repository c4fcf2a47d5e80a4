# Sourced by scripts/build and scripts/test: CMake arguments every build of Ajar shares.
# Compilation goes through ccache when it is installed (scripts/install-deps installs it), with
# paths made relative to the checkout so that a fresh clone on the same machine reuses the cache.
# AJAR_NO_CCACHE=1 turns it off.
ajar_cmake_common=()
if [[ "${AJAR_NO_CCACHE:-0}" != 1 ]] && command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
  ajar_cmake_common+=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  # An empty cache (a fresh CI machine) compiles every file: there ccache's depend mode, unless
  # CCACHE_DEPEND is set already. On a miss ccache otherwise runs the preprocessor once more, to
  # hash the preprocessed file (0.1-0.7 CPU s a file here: Asio, Beast, Eigen; docs/development.md,
  # CI time); depend mode hashes the sources and takes the headers from the compiler's own -MD
  # output. It gives up preprocessor-mode hits, which only a cache already holding objects has.
  if [[ -z ${CCACHE_DEPEND+set} ]] &&
    [[ $(ccache --print-stats 2>/dev/null | awk '$1 == "files_in_cache" { print $2 }') == 0 ]]; then
    export CCACHE_DEPEND=1
  fi
fi

# ajar_generator DIR: the CMake generator arguments for a build tree: Ninja (when installed) for a
# new tree; nothing for an existing one (it keeps the generator it was made with: CMake refuses to
# switch). Ninja compiles a target's objects while the libraries it links are still being built,
# where Make waits for each dependency's link: both cores stay busy (docs/development.md, CI time).
ajar_generator() {
  if [[ ! -f $1/CMakeCache.txt ]] && command -v ninja >/dev/null 2>&1; then echo "-G Ninja"; fi
}

# ajar_seed_test_costs FROM TO: give build tree TO the test times measured in FROM
# (Testing/Temporary/CTestCostData.txt) when TO has none of its own, so that its first ctest run
# starts the slowest tests first instead of finishing on them.
ajar_seed_test_costs() {
  local from=$1/Testing/Temporary/CTestCostData.txt to=$2/Testing/Temporary
  if [[ -f $from && ! -f $to/CTestCostData.txt ]]; then
    mkdir -p "$to"
    cp "$from" "$to/CTestCostData.txt"
  fi
}
