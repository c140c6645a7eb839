# `cpack -G DEB`: softhom_<version>_<arch>.deb of what `cmake --install` puts under /usr (the program, the
# Python module, the examples, the libraries with their headers and CMake package). scripts/package-deb.sh
# configures a build for it (/usr, Debian's python3 path) and checks the result.
#
# Run-time dependencies: the shared libraries the program and the module link are found by
# dpkg-shlibdeps (CPACK_DEBIAN_PACKAGE_SHLIBDEPS); programs and Python packages they call or import
# cannot be found that way and are listed here: `softhom macro` runs gmsh on .geo geometries, the Python
# module imports numpy and pandas; the plot scripts use matplotlib and `mpirun` launches ranks.
set(CPACK_PACKAGE_NAME softhom)
set(CPACK_PACKAGE_VENDOR "The softhom developers")
set(CPACK_PACKAGE_CONTACT "The softhom developers")  # as CITATION.cff names them
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "multiscale mechanics of soft fiber composites (FFT and FE cells, structure-scale FE)")
set(CPACK_PACKAGE_DESCRIPTION
    "softhom homogenizes fiber-reinforced elastomer cells with FFT and finite-element solvers and runs
structure-scale nonlinear FE of soft devices; the softhom program, its Python module and examples.")
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # softhom_0.1.0_amd64.deb
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "gmsh, python3, python3-numpy, python3-pandas")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "python3-matplotlib, openmpi-bin")
include(CPack)
