#pragma once
// Backtracking line search on a merit function, generic over how a trial iterate is evaluated (the
// FFT and FE RVE engines, the macro solver): trial scales 1, 1/2, 1/4, … of the Newton step; the
// first admissible trial with a sufficient decrease (Armijo, merit < (1 − c·s) merit₀) is taken, or
// any admissible one when the caller says so (a prescribed-increment step, whose merit is not
// comparable with the previous one; a continuation iteration), or the last admissible trial.
#include <cmath>
#include <optional>

namespace softhom::fe {

struct LineSearchOptions {
  int max_trials = 8;         ///< trial scales 1 … 2^−(max_trials−1)
  double sufficient = 1e-4;   ///< Armijo constant c
};

struct LineSearchResult {
  bool accepted = false;
  double scale = 0.0;  ///< of the accepted trial
  int trials = 0;      ///< evaluated trials
};

/// `trial(scale)` sets the iterate x₀ + scale·Δx, evaluates it and returns its merit, or nullopt when
/// it is not admissible (a failed material call); a non-finite merit is not admissible either. On
/// failure the iterate is that of the last trial (the caller restores x₀).
template <class Trial>
LineSearchResult backtracking_line_search(double merit_old, bool accept_any, Trial&& trial,
                                          const LineSearchOptions& o = {}) {
  LineSearchResult r;
  double scale = 1.0;
  for (int ls = 0; ls < o.max_trials; ++ls, scale *= 0.5) {
    ++r.trials;
    const std::optional<double> merit = trial(scale);
    if (!merit || !std::isfinite(*merit)) continue;
    if (accept_any || *merit < (1.0 - o.sufficient * scale) * merit_old || ls == o.max_trials - 1) {
      r.accepted = true;
      r.scale = scale;
      return r;
    }
  }
  return r;
}

}  // namespace softhom::fe
