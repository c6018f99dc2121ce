# SPDX-License-Identifier: Apache-2.0
# The installed package: libraries, headers, CMake package files and a pkg-config file.
#
#   cmake --install <build> --prefix <prefix>
#   find_package(vfit 0.1 REQUIRED)   # CMAKE_PREFIX_PATH=<prefix>, or vfit_DIR=<build>
#   target_link_libraries(app PRIVATE vfit::engine)   # or vfit::geometry, vfit::kernels
#   #include "vfit/engine/engine.h"
#
# Headers go to <prefix>/include/vfit/<layer>/…, as the build tree's include folder shows them
# (vfit_library.cmake). The four headers that include a private dependency's header (Embree,
# OpenCL, nlohmann/json) are used by the libraries' own sources only and are not installed.
include(CMakePackageConfigHelpers)

set(VFIT_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/vfit")
get_property(vfit_libraries GLOBAL PROPERTY VFIT_LIBRARIES)

install(TARGETS ${vfit_libraries} vfit_c EXPORT vfitTargets
  ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
  LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}"
  RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}")
install(TARGETS vfit RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}")
foreach(layer kernels geometry engine)
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/${layer}/" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/vfit/${layer}"
    FILES_MATCHING PATTERN "*.h"
    PATTERN "embree_device.h" EXCLUDE
    PATTERN "opencl_impl.h" EXCLUDE
    PATTERN "gltf_document.h" EXCLUDE
    PATTERN "json_input.h" EXCLUDE)
endforeach()

install(FILES "${PROJECT_SOURCE_DIR}/bindings/c/vfit.h" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/vfit")

install(EXPORT vfitTargets NAMESPACE vfit:: DESTINATION "${VFIT_INSTALL_CMAKEDIR}")
export(EXPORT vfitTargets NAMESPACE vfit:: FILE "${PROJECT_BINARY_DIR}/vfitTargets.cmake")

# What a consumer's find_package must find again: every dependency the libraries link, for a
# static build links them all into the consumer (a shared one needs the public ones only).
set(VFIT_WITH_OPENCL_VALUE ${VFIT_WITH_OPENCL})
configure_package_config_file("${PROJECT_SOURCE_DIR}/cmake/vfitConfig.cmake.in"
  "${PROJECT_BINARY_DIR}/vfitConfig.cmake"
  INSTALL_DESTINATION "${VFIT_INSTALL_CMAKEDIR}")
# 0.x: a minor version may break the interface, so only the same minor version is compatible.
write_basic_package_version_file("${PROJECT_BINARY_DIR}/vfitConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/vfitConfig.cmake" "${PROJECT_BINARY_DIR}/vfitConfigVersion.cmake"
              "${PROJECT_SOURCE_DIR}/cmake/FindCHOLMOD.cmake"
        DESTINATION "${VFIT_INSTALL_CMAKEDIR}")
# The build tree is a package too (vfit_DIR=<build>): FindCHOLMOD.cmake beside its config.
configure_file("${PROJECT_SOURCE_DIR}/cmake/FindCHOLMOD.cmake" "${PROJECT_BINARY_DIR}/FindCHOLMOD.cmake" COPYONLY)

# pkg-config: vfit.pc, for builds that do not use CMake.
if(BUILD_SHARED_LIBS)
  set(VFIT_PC_LIBS_PRIVATE "")
else()
  set(VFIT_PC_LIBS_PRIVATE "-lembree3 -lOpenMeshTools -lOpenMeshCore -lceres -lglog -lcholmod -lpng -lz")
  if(VFIT_WITH_OPENCL)
    string(APPEND VFIT_PC_LIBS_PRIVATE " -lOpenCL")
  endif()
endif()
configure_file("${PROJECT_SOURCE_DIR}/cmake/vfit.pc.in" "${PROJECT_BINARY_DIR}/vfit.pc" @ONLY)
install(FILES "${PROJECT_BINARY_DIR}/vfit.pc" DESTINATION "${CMAKE_INSTALL_LIBDIR}/pkgconfig")
