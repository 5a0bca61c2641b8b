# varbo_add_plugin(NAME <name> SOURCES ... [LIBRARIES ...])
# Builds libvarbo_<name>.so: hidden visibility (only the extern "C" entry points are exported),
# no undefined symbols, placed in the plugin directory of the build (or install) tree.
# Works in-tree and for third parties after find_package(varbo).
function(varbo_add_plugin)
  cmake_parse_arguments(P "" "NAME" "SOURCES;LIBRARIES" ${ARGN})
  set(target varbo_${P_NAME})
  add_library(${target} MODULE ${P_SOURCES})
  set_target_properties(${target} PROPERTIES PREFIX "lib" OUTPUT_NAME "varbo_${P_NAME}"
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON INSTALL_RPATH "$ORIGIN/../..")
  if(TARGET varbo_core)
    target_link_libraries(${target} PRIVATE varbo_core ${P_LIBRARIES})
  else()
    target_link_libraries(${target} PRIVATE varbo::core ${P_LIBRARIES})
  endif()
  target_link_options(${target} PRIVATE -Wl,-z,defs)
  if(DEFINED VARBO_WARNINGS)
    target_compile_options(${target} PRIVATE ${VARBO_WARNINGS})
  endif()
  if(DEFINED VARBO_PLUGIN_OUTPUT_DIR)
    set_target_properties(${target} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${VARBO_PLUGIN_OUTPUT_DIR})
    install(TARGETS ${target} LIBRARY DESTINATION ${VARBO_PLUGIN_INSTALL_DIR})
  endif()
endfunction()
