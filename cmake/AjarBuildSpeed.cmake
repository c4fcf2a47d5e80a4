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
