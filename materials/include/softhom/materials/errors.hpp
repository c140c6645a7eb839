#pragma once
// Typed errors. InputError names the offending field and value so that every front end can report
// "field = value: reason" and exit non-zero without a crash.
#include <stdexcept>

#include "softhom/core/input_error.hpp"

namespace softhom {

/// A solver that could not reach convergence even after cutting the step back to its minimum.
class ConvergenceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace softhom
