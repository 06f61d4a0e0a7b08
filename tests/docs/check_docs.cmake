# cmake -DDOXYGEN=... -DSOURCE_DIR=... -DOUTPUT_DIR=... -DVERSION=... -P check_docs.cmake
# Runs Doxygen on docs/Doxyfile into OUTPUT_DIR and fails unless it exits 0 with an empty
# warning log; on failure the log (file:line: message) is the test's output.
if(NOT DOXYGEN)
  message(FATAL_ERROR "doxygen was not found when tacmap was configured. Install it (Debian: "
                      "apt-get install doxygen; scripts/test does it) and configure again, or "
                      "configure with -DTACMAP_CHECK_DOCS=OFF to skip this test.")
endif()

file(REMOVE_RECURSE "${OUTPUT_DIR}")
file(MAKE_DIRECTORY "${OUTPUT_DIR}")
set(log "${OUTPUT_DIR}/warnings.log")
file(WRITE "${OUTPUT_DIR}/Doxyfile"
     "@INCLUDE = \"${SOURCE_DIR}/docs/Doxyfile\"\n"
     "PROJECT_NUMBER = ${VERSION}\n"
     "OUTPUT_DIRECTORY = \"${OUTPUT_DIR}\"\n"
     "WARN_LOGFILE = \"${log}\"\n")

# docs/Doxyfile's paths are relative to the repository's root.
execute_process(COMMAND "${DOXYGEN}" "${OUTPUT_DIR}/Doxyfile" WORKING_DIRECTORY "${SOURCE_DIR}"
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(warnings "")
if(EXISTS "${log}")
  file(READ "${log}" warnings)
endif()
if(NOT status EQUAL 0 OR NOT warnings STREQUAL "")
  message(FATAL_ERROR "Doxygen (exit ${status}) on the public headers; fix the comments named "
                      "below (scripts/docs reproduces this):\n${warnings}${out}${err}")
endif()
if(NOT EXISTS "${OUTPUT_DIR}/html/index.html")
  message(FATAL_ERROR "Doxygen exited 0 but wrote no ${OUTPUT_DIR}/html/index.html:\n${out}${err}")
endif()
message(STATUS "API reference without warnings: ${OUTPUT_DIR}/html/index.html")
