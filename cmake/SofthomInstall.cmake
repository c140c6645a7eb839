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

# The examples (`softhom examples list|copy`, jobs/examples.hpp): share/softhom/examples in the layout of
# studies/ (scenes name ../meshes, calibrations their data/ beside them), the Python examples and the
# tutorial as python/, the plot scripts at the top. The same tree is staged in the build directory
# (configure_file re-runs on a change), where a build that is not installed finds it.
set(softhom_examples_dir ${CMAKE_INSTALL_DATADIR}/softhom/examples)
file(GLOB softhom_example_sources CONFIGURE_DEPENDS
     RELATIVE ${PROJECT_SOURCE_DIR}/studies
     ${PROJECT_SOURCE_DIR}/studies/scenes/*.toml ${PROJECT_SOURCE_DIR}/studies/devices/*.toml
     ${PROJECT_SOURCE_DIR}/studies/campaigns/*.toml ${PROJECT_SOURCE_DIR}/studies/calibrations/*.toml
     ${PROJECT_SOURCE_DIR}/studies/calibrations/data/*.csv ${PROJECT_SOURCE_DIR}/studies/calibrations/data/*.py
     ${PROJECT_SOURCE_DIR}/studies/meshes/*.geo ${PROJECT_SOURCE_DIR}/studies/meshes/*.msh
     ${PROJECT_SOURCE_DIR}/studies/plot_*.py)
set(softhom_example_pairs)
foreach(f IN LISTS softhom_example_sources)
  list(APPEND softhom_example_pairs "${PROJECT_SOURCE_DIR}/studies/${f}|${f}")
endforeach()
foreach(f ${PROJECT_SOURCE_DIR}/studies/examples/fiber_angle_sweep.py ${PROJECT_SOURCE_DIR}/docs/tutorial_angle_sweep.py)
  get_filename_component(name ${f} NAME)
  list(APPEND softhom_example_pairs "${f}|python/${name}")
endforeach()
foreach(pair IN LISTS softhom_example_pairs)
  string(REPLACE "|" ";" pair "${pair}")
  list(GET pair 0 source)
  list(GET pair 1 relative)
  get_filename_component(folder ${relative} DIRECTORY)
  configure_file(${source} ${PROJECT_BINARY_DIR}/share/softhom/examples/${relative} COPYONLY)
  install(FILES ${source} DESTINATION ${softhom_examples_dir}/${folder})
endforeach()
