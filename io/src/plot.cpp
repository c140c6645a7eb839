#include "softhom/io/plot.hpp"

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "softhom/io/files.hpp"

namespace softhom::io {
namespace {

// The plotting script: reads a JSON description (argv[1]) and writes the PNG (argv[2]).
constexpr const char* kScript = R"py(
import csv, json, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
spec = json.load(open(sys.argv[1]))
fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=120)
for s in spec["series"]:
    with open(s["csv"]) as f:
        rows = list(csv.DictReader(f))
    ax.plot([float(r[s["x"]]) for r in rows], [float(r[s["y"]]) for r in rows], label=s["label"])
ax.set_title(spec["title"]); ax.set_xlabel(spec["xlabel"]); ax.set_ylabel(spec["ylabel"])
ax.grid(True, alpha=0.3)
if len(spec["series"]) > 1: ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(sys.argv[2], format="png")
)py";

}  // namespace

bool plot_curves(const std::filesystem::path& png, const PlotSpec& spec, std::string* why) {
  nlohmann::json j;
  j["title"] = spec.title;
  j["xlabel"] = spec.xlabel;
  j["ylabel"] = spec.ylabel;
  j["series"] = nlohmann::json::array();
  for (const auto& s : spec.series)
    j["series"].push_back({{"label", s.label}, {"csv", std::filesystem::absolute(s.csv).string()}, {"x", s.x}, {"y", s.y}});
  const auto dir = png.parent_path().empty() ? std::filesystem::path(".") : png.parent_path();
  const auto script = dir / ".softhom-plot.py";
  const auto json = dir / ".softhom-plot.json";
  const auto tmp = temporary_path(png);
  write_file_atomic(script, kScript);
  write_file_atomic(json, j.dump());
  // The first interpreter that has matplotlib: $SOFTHOM_PYTHON, Debian's /usr/bin/python3 (where
  // python3-matplotlib installs), then whatever python3 is on PATH (may be a virtualenv without it).
  std::string python;
  const char* candidates[] = {std::getenv("SOFTHOM_PYTHON"), "/usr/bin/python3", "python3"};
  for (const char* candidate : candidates) {
    if (!candidate || !*candidate) continue;
    const std::string probe = std::string("'") + candidate + "' -c 'import matplotlib' > /dev/null 2>&1";
    if (std::system(probe.c_str()) == 0) {
      python = candidate;
      break;
    }
  }
  std::error_code ec;  // clean-up is best effort: a failed removal must not hide the plot's outcome
  if (python.empty()) {
    std::filesystem::remove(script, ec);
    std::filesystem::remove(json, ec);
    if (why) *why = "no python3 with matplotlib found (Debian: python3-matplotlib; or set SOFTHOM_PYTHON)";
    return false;
  }
  const std::string cmd = "'" + python + "' '" + script.string() + "' '" + json.string() + "' '" + tmp.string() + "' > /dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  std::filesystem::remove(script, ec);
  std::filesystem::remove(json, ec);
  if (rc != 0 || !std::filesystem::exists(tmp, ec)) {
    std::filesystem::remove(tmp, ec);
    if (why) *why = "python3 with matplotlib (Debian: python3-matplotlib) not available or the plot failed";
    return false;
  }
  std::filesystem::rename(tmp, png, ec);
  if (ec) {
    const int err = ec.value();
    std::filesystem::remove(tmp, ec);
    throw WriteError(png, "cannot rename temporary into place", err);
  }
  return true;
}

}  // namespace softhom::io
