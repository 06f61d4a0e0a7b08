# tacmap's Python module (TACMAP_BUILD_PYTHON): find an interpreter that has numpy, its headers,
# and pybind11. Included by the top-level CMakeLists.txt only when the option is on, so a build
# without Python needs none of it.
#
# Which interpreter. Unless the user sets Python3_EXECUTABLE, the first of `python3` on PATH and
# /usr/bin/python3 that can import numpy: a pyenv or virtualenv python3 without numpy shadows the
# system one on many machines (pyenv's shim on tacmap's CI machine), and FindPython would pick
# it and then fail on NumPy. The module only loads in the interpreter it was built for, so the
# same Python3_EXECUTABLE runs the tests (tests/python) and the example.
#
# Order. FindPython3 first, then pybind11: pybind11's config then builds on the Python3 already
# found (its "new" FindPython mode); the other order makes it fall back to its legacy
# FindPythonLibsNew, which ignores Python3_EXECUTABLE.
set(tacmap_python_packages "pybind11-dev python3-dev python3-numpy")

if(NOT Python3_EXECUTABLE)
  find_program(tacmap_python_on_path NAMES python3 NO_CACHE)
  set(tacmap_python_tried "")
  foreach(candidate IN ITEMS "${tacmap_python_on_path}" /usr/bin/python3)
    if(NOT candidate OR NOT EXISTS "${candidate}" OR candidate IN_LIST tacmap_python_tried)
      continue()
    endif()
    list(APPEND tacmap_python_tried "${candidate}")
    execute_process(COMMAND "${candidate}" -c "import numpy"
                    RESULT_VARIABLE tacmap_numpy_status OUTPUT_QUIET ERROR_QUIET)
    if(tacmap_numpy_status EQUAL 0)
      set(Python3_EXECUTABLE "${candidate}" CACHE FILEPATH
          "The Python interpreter tacmap's module is built for and tested with (needs numpy)")
      break()
    endif()
  endforeach()
  if(NOT Python3_EXECUTABLE)
    list(JOIN tacmap_python_tried ", " tacmap_python_tried_text)
    message(FATAL_ERROR
      "tacmap: TACMAP_BUILD_PYTHON is ON but no python3 that can import numpy was found "
      "(tried: ${tacmap_python_tried_text}). Install the Debian packages "
      "${tacmap_python_packages} (scripts/deps.sh lists them), or pass "
      "-DPython3_EXECUTABLE=/path/to/python3 for an interpreter with numpy and its headers, "
      "or set TACMAP_BUILD_PYTHON=OFF.")
  endif()
endif()

find_package(Python3 COMPONENTS Interpreter Development.Module NumPy)
if(NOT Python3_FOUND)
  # Each missing part with the Debian package that provides it.
  set(tacmap_python_missing "")
  set(tacmap_python_missing_packages "")
  foreach(component_package IN ITEMS "Interpreter=python3" "Development.Module=python3-dev"
                                     "NumPy=python3-numpy")
    string(REPLACE "=" ";" component_package "${component_package}")
    list(GET component_package 0 component)
    list(GET component_package 1 package)
    if(NOT Python3_${component}_FOUND)
      list(APPEND tacmap_python_missing "${component} (Debian: ${package})")
      list(APPEND tacmap_python_missing_packages "${package}")
    endif()
  endforeach()
  list(JOIN tacmap_python_missing ", " tacmap_python_missing)
  list(JOIN tacmap_python_missing_packages " " tacmap_python_missing_packages)
  message(FATAL_ERROR
    "tacmap: TACMAP_BUILD_PYTHON is ON but Python 3 for ${Python3_EXECUTABLE} lacks: "
    "${tacmap_python_missing} (Development.Module: the C headers; NumPy: numpy and its "
    "headers). Install the Debian packages ${tacmap_python_missing_packages}, or pass "
    "-DPython3_EXECUTABLE=... for another interpreter, or set TACMAP_BUILD_PYTHON=OFF.")
endif()

find_package(pybind11 2.6 CONFIG)
if(NOT pybind11_FOUND)
  message(FATAL_ERROR
    "tacmap: TACMAP_BUILD_PYTHON is ON but pybind11 (>= 2.6, CMake config) was not found. "
    "Install the Debian package pybind11-dev (scripts/deps.sh lists it), or point pybind11_DIR at "
    "pybind11's CMake folder, or set TACMAP_BUILD_PYTHON=OFF.")
endif()
message(STATUS "tacmap: Python module for ${Python3_EXECUTABLE} (Python ${Python3_VERSION}, "
               "numpy ${Python3_NumPy_VERSION}, pybind11 ${pybind11_VERSION})")
