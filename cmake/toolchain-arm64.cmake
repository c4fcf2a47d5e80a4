# Cross-building Ajar for arm64 (aarch64) on a Debian 12 amd64 machine, with Debian's cross toolchain
# and multiarch libraries (scripts/install-deps-arm64 installs them; scripts/test-arm64 uses this
# file; docs/packaging.md, "arm64"):
#   cmake -S . -B build-arm64 -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-arm64.cmake
#         [-DAJAR_ARM64_SYSROOT=build-arm64-sysroot]
# - compilers: aarch64-linux-gnu-gcc/g++ (GCC 12, crossbuild-essential-arm64); they search the
#   multiarch directories themselves (/usr/include/aarch64-linux-gnu, /usr/lib/aarch64-linux-gnu);
# - libraries and CMake packages: the arm64 ones only (/usr/lib/aarch64-linux-gnu), then
#   AJAR_ARM64_SYSROOT, where the two -dev packages that are not Multi-Arch in Debian 12
#   (libserial-dev, libyaml-cpp-dev) are unpacked; architecture-independent packages (Eigen,
#   CLI11, nlohmann-json: /usr/share) serve both architectures;
# - pkg-config: the arm64 .pc files only;
# - programs built here run under qemu-user (CMAKE_CROSSCOMPILING_EMULATOR): ctest, the tests'
#   discovery, help2man for the man pages.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

if(NOT AJAR_ARM64_SYSROOT)
  get_filename_component(AJAR_ARM64_SYSROOT "${CMAKE_CURRENT_LIST_DIR}/../build-arm64-sysroot"
                         ABSOLUTE)
endif()
set(AJAR_ARM64_SYSROOT "${AJAR_ARM64_SYSROOT}" CACHE PATH
    "Where scripts/install-deps-arm64 unpacked the arm64 -dev packages that are not Multi-Arch")
# Re-rooted searches: "/" (the multiarch directories; CMAKE_LIBRARY_ARCHITECTURE selects
# lib/aarch64-linux-gnu), then the sysroot. Programs (help2man, perl) are the build machine's.
set(CMAKE_FIND_ROOT_PATH / "${AJAR_ARM64_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# The sysroot's headers (yaml-cpp, libserial) come after the system's: they are the same files as
# the amd64 -dev packages', when those are installed.
include_directories(SYSTEM AFTER "${AJAR_ARM64_SYSROOT}/usr/include")

set(ENV{PKG_CONFIG_LIBDIR}
    "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig:${AJAR_ARM64_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

find_program(AJAR_QEMU_AARCH64 qemu-aarch64 REQUIRED)
# The dynamic loader and libraries come from the multiarch packages (libc6:arm64 installs
# /lib/ld-linux-aarch64.so.1), so qemu needs no -L.
set(CMAKE_CROSSCOMPILING_EMULATOR "${AJAR_QEMU_AARCH64}")
