#pragma once
// Refusing a problem that cannot fit before allocating it: the engines estimate their bytes from the
// problem size and compare with the memory this process may still use, so a grid or mesh that is too
// large ends in an input error naming the field instead of std::bad_alloc (or a solver library's
// failure) minutes later.
#include <algorithm>
#include <cstddef>
#include <limits>
#include <sstream>
#include <string>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/system_memory.hpp"

namespace softhom::rve::detail {

inline std::string gib(std::size_t bytes) {
  std::ostringstream s;
  s.precision(bytes >= (std::size_t(10) << 30) ? 3 : 2);
  s << double(bytes) / double(std::size_t(1) << 30);
  return s.str();
}

/// Throws InputError(field, value, "[what: ]needs about X GiB, the machine has Y GiB available") when
/// `needed` bytes exceed what is available (`available` 0: query the machine); `what` says what was
/// estimated (an element count, say).
inline void refuse_if_too_big(std::size_t needed, const std::string& field, const std::string& value,
                              std::size_t available = 0, const std::string& what = "") {
  if (available == 0) available = softhom::available_memory_bytes();
  if (available == 0 || needed <= available) return;
  throw InputError(field, value, (what.empty() ? "" : what + ": ") + "needs about " + gib(needed) + " GiB, the machine has " +
                                     gib(available) + " GiB available");
}

/// Product of sizes in bytes, saturating instead of wrapping (absurd grids must still be refused).
inline std::size_t saturating_product(std::initializer_list<double> factors) {
  double p = 1.0;
  for (double f : factors) p *= f;
  return p >= double(std::numeric_limits<std::size_t>::max()) ? std::numeric_limits<std::size_t>::max() : std::size_t(p);
}

}  // namespace softhom::rve::detail
