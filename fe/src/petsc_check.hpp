#pragma once
// The error check of every PETSc call in fe/src: a failed call is a broken build or an exhausted
// machine, not a user error, so it throws std::runtime_error naming the call.
#include <petscsys.h>

#include <stdexcept>
#include <string>

namespace softhom::fe {

inline void petsc_check(PetscErrorCode code, const char* what) {
  if (code != 0) throw std::runtime_error(std::string("PETSc: ") + what + " failed (error " + std::to_string(int(code)) + ")");
}

}  // namespace softhom::fe
