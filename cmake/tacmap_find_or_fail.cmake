# tacmap_find_or_fail(<package> [VERSION <v>] [ARGS <find_package args>...] DEBIAN <debian package>
#                     FOR <what needs it> [OR <the other way out>])
#
# find_package(<package> <v> <args> QUIET), and when it is not found a configure error that names
# the package, the version wanted (and the versions seen), the Debian package that provides it,
# and what to do instead — rather than find_package's generic "Could not find a package
# configuration file" or, worse, a build that is half configured. Variables the package's config
# sets stay inside this function; its imported targets are visible in the calling directory (and
# whoever needs its variables finds it again, e.g. tests/ and bench/).
function(tacmap_find_or_fail package)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "VERSION;DEBIAN;FOR;OR" "ARGS")
  find_package(${package} ${arg_VERSION} ${arg_ARGS} QUIET)
  if(${package}_FOUND)
    return()
  endif()
  set(wanted "${package}")
  if(arg_VERSION)
    string(APPEND wanted " >= ${arg_VERSION}")
  endif()
  set(seen "")
  if(${package}_CONSIDERED_VERSIONS)
    list(JOIN ${package}_CONSIDERED_VERSIONS ", " seen)
    set(seen " (found only version ${seen})")
  endif()
  set(instead "")
  if(arg_OR)
    set(instead ", or configure with ${arg_OR}")
  endif()
  message(FATAL_ERROR
    "tacmap: ${arg_FOR} needs ${wanted}, which was not found${seen}. Install the Debian package "
    "${arg_DEBIAN} (scripts/deps.sh lists it), or point CMAKE_PREFIX_PATH or ${package}_DIR at "
    "an installed ${package}${instead}.")
endfunction()
