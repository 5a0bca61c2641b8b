# `varbo dashboard` (docs/dashboard.md): Debian's cpp-httplib (libcpp-httplib-dev) serves the JSON API and one page.
# The page (dashboard_page.html) is compiled into the binary as a string, so an installed varbo needs no data files.
find_package(PkgConfig REQUIRED)
pkg_check_modules(CPP_HTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib)
set(VARBO_DASHBOARD_PAGE ${CMAKE_CURRENT_SOURCE_DIR}/cli/dashboard/dashboard_page.html)
set(VARBO_DASHBOARD_PAGE_HEADER ${PROJECT_BINARY_DIR}/generated/dashboard_page.inc)
add_custom_command(OUTPUT ${VARBO_DASHBOARD_PAGE_HEADER}
  COMMAND ${CMAKE_COMMAND} -DINPUT=${VARBO_DASHBOARD_PAGE} -DOUTPUT=${VARBO_DASHBOARD_PAGE_HEADER}
          -P ${CMAKE_CURRENT_SOURCE_DIR}/cli/dashboard/embed_text.cmake
  DEPENDS ${VARBO_DASHBOARD_PAGE} ${CMAKE_CURRENT_SOURCE_DIR}/cli/dashboard/embed_text.cmake
  COMMENT "Embedding the dashboard page")
target_sources(varbo PRIVATE ${VARBO_DASHBOARD_PAGE_HEADER})
target_include_directories(varbo PRIVATE ${PROJECT_BINARY_DIR}/generated)
target_link_libraries(varbo PRIVATE PkgConfig::CPP_HTTPLIB)
