#!/usr/bin/env bash
# Installs exactly the Debian 12 packages softhom needs to build, test and plot. Idempotent: a second
# run changes nothing. Run as root (or with sudo available).
set -euo pipefail
packages=(
  build-essential cmake pkg-config
  libeigen3-dev            # materials/, everywhere
  libfftw3-dev             # fft/ (with libfftw3-omp / -threads)
  libsuitesparse-dev       # fe/: CHOLMOD, UMFPACK
  libopenblas0-openmp      # BLAS for CHOLMOD/UMFPACK (replaces generic ATLAS: 1.3-1.8x faster factorizations; OpenMP build shares our thread pool)
  libcgal-dev              # rve/: conforming meshes
  libhdf5-dev              # fields and stores
  libhdf5-openmpi-dev      # the HDF5 build PETSc links (one HDF5 per process)
  openmpi-bin libopenmpi-dev   # MPI: campaigns over ranks, distributed cells and macro solves
  libfftw3-mpi-dev         # fft/: distributed (slab) transforms
  libpetsc-real-dev        # fe/: Krylov solvers and AMG (hypre, MUMPS) for large macro meshes
  gmsh                     # macro/: meshes the device geometries (studies/meshes/*.geo) at run time
  hdf5-tools               # tests/faults: h5dump compares campaign stores
  libtomlplusplus-dev      # scene files
  libcli11-dev             # command line
  nlohmann-json3-dev       # summary.json
  libceres-dev             # calibration (bounded least squares)
  libgtest-dev             # tests
  libbenchmark-dev         # bench/
  python3-matplotlib       # PNG plots
  python3-h5py             # tests/mpi_fft: compares the fields.h5 of a distributed and a one-process run (with numpy)
  pybind11-dev python3-dev # python/: the `softhom` Python module, for Debian's /usr/bin/python3
  python3-numpy python3-pandas python3-pytest   # python/: arrays in and out, DataFrames, its tests
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
echo "softhom dependencies: all ${#packages[@]} packages installed"
