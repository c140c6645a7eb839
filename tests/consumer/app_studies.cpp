// Links the top of the library stack (softhom::studies: campaigns, calibration, and through it
// softhom::macro, ::io with HDF5, Ceres): every transitive dependency of the static libraries must come
// from softhomConfig.cmake. Checks a value the campaign layer defines.
#include <algorithm>
#include <cstdio>

#include "softhom/io/summary.hpp"
#include "softhom/studies/campaign.hpp"

int main() {
  const auto& axes = softhom::studies::campaign_axes();
  const bool has_angle = std::find(axes.begin(), axes.end(), "angle") != axes.end();
  std::printf("softhom %s: %zu campaign axes, angle %s\n", softhom::io::softhom_version().c_str(), axes.size(),
              has_angle ? "present" : "missing");
  return has_angle ? 0 : 1;
}
