# FindCHOLMOD
# -----------
# Finds SuiteSparse's CHOLMOD, whose Debian package (libsuitesparse-dev) ships no CMake config.
#
# Imported target: SuiteSparse::CHOLMOD (cholmod and the SuiteSparse libraries it needs).
# Result variables: CHOLMOD_FOUND, CHOLMOD_INCLUDE_DIR, CHOLMOD_LIBRARY, CHOLMOD_VERSION.

find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY cholmod)
find_library(CHOLMOD_SUITESPARSECONFIG_LIBRARY suitesparseconfig)
find_library(CHOLMOD_AMD_LIBRARY amd)
find_library(CHOLMOD_CAMD_LIBRARY camd)
find_library(CHOLMOD_COLAMD_LIBRARY colamd)
find_library(CHOLMOD_CCOLAMD_LIBRARY ccolamd)

# The version is in cholmod_core.h up to SuiteSparse 5 (Debian 12), in cholmod.h from 7 on.
set(_cholmod_version_lines "")
foreach(_header cholmod.h cholmod_core.h)
  if(CHOLMOD_INCLUDE_DIR AND EXISTS "${CHOLMOD_INCLUDE_DIR}/${_header}")
    file(STRINGS "${CHOLMOD_INCLUDE_DIR}/${_header}" _lines
         REGEX "#define CHOLMOD_(MAIN|SUB|SUBSUB)_VERSION[ \t]+[0-9]+")
    list(APPEND _cholmod_version_lines ${_lines})
  endif()
endforeach()
if(_cholmod_version_lines)
  foreach(_part MAIN SUB SUBSUB)
    string(REGEX REPLACE ".*#define CHOLMOD_${_part}_VERSION[ \t]+([0-9]+).*" "\\1"
           _cholmod_${_part} "${_cholmod_version_lines}")
  endforeach()
  set(CHOLMOD_VERSION "${_cholmod_MAIN}.${_cholmod_SUB}.${_cholmod_SUBSUB}")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD
  REQUIRED_VARS CHOLMOD_LIBRARY CHOLMOD_INCLUDE_DIR CHOLMOD_SUITESPARSECONFIG_LIBRARY
  VERSION_VAR CHOLMOD_VERSION)

if(CHOLMOD_FOUND AND NOT TARGET SuiteSparse::CHOLMOD)
  add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
  set(_cholmod_deps "${CHOLMOD_SUITESPARSECONFIG_LIBRARY}")
  foreach(_lib CHOLMOD_AMD_LIBRARY CHOLMOD_CAMD_LIBRARY CHOLMOD_COLAMD_LIBRARY CHOLMOD_CCOLAMD_LIBRARY)
    if(${_lib})
      list(APPEND _cholmod_deps "${${_lib}}")
    endif()
  endforeach()
  set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${_cholmod_deps}")
endif()
mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY CHOLMOD_SUITESPARSECONFIG_LIBRARY
                 CHOLMOD_AMD_LIBRARY CHOLMOD_CAMD_LIBRARY CHOLMOD_COLAMD_LIBRARY CHOLMOD_CCOLAMD_LIBRARY)
