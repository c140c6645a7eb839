#pragma once
// Typed errors. InputError names the offending field and value so that every front end can report
// "field = value: reason" and exit non-zero without a crash.
#include <charconv>
#include <stdexcept>
#include <string>

namespace softhom {

/// A number as the user wrote it: the shortest text that reads back to the same double ("1e+300",
/// "1e-300", "0.1", "nan", "inf"), for messages; never std::to_string's fixed six decimals.
inline std::string format_number(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

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
