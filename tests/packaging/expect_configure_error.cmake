# cmake -DSOURCE=<project> -DBUILD=<scratch build folder> -DGENERATOR=<g> -DCXX=<compiler>
#       "-DOPTIONS=<-D...;-D...>" "-DEXPECT=<regular expression>" -P expect_configure_error.cmake
#
# Bad input: a configuration that cannot work must stop at configure time with a message that
# matches EXPECT (naming the missing package and where it comes from), and leave no build
# system behind — never a half-configured build.
file(REMOVE_RECURSE "${BUILD}")
execute_process(COMMAND "${CMAKE_COMMAND}" -S "${SOURCE}" -B "${BUILD}" -G "${GENERATOR}"
                        "-DCMAKE_CXX_COMPILER=${CXX}" ${OPTIONS}
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
# One line, so that EXPECT need not know where CMake wraps the message.
string(REGEX REPLACE "[ \t\r\n]+" " " flat "${out}")
if(status EQUAL 0)
  message(FATAL_ERROR "configuring with ${OPTIONS} succeeded; expected a configure error "
                      "matching '${EXPECT}':\n${out}")
endif()
if(NOT flat MATCHES "${EXPECT}")
  message(FATAL_ERROR "configuring with ${OPTIONS} failed, but the message does not match "
                      "'${EXPECT}':\n${out}")
endif()
foreach(generated IN ITEMS build.ninja Makefile)
  if(EXISTS "${BUILD}/${generated}")
    message(FATAL_ERROR "configuring with ${OPTIONS} failed but left ${BUILD}/${generated}")
  endif()
endforeach()
string(REGEX MATCH "CMake Error[^\n]*\n[^\n]*\n[^\n]*\n[^\n]*" first "${out}")
message(STATUS "configure error as expected:\n${first}")
