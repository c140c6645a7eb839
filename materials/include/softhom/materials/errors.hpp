#pragma once
// Typed errors. InputError names the offending field and value so that every front end can report
// "field = value: reason" and exit non-zero without a crash.
#include <stdexcept>
#include <string>

namespace softhom {

class InputError : public std::runtime_error {
 public:
  InputError(std::string field, std::string value, const std::string& reason)
      : std::runtime_error(field + (value.empty() ? "" : " = " + value) + ": " + reason),
        field_(std::move(field)), value_(std::move(value)) {}
  const std::string& field() const { return field_; }
  const std::string& value() const { return value_; }

 private:
  std::string field_, value_;
};

/// A solver that could not reach convergence even after cutting the step back to its minimum.
class ConvergenceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A material call failed in a way no step cut-back can cure (e.g. Gent locking at a prescribed
/// stretch): the caller keeps what it computed so far and stops with this message.
class MaterialLimitError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace softhom
