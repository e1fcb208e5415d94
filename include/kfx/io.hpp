#pragma once
// Files: NumPy .npy arrays, CSV time series, and the kfx model file (JSON + .npy).
// Formats are specified in docs/formats.md. Every reader throws kfx::Error naming the file and
// what was expected (never a crash on a truncated or malformed file).
#include <Eigen/Dense>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "kfx/model.hpp"

namespace kfx {

/// An output file written under a temporary name in the same directory (path + ".tmp-<pid>-<n>")
/// and renamed to `path` by Commit(), so that a failed or interrupted write never leaves a partial
/// file under the final name. Destroyed without Commit(), it removes the temporary file. Every
/// writer of kfx (WriteNpy, WriteTimeSeries, SaveModel, the CLI) writes through it.
class AtomicOutputFile {
 public:
  /// @throws kfx::Error if the temporary file cannot be created.
  explicit AtomicOutputFile(std::string path);
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;
  std::ofstream& stream() { return out_; }
  const std::string& temp_path() const { return temp_; }
  /// Closes, checks and renames the file. @throws kfx::Error if writing or renaming failed.
  void Commit();

 private:
  std::string path_, temp_;
  std::ofstream out_;
  bool committed_ = false;
};

/// A directory of outputs that holds one complete run or is visibly incomplete (the one mechanism of every
/// command that writes a directory: filter, smooth, simulate, blockdiag on any number of ranks). The owner's
/// constructor creates the directory and removes its completion marker (summary.json, metadata.json: the file
/// that lists the run's outputs) before any output is written; each output goes through AtomicOutputFile; Commit
/// writes the marker last. A directory without its marker is an incomplete run, whatever else it holds; a
/// marker lists only files of its own run, complete. A non-owner (an MPI rank other than 0) only makes sure the
/// directory exists and writes its outputs; the owner commits after every writer has finished.
class OutputDirectory {
 public:
  /// @throws kfx::Error "<option>: cannot create directory ..." or "... cannot remove the completion marker"
  /// (`option` names the argument that gave the directory, e.g. "-o/--out").
  OutputDirectory(std::string dir, std::string marker, bool owner = true, const std::string& option = "-o/--out");
  /// dir/name.
  std::string Path(const std::string& name) const;
  const std::string& dir() const { return dir_; }
  /// Writes the marker (text and a newline) atomically, last. @throws kfx::Error if it cannot, or if not the owner.
  void Commit(const std::string& marker_text);

 private:
  std::string dir_, marker_;
  bool owner_;
};

/// A dense array read from a .npy file, converted to double, stored in C (row-major) order.
struct NpyArray {
  std::vector<std::int64_t> shape;
  std::vector<double> data;  ///< C order, size = product of shape
};

/// Reads a .npy file (format versions 1.0-3.0; dtypes <f8, <f4, <i8, <i4, <u1, |b1 read as double;
/// fortran_order true or false). @throws kfx::Error for an unreadable/truncated/unsupported file.
NpyArray ReadNpy(const std::string& path);
/// Reads only elements [start, start + count) along `axis` of a .npy file (the slice a process needs of a
/// large array; seeks past the rest). The returned shape is the file's with that axis set to count.
/// @throws kfx::Error as ReadNpy, or for an axis or range outside the array's shape.
NpyArray ReadNpySlice(const std::string& path, int axis, std::int64_t start, std::int64_t count);
/// Writes a C-order <f8 array. @throws kfx::Error if the file cannot be written or sizes disagree.
void WriteNpy(const std::string& path, const std::vector<std::int64_t>& shape, const double* data);
/// A 2-D array (a 1-D array of length n becomes n x 1). @throws kfx::Error for other ranks.
Eigen::MatrixXd ReadNpyMatrix(const std::string& path);
/// Writes an r x c matrix as shape (r, c).
void WriteNpyMatrix(const std::string& path, const Eigen::Ref<const Eigen::MatrixXd>& m);
/// Writes a vector as shape (n,).
void WriteNpyVector(const std::string& path, const Eigen::Ref<const Eigen::VectorXd>& v);

/// Reads a time series (T rows, one per time step) from .npy (shape (T, m) or (T,)) or .csv
/// (chosen by extension). CSV: comma-separated numbers, optional header line (non-numeric first
/// line), '#' comment lines, and "nan"/"NaN"/empty fields read as NaN (missing measurements).
/// @throws kfx::Error for unreadable files, ragged rows, non-numeric fields.
TimeSeries ReadTimeSeries(const std::string& path);
/// As ReadTimeSeries(path), and sets *column_names (if not null) to the CSV header's names (empty
/// when the file has no header line, and always for .npy).
TimeSeries ReadTimeSeries(const std::string& path, std::vector<std::string>* column_names);
/// Writes a time series as .npy or .csv (by extension); CSV gets a header line if names are given.
void WriteTimeSeries(const std::string& path, const TimeSeries& data,
                     const std::vector<std::string>& column_names = {});

/// Loads a model file (JSON; matrices inline or as {"npy": "relative/path.npy"}; a leading time
/// dimension makes the model time-varying). @throws kfx::Error naming the file and the field.
Model LoadModel(const std::string& path);

/// The "format" field of the JSON object in `path` ("kfx-model", "kfx-coupled-model", ...), or "" when the
/// path is not a regular file (a FIFO is not opened), cannot be read, or holds no JSON object with a
/// string "format": the reader of the file then says what is wrong.
std::string JsonFileFormat(const std::string& path);

struct SaveModelOptions {
  /// Matrices with more entries than this go to .npy files beside the JSON file.
  std::int64_t inline_max_entries = 400;
  /// For callback models (no stored sequence): number of steps to write out.
  int steps = -1;
};
/// Writes a model file (JSON plus .npy files named <stem>.<field>.npy next to it).
void SaveModel(const std::string& path, const Model& model, const SaveModelOptions& options = SaveModelOptions());

}  // namespace kfx
