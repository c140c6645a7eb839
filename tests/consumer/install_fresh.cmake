# cmake -DBUILD_DIR=... -DPREFIX=... -P install_fresh.cmake: installs the build into an emptied PREFIX, so
# that the consumer test sees exactly what this build installs (no header left by an earlier install).
file(REMOVE_RECURSE "${PREFIX}")
execute_process(COMMAND "${CMAKE_COMMAND}" --install "${BUILD_DIR}" --prefix "${PREFIX}" RESULT_VARIABLE rc
                OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install ${BUILD_DIR} --prefix ${PREFIX} failed: ${rc}")
endif()
foreach(f lib/cmake/softhom/softhomConfig.cmake lib/cmake/softhom/softhomConfigVersion.cmake bin/softhom
          include/softhom/rve/fft_solver.hpp)
  if(NOT EXISTS "${PREFIX}/${f}")
    message(FATAL_ERROR "install tree ${PREFIX} lacks ${f}")
  endif()
endforeach()
