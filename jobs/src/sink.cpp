// Where a job's results go (sink.hpp).
#include "softhom/jobs/sink.hpp"

#include "softhom/core/input_error.hpp"
#include "softhom/io/files.hpp"

#include "softhom/io/summary.hpp"

namespace softhom::jobs {

FileSink::FileSink(std::filesystem::path out) : out_(std::move(out)) {}

namespace {

/// The subcommand whose results are in `out` (its summary.json's "command"), or "" when none can be read.
std::string command_of_results(const std::filesystem::path& out) {
  const std::filesystem::path summary = out / "summary.json";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(summary, ec)) return "";
  if (!io::input_file_problem(summary, io::kJsonFile).empty()) return "";
  const nlohmann::json j = nlohmann::json::parse(io::read_input_file(summary, "--out", io::kJsonFile), nullptr, false);
  if (!j.is_object() || !j.contains("command") || !j["command"].is_string()) return "";
  return j["command"].get<std::string>();
}

}  // namespace

FileSink::FileSink(std::filesystem::path out, const std::string& command) : out_(std::move(out)) {
  const std::string earlier = command_of_results(out_);
  if (!earlier.empty() && earlier != command)
    throw InputError("--out", out_.string(),
                     "holds the results of `softhom " + earlier + "` (its summary.json): the files of a " + command +
                         " run would mix with them; choose another directory");
}

void FileSink::prepare() { std::filesystem::create_directories(out_); }

void FileSink::open_table(const std::string& name, const std::vector<std::string>& columns) {
  tables_.insert_or_assign(name, io::ProgressiveCsv(out_ / (name + ".csv"), columns));
}

void FileSink::add_row(const std::string& name, const std::vector<double>& row) { tables_.at(name).add_row(row); }

void FileSink::flush() {
  for (auto& [name, table] : tables_) table.flush();
}

void FileSink::write_summary(const nlohmann::json& summary) { io::write_summary(out_, summary); }

std::unique_ptr<io::FieldWriter> FileSink::open_fields(const std::string& stem, const io::VoxelGrid& grid) {
  prepare();
  return std::make_unique<io::FieldWriter>(out_ / stem, grid);
}

std::unique_ptr<io::FieldWriter> FileSink::open_fields(const std::string& stem, const io::UnstructuredMesh& mesh) {
  prepare();
  return std::make_unique<io::FieldWriter>(out_ / stem, mesh);
}

void MemorySink::open_table(const std::string& name, const std::vector<std::string>& columns) {
  tables_.insert_or_assign(name, io::CsvTable(columns));
}

void MemorySink::add_row(const std::string& name, const std::vector<double>& row) { tables_.at(name).add_row(row); }

void MemorySink::write_summary(const nlohmann::json& summary) {
  // The text io::write_summary writes, so that a reader of either gets the same values.
  summary_text_ = summary.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

const io::CsvTable* MemorySink::table(const std::string& name) const {
  const auto it = tables_.find(name);
  return it == tables_.end() ? nullptr : &it->second;
}

std::unique_ptr<io::FieldWriter> TeeSink::open_fields(const std::string& stem, const io::VoxelGrid& grid) {
  auto w = a_.open_fields(stem, grid);
  return w ? std::move(w) : b_.open_fields(stem, grid);
}

std::unique_ptr<io::FieldWriter> TeeSink::open_fields(const std::string& stem, const io::UnstructuredMesh& mesh) {
  auto w = a_.open_fields(stem, mesh);
  return w ? std::move(w) : b_.open_fields(stem, mesh);
}

std::filesystem::path TeeSink::directory() const {
  const std::filesystem::path d = a_.directory();
  return d.empty() ? b_.directory() : d;
}

std::string TeeSink::where(const std::string& file) const {
  return a_.directory().empty() ? b_.where(file) : a_.where(file);
}

}  // namespace softhom::jobs
