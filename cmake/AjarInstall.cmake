# Install rules (GNUInstallDirs + cmake/AjarInstallDirs.cmake) and the CMake/pkg-config package.
# Everything is picked up by target or by directory, so new sources, headers, docs, scenarios and
# vectors are installed without touching this file. Two components:
#   Runtime      ajard, ajarctl, ajar-armsim, the card simulator, the unit, /etc/ajar/ajard.yaml,
#                examples, golden vectors, docs, man pages, bash completion   (Debian: ajar)
#   Development  ajar::core, ajar::protocol, ajar::client: static libraries, headers,
#                ajarConfig.cmake, ajarConfigVersion.cmake, ajar.pc            (Debian: ajar-dev)
include(CMakePackageConfigHelpers)

# ---- Development: the libraries a host GUI links ------------------------------------------------
set(AJAR_EXPORTED_TARGETS ajar_core ajar_protocol ajar_client)
install(TARGETS ${AJAR_EXPORTED_TARGETS} EXPORT ajarTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT Development
  FILE_SET HEADERS DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT Development)
install(EXPORT ajarTargets NAMESPACE ajar:: DESTINATION ${AJAR_INSTALL_CMAKEDIR}
  FILE ajarTargets.cmake COMPONENT Development)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/ajarConfig.cmake.in
  ${PROJECT_BINARY_DIR}/ajarConfig.cmake INSTALL_DESTINATION ${AJAR_INSTALL_CMAKEDIR})
# 0.x: a minor release may change the API (semantic versioning before 1.0), so find_package(ajar
# 0.1) accepts 0.1.z with z >= the asked patch level, and never 0.2. From 1.0 on this becomes
# SameMajorVersion.
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(AJAR_VERSION_COMPATIBILITY SameMinorVersion)
else()
  set(AJAR_VERSION_COMPATIBILITY SameMajorVersion)
endif()
write_basic_package_version_file(${PROJECT_BINARY_DIR}/ajarConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY ${AJAR_VERSION_COMPATIBILITY})
install(FILES ${PROJECT_BINARY_DIR}/ajarConfig.cmake ${PROJECT_BINARY_DIR}/ajarConfigVersion.cmake
  DESTINATION ${AJAR_INSTALL_CMAKEDIR} COMPONENT Development)

# pkg-config: prefix relative to the .pc file (${pcfiledir}), so a staged install works as well.
ajar_relative_dir(AJAR_REL_PC_TO_PREFIX "${CMAKE_INSTALL_LIBDIR}/pkgconfig" "")
string(REGEX REPLACE "/$" "" AJAR_REL_PC_TO_PREFIX "${AJAR_REL_PC_TO_PREFIX}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/ajar.pc.in ${PROJECT_BINARY_DIR}/ajar.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/ajar.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig
  COMPONENT Development)

if(AJAR_CLIENT_ONLY)
  if(TARGET ajarctl)
    install(TARGETS ajarctl RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT Runtime)
  endif()
  return()
endif()

# ---- Runtime: the daemon and its tools ----------------------------------------------------------
install(TARGETS ajard RUNTIME DESTINATION ${CMAKE_INSTALL_SBINDIR} COMPONENT Runtime)
install(TARGETS ajarctl ajar-armsim RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT Runtime)
# The card simulator is dlopen()ed by ajard (drivers.kind sim): a private library, no SONAME.
install(TARGETS ajar_gts_sim LIBRARY DESTINATION ${AJAR_INSTALL_PKGLIBDIR} COMPONENT Runtime)

# The robot's config is the installed /etc/ajar/ajard.yaml (a conffile in the Debian package); the
# simulated one and the scenarios are examples.
install(FILES ${PROJECT_SOURCE_DIR}/config/ajard.robot.yaml DESTINATION ${AJAR_INSTALL_CONFDIR}
  RENAME ajard.yaml COMPONENT Runtime)
install(FILES ${PROJECT_SOURCE_DIR}/config/ajard.yaml
  DESTINATION ${AJAR_INSTALL_PKGDATADIR}/examples RENAME ajard.sim.yaml COMPONENT Runtime)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/scenarios
  DESTINATION ${AJAR_INSTALL_PKGDATADIR}/examples COMPONENT Runtime FILES_MATCHING PATTERN "*.yaml")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/tests/conformance/vectors
  DESTINATION ${AJAR_INSTALL_PKGDATADIR} COMPONENT Runtime FILES_MATCHING PATTERN "*.vec")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR}
  COMPONENT Runtime FILES_MATCHING PATTERN "*.md")
install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT Runtime)

# The unit names /usr/sbin/ajard (the Debian layout); another prefix gets a copy naming its own.
file(READ ${PROJECT_SOURCE_DIR}/systemd/ajard.service AJAR_UNIT)
string(REPLACE "/usr/sbin/ajard" "${CMAKE_INSTALL_FULL_SBINDIR}/ajard" AJAR_UNIT "${AJAR_UNIT}")
string(REPLACE "/etc/ajar/" "${CMAKE_INSTALL_FULL_SYSCONFDIR}/ajar/" AJAR_UNIT "${AJAR_UNIT}")
file(GENERATE OUTPUT ${PROJECT_BINARY_DIR}/systemd/ajard.service CONTENT "${AJAR_UNIT}")
install(FILES ${PROJECT_BINARY_DIR}/systemd/ajard.service DESTINATION ${AJAR_INSTALL_UNITDIR}
  COMPONENT Runtime)
# Device access for the dynamic user: the ajar-card group (sysusers.d) and the card node's udev
# rule; and the example drop-in for site device nodes.
install(FILES ${PROJECT_SOURCE_DIR}/systemd/ajar.sysusers.conf DESTINATION lib/sysusers.d
  RENAME ajar.conf COMPONENT Runtime)
install(FILES ${PROJECT_SOURCE_DIR}/systemd/60-ajar-card.rules DESTINATION lib/udev/rules.d
  COMPONENT Runtime)
install(FILES ${PROJECT_SOURCE_DIR}/systemd/ajard-site-devices.conf
  DESTINATION ${AJAR_INSTALL_PKGDATADIR}/examples/systemd COMPONENT Runtime)

# bash completion (asks ajarctl itself for the words, so it follows the commands) and man pages.
install(FILES ${PROJECT_SOURCE_DIR}/client/completion/ajarctl
  DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions COMPONENT Runtime)
include(${CMAKE_CURRENT_LIST_DIR}/AjarManPages.cmake)
