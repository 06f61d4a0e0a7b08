# Runs a command and checks its exit status and output (cmake -P):
#   -DCOMMAND="prog|arg|arg"  the command, arguments separated by |
#   -DEXPECT_STATUS=2         the exit status it must return
#   -DEXPECT_OUTPUT=regex     a regular expression its stdout + stderr must match
# CTest's PASS_REGULAR_EXPRESSION ignores the exit status; the tools' documented statuses
# (tools/cli_checks.hpp) are part of their interface, so they are checked here.
string(REPLACE "|" ";" command "${COMMAND}")
execute_process(COMMAND ${command} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status STREQUAL "${EXPECT_STATUS}")
  message(FATAL_ERROR "exit status ${status}, expected ${EXPECT_STATUS}\nstdout:\n${out}\nstderr:\n${err}")
endif()
if(NOT "${out}${err}" MATCHES "${EXPECT_OUTPUT}")
  message(FATAL_ERROR "output does not match '${EXPECT_OUTPUT}'\nstdout:\n${out}\nstderr:\n${err}")
endif()
