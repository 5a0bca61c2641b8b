# varbo_add_plugin(NAME <name> SOURCES <entry point sources>...
#                  [IMPL_SOURCES <sources>...] [LIBRARIES <libs>...] [PRIVATE_LIBRARIES <libs>...])
#
# Builds libvarbo_<name>.so (target varbo_<name>): C and C++ symbols hidden (only the extern "C" entry points
# of VARBO_PLUGIN are exported), no undefined symbols (-z defs), placed in the plugin directory of the build
# (or install) tree. Links varbo::core, the SDK, and nothing else of varbo.
#
# IMPL_SOURCES: the plugin's implementation as a static, position-independent library varbo_<name>_impl with
# the same hidden visibility, which the plugin and the plugin's tests link (the folder is on its include
# path). LIBRARIES are linked PUBLIC to it (the tests see them too), PRIVATE_LIBRARIES privately. Without
# IMPL_SOURCES both are linked to the plugin itself.
#
# Works in-tree and for third parties after find_package(varbo).
function(_varbo_plugin_defaults target)
  set_target_properties(${target} PROPERTIES
    C_VISIBILITY_PRESET hidden CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON
    POSITION_INDEPENDENT_CODE ON)
  if(DEFINED VARBO_WARNINGS)
    target_compile_options(${target} PRIVATE ${VARBO_WARNINGS})
  endif()
endfunction()

function(varbo_add_plugin)
  cmake_parse_arguments(P "" "NAME" "SOURCES;IMPL_SOURCES;LIBRARIES;PRIVATE_LIBRARIES" ${ARGN})
  if(NOT P_NAME OR NOT P_SOURCES)
    message(FATAL_ERROR "varbo_add_plugin: NAME and SOURCES are required")
  endif()
  if(TARGET varbo_core)
    set(core varbo_core)
  else()
    set(core varbo::core)
  endif()
  set(target varbo_${P_NAME})
  add_library(${target} MODULE ${P_SOURCES})
  _varbo_plugin_defaults(${target})
  set_target_properties(${target} PROPERTIES PREFIX "lib" OUTPUT_NAME "varbo_${P_NAME}"
    INSTALL_RPATH "$ORIGIN/../..")
  if(P_IMPL_SOURCES)
    set(impl varbo_${P_NAME}_impl)
    add_library(${impl} STATIC ${P_IMPL_SOURCES})
    _varbo_plugin_defaults(${impl})
    target_include_directories(${impl} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR})
    target_link_libraries(${impl} PUBLIC ${core} ${P_LIBRARIES} PRIVATE ${P_PRIVATE_LIBRARIES})
    target_link_libraries(${target} PRIVATE ${impl})
  else()
    target_link_libraries(${target} PRIVATE ${core} ${P_LIBRARIES} ${P_PRIVATE_LIBRARIES})
  endif()
  target_link_options(${target} PRIVATE -Wl,-z,defs)
  # The RUNPATH the plugin is built with is the one it is installed with. Otherwise CMake pads the build RUNPATH
  # with ':' for install to rewrite in place, and an empty entry is the current folder: a third-party plugin with
  # an install() rule loaded its libraries from wherever varbo was started (red team, session 29;
  # tests/loader/check_runpath.sh). In varbo's tree lib/varbo/plugins/../.. is lib/ in build and install alike;
  # out of tree the SDK's library folder is added, where the build tree finds libvarbo_core.
  if(NOT TARGET varbo_core)
    get_target_property(_core_location varbo::core LOCATION)
    get_filename_component(_core_dir "${_core_location}" DIRECTORY)
    set_property(TARGET ${target} APPEND PROPERTY INSTALL_RPATH "${_core_dir}")
  endif()
  set_target_properties(${target} PROPERTIES BUILD_WITH_INSTALL_RPATH TRUE)
  if(DEFINED VARBO_PLUGIN_OUTPUT_DIR)
    set_target_properties(${target} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${VARBO_PLUGIN_OUTPUT_DIR})
    # varbo's own plugin: its file name goes into the core's list of built-in libraries (top-level
    # CMakeLists.txt), so a third-party library installed into the same folder is not taken for one.
    set_property(GLOBAL APPEND PROPERTY VARBO_BUILTIN_PLUGIN_FILES "libvarbo_${P_NAME}.so")
    install(TARGETS ${target} LIBRARY DESTINATION ${VARBO_PLUGIN_INSTALL_DIR})
  endif()
endfunction()
