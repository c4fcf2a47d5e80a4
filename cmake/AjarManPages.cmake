# Man pages generated at build time from one source each, so they cannot drift:
#   ajard(8)       help2man over `ajard --help` / `--version` (+ cmake/man/ajard.h2m)
#   ajarctl(1)     help2man over `ajarctl --help` / `--version` (+ cmake/man/ajarctl.h2m)
#   ajar-armsim(1) help2man over `ajar-armsim --help` / `--version`
#   ajard.yaml(5)  cmake/md2man.pl over docs/configuration.md
# Needs help2man and perl (scripts/install-deps); without help2man the pages are skipped.
find_program(AJAR_HELP2MAN help2man)
find_package(Perl)
if(NOT AJAR_HELP2MAN OR NOT PERL_FOUND)
  message(STATUS "help2man or perl not found: man pages are not built")
  return()
endif()
set(man_dir ${PROJECT_BINARY_DIR}/man)
file(MAKE_DIRECTORY ${man_dir})
# help2man runs the program: a cross build (cmake/toolchain-arm64.cmake) runs it through its
# emulator, by a wrapper of the program's own name (help2man names the page after it).
foreach(program ajard ajarctl ajar-armsim)
  if(CMAKE_CROSSCOMPILING AND CMAKE_CROSSCOMPILING_EMULATOR)
    list(JOIN CMAKE_CROSSCOMPILING_EMULATOR " " _ajar_emulator)
    file(GENERATE OUTPUT ${man_dir}/run/${program}
      CONTENT "#!/bin/sh\nexec ${_ajar_emulator} $<TARGET_FILE:${program}> \"$@\"\n"
      FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ
                       WORLD_EXECUTE)
    set(help2man_run_${program} ${man_dir}/run/${program})
  else()
    set(help2man_run_${program} $<TARGET_FILE:${program}>)
  endif()
endforeach()
add_custom_command(OUTPUT ${man_dir}/ajard.8
  COMMAND ${AJAR_HELP2MAN} --no-info --section 8 --name "the Ajar door-opening controller daemon"
          --include ${CMAKE_CURRENT_LIST_DIR}/man/ajard.h2m --output ${man_dir}/ajard.8
          ${help2man_run_ajard}
  DEPENDS ajard ${CMAKE_CURRENT_LIST_DIR}/man/ajard.h2m VERBATIM)
add_custom_command(OUTPUT ${man_dir}/ajarctl.1
  COMMAND ${AJAR_HELP2MAN} --no-info --section 1 --name "command-line client of the Ajar daemon"
          --include ${CMAKE_CURRENT_LIST_DIR}/man/ajarctl.h2m --output ${man_dir}/ajarctl.1
          ${help2man_run_ajarctl}
  DEPENDS ajarctl ${CMAKE_CURRENT_LIST_DIR}/man/ajarctl.h2m VERBATIM)
add_custom_command(OUTPUT ${man_dir}/ajar-armsim.1
  COMMAND ${AJAR_HELP2MAN} --no-info --section 1 --name "arm-controller simulator on a pseudo-terminal"
          --output ${man_dir}/ajar-armsim.1 ${help2man_run_ajar-armsim}
  DEPENDS ajar-armsim VERBATIM)
add_custom_command(OUTPUT ${man_dir}/ajard.yaml.5
  COMMAND ${PERL_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/md2man.pl ajard.yaml 5
          "configuration file of the Ajar controller daemon" ${PROJECT_VERSION}
          ${PROJECT_SOURCE_DIR}/docs/configuration.md ${man_dir}/ajard.yaml.5
  DEPENDS ${CMAKE_CURRENT_LIST_DIR}/md2man.pl ${PROJECT_SOURCE_DIR}/docs/configuration.md VERBATIM)
add_custom_target(ajar_man_pages ALL
  DEPENDS ${man_dir}/ajard.8 ${man_dir}/ajarctl.1 ${man_dir}/ajar-armsim.1 ${man_dir}/ajard.yaml.5)
install(FILES ${man_dir}/ajarctl.1 ${man_dir}/ajar-armsim.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT Runtime)
install(FILES ${man_dir}/ajard.yaml.5 DESTINATION ${CMAKE_INSTALL_MANDIR}/man5 COMPONENT Runtime)
install(FILES ${man_dir}/ajard.8 DESTINATION ${CMAKE_INSTALL_MANDIR}/man8 COMPONENT Runtime)
