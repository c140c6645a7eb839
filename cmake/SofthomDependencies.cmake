# Finds every dependency from Debian 12 packages. A missing one stops configuration with the name of the
# Debian package that provides it (scripts/install-deps.sh installs them all).
find_package(PkgConfig QUIET)

macro(softhom_require found what package)
  if(NOT ${found})
    message(FATAL_ERROR "softhom: ${what} not found. Install the Debian package '${package}' "
                        "(or run scripts/install-deps.sh as root).")
  endif()
endmacro()

if(NOT PKG_CONFIG_FOUND)
  message(FATAL_ERROR "softhom: pkg-config not found. Install the Debian package 'pkg-config'.")
endif()

find_package(Eigen3 3.4 QUIET NO_MODULE)
softhom_require(Eigen3_FOUND "Eigen 3.4" libeigen3-dev)

find_package(OpenMP QUIET)
softhom_require(OpenMP_CXX_FOUND "OpenMP for C++" "libgomp1 (g++)")

pkg_check_modules(FFTW3 QUIET IMPORTED_TARGET fftw3)
softhom_require(FFTW3_FOUND "FFTW3" libfftw3-dev)
find_library(FFTW3_OMP_LIB fftw3_omp)
softhom_require(FFTW3_OMP_LIB "FFTW3 OpenMP library (libfftw3_omp)" libfftw3-dev)

# SuiteSparse 5.x on Debian 12 ships no CMake config: find the headers and libraries directly.
find_path(SUITESPARSE_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIB cholmod)
find_library(UMFPACK_LIB umfpack)
find_library(AMD_LIB amd)
find_library(COLAMD_LIB colamd)
find_library(SUITESPARSECONFIG_LIB suitesparseconfig)
softhom_require(SUITESPARSE_INCLUDE_DIR "SuiteSparse headers (cholmod.h)" libsuitesparse-dev)
softhom_require(CHOLMOD_LIB "CHOLMOD" libsuitesparse-dev)
softhom_require(UMFPACK_LIB "UMFPACK" libsuitesparse-dev)
add_library(softhom_suitesparse INTERFACE)
target_include_directories(softhom_suitesparse INTERFACE ${SUITESPARSE_INCLUDE_DIR})
target_link_libraries(softhom_suitesparse INTERFACE ${CHOLMOD_LIB} ${UMFPACK_LIB} ${AMD_LIB} ${COLAMD_LIB}
                      ${SUITESPARSECONFIG_LIB})

# Open MPI: campaigns over ranks, distributed FFT cells, the PETSc macro solver. One binary: a process not
# started by an MPI launcher never initialises MPI (softhom/core/mpi.hpp) and runs as before.
set(MPI_CXX_SKIP_MPICXX ON)  # the C API only; the MPI-2 C++ bindings are deprecated
find_package(MPI QUIET COMPONENTS CXX)
softhom_require(MPI_CXX_FOUND "MPI (Open MPI)" "libopenmpi-dev openmpi-bin")
find_library(FFTW3_MPI_LIB fftw3_mpi)
find_path(FFTW3_MPI_INCLUDE_DIR fftw3-mpi.h)
softhom_require(FFTW3_MPI_LIB "FFTW3 MPI library (libfftw3_mpi)" libfftw3-mpi-dev)
softhom_require(FFTW3_MPI_INCLUDE_DIR "FFTW3 MPI header (fftw3-mpi.h)" libfftw3-mpi-dev)
pkg_check_modules(PETSC QUIET IMPORTED_TARGET PETSc)
softhom_require(PETSC_FOUND "PETSc (real scalars)" libpetsc-real-dev)

# The Open MPI build of HDF5, named explicitly: PETSc links libhdf5_openmpi, and one process must not load
# two HDF5 libraries. Used with the serial file drivers unless a distributed writer asks for MPI-IO.
pkg_check_modules(HDF5 QUIET IMPORTED_TARGET hdf5-openmpi)
softhom_require(HDF5_FOUND "HDF5 (Open MPI build)" libhdf5-openmpi-dev)

find_package(tomlplusplus QUIET)
softhom_require(tomlplusplus_FOUND "toml++" libtomlplusplus-dev)
find_package(CLI11 QUIET)
softhom_require(CLI11_FOUND "CLI11" libcli11-dev)
find_package(nlohmann_json 3 QUIET)
softhom_require(nlohmann_json_FOUND "nlohmann-json" nlohmann-json3-dev)

find_package(CGAL QUIET)
softhom_require(CGAL_FOUND "CGAL 5.5" libcgal-dev)

find_package(Ceres QUIET)
softhom_require(Ceres_FOUND "Ceres Solver" libceres-dev)

if(SOFTHOM_BUILD_TESTS)
  find_package(GTest QUIET)
  softhom_require(GTest_FOUND "GoogleTest" libgtest-dev)
endif()
if(SOFTHOM_BUILD_BENCH)
  find_package(benchmark QUIET)
  softhom_require(benchmark_FOUND "Google Benchmark" libbenchmark-dev)
endif()
