# Adds every immediate sub-folder that has a CMakeLists.txt, in sorted order, so a new plugin folder
# needs no edit elsewhere. A folder holding a `.standalone` marker (e.g. the plugin template, built
# against the installed SDK) is skipped.
function(varbo_add_children)
  file(GLOB children LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR}/*)
  list(SORT children)
  foreach(child ${children})
    if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${child} AND EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${child}/CMakeLists.txt
       AND NOT EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${child}/.standalone)
      add_subdirectory(${child})
    endif()
  endforeach()
endfunction()
