#pragma once
// PNG plots of CSV curves through python3 + matplotlib (Debian: python3-matplotlib). Plotting is a
// convenience: when python3 or matplotlib is missing the call returns false and the caller warns.
#include <filesystem>
#include <string>
#include <vector>

namespace softhom::io {

struct CurveSeries {
  std::string label;
  std::filesystem::path csv;  ///< a CSV with a header row (e.g. a response.csv)
  std::string x, y;           ///< column names
};

struct PlotSpec {
  std::string title, xlabel, ylabel;
  std::vector<CurveSeries> series;
};

/// Writes `png` (atomically: matplotlib renders to a temporary name that is then renamed). Returns
/// false, with the reason in `why`, if python3/matplotlib is unavailable or the plot failed.
bool plot_curves(const std::filesystem::path& png, const PlotSpec& spec, std::string* why = nullptr);

}  // namespace softhom::io
