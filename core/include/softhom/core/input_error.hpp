#pragma once
// The input error every front end reports as "field = value: reason" (exit status 2), and numbers as
// the user wrote them. Header-only and free of dependencies, so every library can throw it.
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

/// Bad input, naming the TOML path of the field ("solver.tolerance", "load.stretch[2][1]") and the
/// value as written.
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

}  // namespace softhom
