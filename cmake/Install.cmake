# SPDX-License-Identifier: MIT
# `cmake --install` puts the headers, the static libraries and a CMake package in the prefix, so that
# `find_package(spacebvh CONFIG REQUIRED)` gives spacebvh::spacebvh and spacebvh::tools.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(DIRECTORY include/spacebvh DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
# The installed targets' usage requirements: the include directory below (the one the headers go
# to), C++20 (target_compile_features in CMakeLists.txt), and their link dependencies, found again by
# the package config (TBB; Embree when the tools were built with it).
install(TARGETS spacebvh spacebvh_tools EXPORT spacebvh-targets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
set(SPACEBVH_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/spacebvh)
install(EXPORT spacebvh-targets NAMESPACE spacebvh:: DESTINATION ${SPACEBVH_CMAKE_DIR})
configure_package_config_file(cmake/spacebvh-config.cmake.in ${PROJECT_BINARY_DIR}/spacebvh-config.cmake
                              INSTALL_DESTINATION ${SPACEBVH_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/spacebvh-config-version.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/spacebvh-config.cmake ${PROJECT_BINARY_DIR}/spacebvh-config-version.cmake
        DESTINATION ${SPACEBVH_CMAKE_DIR})
