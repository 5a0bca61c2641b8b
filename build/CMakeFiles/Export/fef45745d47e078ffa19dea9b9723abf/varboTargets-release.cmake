#----------------------------------------------------------------
# Generated CMake target import file for configuration "Release".
#----------------------------------------------------------------

# Commands may need to know the format version.
set(CMAKE_IMPORT_FILE_VERSION 1)

# Import target "varbo::core" for configuration "Release"
set_property(TARGET varbo::core APPEND PROPERTY IMPORTED_CONFIGURATIONS RELEASE)
set_target_properties(varbo::core PROPERTIES
  IMPORTED_LINK_DEPENDENT_LIBRARIES_RELEASE "TBB::tbb"
  IMPORTED_LOCATION_RELEASE "${_IMPORT_PREFIX}/lib/libvarbo_core.so"
  IMPORTED_SONAME_RELEASE "libvarbo_core.so"
  )

list(APPEND _cmake_import_check_targets varbo::core )
list(APPEND _cmake_import_check_files_for_varbo::core "${_IMPORT_PREFIX}/lib/libvarbo_core.so" )

# Commands beyond this point should not need to know the version.
set(CMAKE_IMPORT_FILE_VERSION)
