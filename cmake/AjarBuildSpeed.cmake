# Build speed of the sanitizer builds (scripts/test's ASan+UBSan and TSan stages; measurements in
# docs/development.md, "CI time"). AJAR_SANITIZE_CODEGEN follows the build type's flags, so it wins:
# -Og optimises what does not hurt debugging (reports stay precise; it compiles 20-40 % faster than
# -O1, the level the sanitizers' docs suggest, on the codec, the session hub and geometry) and
# -g1 emits line tables only: every report keeps function, file and line, also of inlined frames,
# but GCC does no variable tracking, which dominated the sanitizer builds' compile time (the
# table-driven codec alone took minutes). Set it to "" to keep the build type's flags.
set(AJAR_SANITIZE_CODEGEN "-Og -g1" CACHE STRING
    "Optimisation/debug flags of sanitizer builds (after the build type's)")
if(NOT AJAR_SANITIZE STREQUAL "" AND NOT AJAR_SANITIZE_CODEGEN STREQUAL "")
  separate_arguments(_ajar_sanitize_codegen UNIX_COMMAND "${AJAR_SANITIZE_CODEGEN}")
  add_compile_options(${_ajar_sanitize_codegen})
endif()

# Every target of every build compiles as a unity build (AJAR_UNITY_BATCH source files to a
# translation unit): the product, its tests, the fuzzers, the arm64 cross build and the Debian
# package (debian/rules builds with this default, so what ships is what the tests ran). A unity
# batch compiles in a fraction of the CPU time of its files apart: GCC generates the inline and
# template code the files share (Asio, Beast, gtest, Eigen, the daemon's headers) once per unit
# (docs/development.md, "CI time": the Release product 723 -> 484 CPU s, the 7 TLS test files
# 76 -> 22). A name two files of one target both define collides in a unit: usually a compile
# error, but an earlier file's file-local overload, using-declaration or macro can silently change
# what a later file's call resolves to. So: a file-local helper lives in an anonymous namespace
# *and* has a name that says what it does, and a source's using-directive or macro (#undef it)
# reaches the files after it in its unit. 0 compiles each file on its own (incremental work on one file; finding which file
# an error is in).
set(AJAR_UNITY_BATCH 8 CACHE STRING "Source files per unity translation unit (0: no unity build)")
if(AJAR_UNITY_BATCH GREATER 0)
  set(CMAKE_UNITY_BUILD ON)
  set(CMAKE_UNITY_BUILD_BATCH_SIZE ${AJAR_UNITY_BATCH})
  # GCC takes every source file a unity unit includes for a header, and warns that a class of one
  # (e.g. Recorder::Impl) has a member whose type is in that file's anonymous namespace: an ODR
  # hazard across translation units that include one header, which a .cpp file included once is not.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    add_compile_options(-Wno-subobject-linkage)
  endif()
endif()
