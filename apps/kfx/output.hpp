#pragma once
// What the subcommands share for their output: directories, paths, atomic text files, matrices printed on
// stdout and matrices as JSON; the known-input file (--input) of simulate, filter and smooth.
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <string>

#include "kfx/model.hpp"

namespace kfx::cli {

/// The known input g of `--input PATH` (.npy or .csv, (T, q), row k-1 = g_k), checked against the model for
/// `steps` steps; a 0 x 0 series when PATH is empty. @throws kfx::Error "--input: ..." when the file does
/// not fit the model's G, D (or the model has a known input and no --input is given).
TimeSeries ReadKnownInput(const std::string& path, const Model& model, int steps);

/// Creates `dir` and its parents. @throws kfx::Error "-o/--out: cannot create directory ...".
void MakeDir(const std::string& dir);

/// `dir/name`.
std::string Join(const std::string& dir, const std::string& name);

/// Writes `text` and a newline to `path` atomically (kfx::AtomicOutputFile).
void WriteText(const std::string& path, const std::string& text);

/// Prints `name (shape):` and the matrix on stdout when it is at most max_size x max_size, else its
/// Frobenius norm and (square) its trace and diagonal.
void PrintMatrix(const std::string& name, const Eigen::MatrixXd& m, Eigen::Index max_size = 4);

/// The matrix as a JSON array of rows.
nlohmann::ordered_json ToJson(const Eigen::MatrixXd& m);

}  // namespace kfx::cli
