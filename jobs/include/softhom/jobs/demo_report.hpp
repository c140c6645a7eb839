#pragma once
// Pure pieces of the `softhom demo` report, kept apart from the steps that run things so that they
// can be tested on their own: notes on calibrated parameters that ended at a bound, and the named
// values of the tube's last response row.
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "softhom/materials/errors.hpp"

namespace softhom::jobs {

/// One note per free parameter of a calibration summary.json that ended at a bound of its
/// [min, max] ("at_bound"), e.g. "k2 at its lower bound 0.001: the curves do not determine it".
/// A parameter at a bound is a property of the data (the curves carry no information that moves it
/// inward), not a failure of the run, so the demo reports it as a note.
inline std::vector<std::string> bound_notes(const nlohmann::json& calibration_summary) {
  std::vector<std::string> notes;
  if (!calibration_summary.contains("parameters")) return notes;
  for (const auto& p : calibration_summary["parameters"]) {
    if (!p.value("free", false) || !p.value("at_bound", false)) continue;
    if (!p.contains("min") || !p.contains("max") || !p.contains("value")) continue;
    const double value = p["value"].get<double>(), lo = p["min"].get<double>(), hi = p["max"].get<double>();
    const bool lower = std::abs(value - lo) <= std::abs(value - hi);
    notes.push_back(p.value("name", std::string("?")) + " at its " + (lower ? "lower" : "upper") + " bound " +
                    format_number(lower ? lo : hi) + ": the curves do not determine it");
  }
  return notes;
}

/// Splits one CSV line at commas (the response files hold plain numbers and names, no quoting).
inline std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) cells.push_back(cell);
  return cells;
}

/// (label, value) pairs of the tube's last response row for the columns a reader looks at first;
/// columns missing from the header are left out.
inline std::vector<std::pair<std::string, std::string>> tube_final_state(const std::string& header,
                                                                         const std::string& last_row) {
  static const std::pair<const char*, const char*> kShown[] = {{"pressure", "pressure [MPa]"},
                                                               {"axial_stretch", "axial stretch"},
                                                               {"stretch", "inner-radius stretch"},
                                                               {"twist_deg", "twist [deg]"},
                                                               {"volume", "cavity volume [mm^3]"}};
  const auto names = split_csv_line(header), values = split_csv_line(last_row);
  std::vector<std::pair<std::string, std::string>> shown;
  for (const auto& [column, label] : kShown)
    for (std::size_t j = 0; j < names.size() && j < values.size(); ++j)
      if (names[j] == column) {
        std::ostringstream v;
        v.precision(4);
        try {
          const double x = std::stod(values[j]);
          v << (std::abs(x) < 1e-12 ? 0.0 : x);  // round-off of a quantity that is zero (twist of a symmetric tube)
        } catch (const std::exception&) {
          v << values[j];  // not a number: show it as written
        }
        shown.emplace_back(label, v.str());
      }
  return shown;
}

/// "pressure [MPa] 0.01, axial stretch 0.9268, ..." for the console.
inline std::string join_state(const std::vector<std::pair<std::string, std::string>>& state) {
  std::string s;
  for (const auto& [label, value] : state) s += (s.empty() ? "" : ", ") + label + " " + value;
  return s;
}

}  // namespace softhom::jobs
