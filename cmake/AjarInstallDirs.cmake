# Where an installed Ajar puts its files (GNUInstallDirs plus Ajar's own directories), and the
# header that lets the installed programs find their files relative to their own location, so
# that an install tree can be moved (DESTDIR staging, another prefix) and still work.
#
#   AJAR_INSTALL_PKGLIBDIR   the package's private libraries: the card simulator (LIBDIR/ajar)
#   AJAR_INSTALL_PKGDATADIR  golden vectors, example configs and scenarios (DATADIR/ajar)
#   AJAR_INSTALL_CMAKEDIR    ajarConfig.cmake and friends (LIBDIR/cmake/ajar)
#   AJAR_INSTALL_CONFDIR     /etc/ajar when the prefix is /usr (GNUInstallDirs' special case),
#                            else SYSCONFDIR/ajar relative to the prefix
#   AJAR_INSTALL_UNITDIR     the systemd unit (lib/systemd/system under the prefix)
set(AJAR_INSTALL_PKGLIBDIR "${CMAKE_INSTALL_LIBDIR}/ajar" CACHE STRING
    "Private libraries of Ajar (card simulator), relative to the prefix")
set(AJAR_INSTALL_PKGDATADIR "${CMAKE_INSTALL_DATADIR}/ajar" CACHE STRING
    "Ajar's data (golden vectors, examples), relative to the prefix")
set(AJAR_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/ajar" CACHE STRING
    "CMake package files of Ajar, relative to the prefix")
set(AJAR_INSTALL_UNITDIR "lib/systemd/system" CACHE STRING "systemd system unit directory")
if(CMAKE_INSTALL_FULL_SYSCONFDIR STREQUAL "${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_SYSCONFDIR}")
  set(AJAR_INSTALL_CONFDIR "${CMAKE_INSTALL_SYSCONFDIR}/ajar")
else()
  set(AJAR_INSTALL_CONFDIR "${CMAKE_INSTALL_FULL_SYSCONFDIR}/ajar")
endif()

# Paths from the directory of an installed program to its files. Only relative directories go in,
# so the binaries do not depend on the prefix they were configured with.
function(ajar_relative_dir out from to)
  foreach(dir from to)
    if(IS_ABSOLUTE "${${dir}}")
      set(${dir}_full "${${dir}}")
    else()
      set(${dir}_full "${CMAKE_INSTALL_PREFIX}/${${dir}}")
    endif()
  endforeach()
  file(RELATIVE_PATH rel "${from_full}" "${to_full}")
  set(${out} "${rel}" PARENT_SCOPE)
endfunction()
ajar_relative_dir(AJAR_REL_SBIN_TO_PKGLIB "${CMAKE_INSTALL_SBINDIR}" "${AJAR_INSTALL_PKGLIBDIR}")
ajar_relative_dir(AJAR_REL_BIN_TO_PKGDATA "${CMAKE_INSTALL_BINDIR}" "${AJAR_INSTALL_PKGDATADIR}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/install_paths.hpp.in
               ${PROJECT_BINARY_DIR}/generated-private/ajar/install_paths.hpp @ONLY)
# Include directory of that header (private to ajard's and ajarctl's code; never installed).
set(AJAR_PRIVATE_GENERATED_DIR ${PROJECT_BINARY_DIR}/generated-private)
