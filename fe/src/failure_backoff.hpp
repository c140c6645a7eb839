#pragma once
// Skipping a try that keeps failing: after k failures in a row, the next 2^(k − lag) − 1 chances (at
// most 7) are not taken, so a try that fails through a stretch of steps (a Cholesky factorization of
// an indefinite tangent, a secant start overshooting a stiffening response) costs a few failures over
// the stretch, not one per step; one success starts the count again.
#include <algorithm>

namespace softhom::fe {

class FailureBackoff {
 public:
  /// lag 0: the first failure skips one chance; lag 1: the second failure in a row skips one.
  explicit FailureBackoff(int lag) : lag_(lag) {}
  /// Whether to take this chance (each call uses one up).
  bool take_chance() {
    if (skip_ == 0) return true;
    --skip_;
    return false;
  }
  void failed() {
    failures_ = std::min(failures_ + 1, 3 + lag_);
    skip_ = (1 << (failures_ - lag_)) - 1;
  }
  void succeeded() { failures_ = 0; }

 private:
  int lag_;
  int failures_ = 0;  ///< in a row
  int skip_ = 0;      ///< chances left to skip
};

}  // namespace softhom::fe
