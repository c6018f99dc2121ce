# SPDX-License-Identifier: Apache-2.0
# vfit_library(<layer> SOURCES...) — one of the installed libraries, vfit::<layer>
# (kernels, geometry, engine): static or shared as BUILD_SHARED_LIBS says, installed as
# libvfit_<layer>, its headers included as "vfit/<layer>/…".
#
# In the build tree that prefix is <build>/include/vfit/<layer>, a link to the source folder,
# so our own sources, the tests and a consumer of the build tree all include the same paths
# that an install provides (<prefix>/include/vfit/<layer>/…, copied by vfit_package.cmake).
set(VFIT_BUILD_INCLUDE_DIR "${PROJECT_BINARY_DIR}/include")

function(vfit_library layer)
  set(name vfit_${layer})
  add_library(${name} ${ARGN})
  add_library(vfit::${layer} ALIAS ${name})
  set_target_properties(${name} PROPERTIES
    EXPORT_NAME ${layer}
    VERSION ${PROJECT_VERSION}
    SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
  file(MAKE_DIRECTORY "${VFIT_BUILD_INCLUDE_DIR}/vfit")
  file(CREATE_LINK "${PROJECT_SOURCE_DIR}/${layer}" "${VFIT_BUILD_INCLUDE_DIR}/vfit/${layer}" SYMBOLIC)
  target_include_directories(${name} PUBLIC
    "$<BUILD_INTERFACE:${VFIT_BUILD_INCLUDE_DIR}>"
    "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
  target_compile_features(${name} PUBLIC cxx_std_20)
  # Warnings and sanitizers are this build's, not a consumer's: their flags are copied, since
  # linking the interface targets, even PRIVATE, would put them in a static library's export.
  target_compile_options(${name} PRIVATE "$<TARGET_PROPERTY:vfit_warnings,INTERFACE_COMPILE_OPTIONS>"
                                         "$<TARGET_PROPERTY:vfit_sanitize,INTERFACE_COMPILE_OPTIONS>")
  target_link_options(${name} PRIVATE "$<TARGET_PROPERTY:vfit_sanitize,INTERFACE_LINK_OPTIONS>")
  target_compile_options(${name} PRIVATE "$<$<CXX_COMPILER_ID:GNU>:-fno-semantic-interposition>")
  set_property(GLOBAL APPEND PROPERTY VFIT_LIBRARIES ${name})
endfunction()
