#pragma once
// Where a job's results go. A job (jobs.hpp) hands its sink what the run produces, as it is produced:
// tables of rows (response.csv, device.csv) as steps converge, field files, and the summary at the end.
// FileSink writes the files of the `softhom` program into its directory (rows on disk as they converge,
// every file replaced atomically); MemorySink keeps the rows as numbers with their column names and
// the summary as JSON, and touches no file system (the Python module's results); TeeSink gives both.
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"

namespace softhom::jobs {

class Sink {
 public:
  virtual ~Sink() = default;
  /// Before the first output: the file sink creates its directory.
  virtual void prepare() {}
  /// Starts the table `name` ("response", "device") with its columns; rows follow with add_row.
  virtual void open_table(const std::string& name, const std::vector<std::string>& columns) = 0;
  /// One converged row of the table `name` (non-finite values are refused, as in every output file).
  virtual void add_row(const std::string& name, const std::vector<double>& row) = 0;
  /// Every row so far reaches its storage (the file sink writes its tables now).
  virtual void flush() = 0;
  /// The run's summary (summary.json).
  virtual void write_summary(const nlohmann::json& summary) = 0;
  /// A field file <stem>.h5 + <stem>.xdmf on a voxel grid or a mesh, or null when the sink keeps no
  /// fields (the memory sink).
  virtual std::unique_ptr<io::FieldWriter> open_fields(const std::string& stem, const io::VoxelGrid& grid) = 0;
  virtual std::unique_ptr<io::FieldWriter> open_fields(const std::string& stem, const io::UnstructuredMesh& mesh) = 0;
  /// The directory of a file sink: checkpoints, microstructure images and the files of the studies go
  /// there. Empty for a sink without one (checkpoints are then not written).
  virtual std::filesystem::path directory() const = 0;
  /// Where `file` ends up, for messages ("OUT/response.csv", or "the returned result").
  virtual std::string where(const std::string& file) const = 0;
};

/// The program's output directory: OUT/<table>.csv, OUT/summary.json, OUT/<stem>.h5/.xdmf.
class FileSink final : public Sink {
 public:
  explicit FileSink(std::filesystem::path out);
  /// The directory of `softhom <command>`: refused (InputError naming --out) when it holds another
  /// subcommand's results (its summary.json says which), so that two runs' files never mix.
  FileSink(std::filesystem::path out, const std::string& command);
  void prepare() override;
  void open_table(const std::string& name, const std::vector<std::string>& columns) override;
  void add_row(const std::string& name, const std::vector<double>& row) override;
  void flush() override;
  void write_summary(const nlohmann::json& summary) override;
  std::unique_ptr<io::FieldWriter> open_fields(const std::string& stem, const io::VoxelGrid& grid) override;
  std::unique_ptr<io::FieldWriter> open_fields(const std::string& stem, const io::UnstructuredMesh& mesh) override;
  std::filesystem::path directory() const override { return out_; }
  std::string where(const std::string& file) const override {
    return file.empty() ? out_.string() : (out_ / file).string();
  }

 private:
  std::filesystem::path out_;
  std::map<std::string, io::ProgressiveCsv> tables_;
};

/// The results in memory: each table's columns and rows (row after row), and the summary.
class MemorySink final : public Sink {
 public:
  void open_table(const std::string& name, const std::vector<std::string>& columns) override;
  void add_row(const std::string& name, const std::vector<double>& row) override;
  void flush() override {}
  void write_summary(const nlohmann::json& summary) override;
  std::unique_ptr<io::FieldWriter> open_fields(const std::string&, const io::VoxelGrid&) override { return nullptr; }
  std::unique_ptr<io::FieldWriter> open_fields(const std::string&, const io::UnstructuredMesh&) override {
    return nullptr;
  }
  std::filesystem::path directory() const override { return {}; }
  std::string where(const std::string& file) const override { return "the returned result (" + file + ")"; }

  /// The table `name` (null when the run wrote none).
  const io::CsvTable* table(const std::string& name) const;
  /// summary.json's text as the file sink writes it; empty before the run wrote its summary.
  const std::string& summary_text() const { return summary_text_; }
  bool has_summary() const { return !summary_text_.empty(); }

 private:
  std::map<std::string, io::CsvTable> tables_;
  std::string summary_text_;
};

/// Both: the files in a directory and the results in memory (the Python module with out=DIR).
class TeeSink final : public Sink {
 public:
  TeeSink(Sink& first, Sink& second) : a_(first), b_(second) {}
  void prepare() override { a_.prepare(); b_.prepare(); }
  void open_table(const std::string& name, const std::vector<std::string>& columns) override {
    a_.open_table(name, columns); b_.open_table(name, columns);
  }
  void add_row(const std::string& name, const std::vector<double>& row) override {
    a_.add_row(name, row); b_.add_row(name, row);
  }
  void flush() override { a_.flush(); b_.flush(); }
  void write_summary(const nlohmann::json& summary) override { a_.write_summary(summary); b_.write_summary(summary); }
  /// The first sink's field file, else the second's.
  std::unique_ptr<io::FieldWriter> open_fields(const std::string& stem, const io::VoxelGrid& grid) override;
  std::unique_ptr<io::FieldWriter> open_fields(const std::string& stem, const io::UnstructuredMesh& mesh) override;
  /// The first sink's directory, else the second's.
  std::filesystem::path directory() const override;
  std::string where(const std::string& file) const override;

 private:
  Sink& a_;
  Sink& b_;
};

/// A sink that keeps nothing: the ranks of an MPI run that compute but do not write.
class DiscardSink final : public Sink {
 public:
  void open_table(const std::string&, const std::vector<std::string>&) override {}
  void add_row(const std::string&, const std::vector<double>&) override {}
  void flush() override {}
  void write_summary(const nlohmann::json&) override {}
  std::unique_ptr<io::FieldWriter> open_fields(const std::string&, const io::VoxelGrid&) override { return nullptr; }
  std::unique_ptr<io::FieldWriter> open_fields(const std::string&, const io::UnstructuredMesh&) override {
    return nullptr;
  }
  std::filesystem::path directory() const override { return {}; }
  std::string where(const std::string& file) const override { return file; }
};

}  // namespace softhom::jobs
