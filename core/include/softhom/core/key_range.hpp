#pragma once
// Allowed-value intervals of scene keys (keys.hpp), in a header of their own so that parameter tables
// (materials/library.hpp) can declare ranges without pulling in the TOML parser.
#include <optional>
#include <string>

namespace softhom::keys {

/// An interval of allowed values; each end absent, open or closed.
struct Range {
  std::optional<double> lo, hi;
  bool lo_open = false, hi_open = false;
  bool contains(double x) const;
  bool bounded() const { return lo || hi; }
  /// "(0, 1)", "[0, 1]", ">= 0", "> 0", "<= 1" or "" (any value).
  std::string describe() const;
};
Range any_value();
Range open_range(double lo, double hi);    ///< (lo, hi)
Range closed_range(double lo, double hi);  ///< [lo, hi]
Range left_open(double lo, double hi);     ///< (lo, hi]
Range right_open(double lo, double hi);    ///< [lo, hi)
Range at_least(double lo);                 ///< [lo, ∞)
Range above(double lo);                    ///< (lo, ∞)
Range at_most(double hi);                  ///< (−∞, hi]

}  // namespace softhom::keys
