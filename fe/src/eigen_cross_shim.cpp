// TEMPORARY: materials/src/loading.cpp calls Vec3::cross without including <Eigen/Geometry>, which
// leaves the symbol undefined at link time. This explicit instantiation provides it until that file
// includes the header; delete this file then (a duplicate instantiation is harmless: COMDAT).
#include <Eigen/Core>
#include <Eigen/Geometry>

template Eigen::MatrixBase<Eigen::Matrix<double, 3, 1>>::cross_product_return_type<Eigen::Matrix<double, 3, 1>>::type
Eigen::MatrixBase<Eigen::Matrix<double, 3, 1>>::cross<Eigen::Matrix<double, 3, 1>>(
    const Eigen::MatrixBase<Eigen::Matrix<double, 3, 1>>&) const;
