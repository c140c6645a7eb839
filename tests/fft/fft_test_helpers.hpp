#pragma once
// Small shared builders of the fft tests.
#include <random>
#include <vector>

#include "softhom/fft/gradient.hpp"

namespace softhom::fft::testing {

/// n complex values with real and imaginary parts uniform in [−1, 1].
inline std::vector<Complex> random_spectrum(std::size_t n, std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<Complex> x(n);
  for (auto& c : x) c = Complex(U(rng), U(rng));
  return x;
}

}  // namespace softhom::fft::testing
