# ajar_warnings(target): the project's warning set, as errors unless AJAR_WERROR is OFF.
function(ajar_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
    -Woverloaded-virtual -Wconversion -Wsign-conversion -Wdouble-promotion -Wformat=2
    -Wimplicit-fallthrough -Wmisleading-indentation)
  if(AJAR_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
