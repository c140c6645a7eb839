# `cmake --install` of softhom as a library: the libraries (static, position-independent), their public
# headers, the `softhom` program and the CMake package softhomConfig.cmake with the exported targets
# softhom::core, ::mpi, ::materials, ::fft, ::fe, ::io, ::rve, ::macro, ::studies, ::jobs.
#
# The libraries stay static: the program needs no run-time search path, benchmarks are unchanged, and the
# Python module links them into one self-contained extension (one copy of the stop flag and of every
# registry). A consumer therefore links their dependencies too; softhomConfig.cmake finds each of them
# (find_dependency / pkg-config) as this build did.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(SOFTHOM_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/softhom" CACHE STRING
    "Where softhomConfig.cmake is installed, relative to the prefix")

set(softhom_exported_libraries softhom_core softhom_mpi softhom_materials softhom_io softhom_fft softhom_fe
    softhom_rve softhom_macro softhom_studies softhom_jobs softhom_suitesparse)
foreach(lib IN LISTS softhom_exported_libraries)
  string(REGEX REPLACE "^softhom_" "" short ${lib})
  set_target_properties(${lib} PROPERTIES EXPORT_NAME ${short})
endforeach()

# Position-independent libraries, so that the installed static libraries and the Python extension module
# can be linked into shared objects. -fno-semantic-interposition keeps the optimiser free to inline the
# libraries' own functions, as the Debian default -fPIE does: the code is that of the executable's.
foreach(lib IN LISTS softhom_exported_libraries)
  get_target_property(type ${lib} TYPE)
  if(NOT type STREQUAL "INTERFACE_LIBRARY")
    set_target_properties(${lib} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    target_compile_options(${lib} PRIVATE -fno-semantic-interposition)
  endif()
endforeach()

install(TARGETS ${softhom_exported_libraries} EXPORT softhomTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
foreach(dir core materials io fft fe rve macro studies jobs)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endforeach()
install(EXPORT softhomTargets NAMESPACE softhom:: DESTINATION ${SOFTHOM_INSTALL_CMAKEDIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/softhomConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/softhomConfig.cmake
                              INSTALL_DESTINATION ${SOFTHOM_INSTALL_CMAKEDIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/softhomConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/softhomConfig.cmake ${PROJECT_BINARY_DIR}/softhomConfigVersion.cmake
        DESTINATION ${SOFTHOM_INSTALL_CMAKEDIR})

# `softhom calibrate` looks for its plot script next to the installed program (share/softhom).
install(FILES ${PROJECT_SOURCE_DIR}/studies/plot_calibration.py DESTINATION ${CMAKE_INSTALL_DATADIR}/softhom)
