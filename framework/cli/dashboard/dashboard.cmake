# `varbo dashboard` (docs/dashboard.md): Debian's cpp-httplib (libcpp-httplib-dev) serves the JSON API and one page.
# The page (dashboard_page.html) is compiled in as a string, so an installed varbo needs no data files. The server
# is a module of its own, libvarbo_dashboard_http.so, loaded by `varbo dashboard` only: cpp-httplib links OpenSSL,
# zlib and brotli, which every other varbo process would otherwise load (dashboard_http.hpp).
find_package(PkgConfig REQUIRED)
pkg_check_modules(CPP_HTTPLIB QUIET IMPORTED_TARGET cpp-httplib)
if(NOT CPP_HTTPLIB_FOUND)
  message(FATAL_ERROR "varbo: `varbo dashboard` needs cpp-httplib (Debian: apt-get install libcpp-httplib-dev); "
                      "scripts/setup.sh installs every package the build needs")
endif()
set(VARBO_DASHBOARD_PAGE ${CMAKE_CURRENT_SOURCE_DIR}/cli/dashboard/dashboard_page.html)
set(VARBO_DASHBOARD_PAGE_HEADER ${PROJECT_BINARY_DIR}/generated/dashboard_page.inc)
add_custom_command(OUTPUT ${VARBO_DASHBOARD_PAGE_HEADER}
  COMMAND ${CMAKE_COMMAND} -DINPUT=${VARBO_DASHBOARD_PAGE} -DOUTPUT=${VARBO_DASHBOARD_PAGE_HEADER}
          -P ${CMAKE_CURRENT_SOURCE_DIR}/cli/dashboard/embed_text.cmake
  DEPENDS ${VARBO_DASHBOARD_PAGE} ${CMAKE_CURRENT_SOURCE_DIR}/cli/dashboard/embed_text.cmake
  COMMENT "Embedding the dashboard page")
add_library(varbo_dashboard_http MODULE ${CMAKE_CURRENT_SOURCE_DIR}/cli/dashboard/dashboard_http.cpp
  ${VARBO_DASHBOARD_PAGE_HEADER})
set_target_properties(varbo_dashboard_http PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/lib
  INSTALL_RPATH "$ORIGIN" BUILD_WITH_INSTALL_RPATH TRUE)
target_include_directories(varbo_dashboard_http PRIVATE ${PROJECT_BINARY_DIR}/generated)
target_link_libraries(varbo_dashboard_http PRIVATE varbo_core varbo_study varbo_tools PkgConfig::CPP_HTTPLIB
  nlohmann_json::nlohmann_json)  # the study and tools libraries for the API types' headers
target_compile_options(varbo_dashboard_http PRIVATE ${VARBO_WARNINGS})
target_link_options(varbo_dashboard_http PRIVATE -Wl,-z,defs)
install(TARGETS varbo_dashboard_http LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
target_link_libraries(varbo PRIVATE ${CMAKE_DL_LIBS})
add_dependencies(varbo varbo_dashboard_http)
