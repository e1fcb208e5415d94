// What the subcommands share for their output: directories, paths, atomic text files, matrices printed on
// stdout and matrices as JSON; the known-input file (--input) of simulate, filter and smooth.
#include "output.hpp"

#include <filesystem>
#include <iostream>
#include <sstream>

#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/validation.hpp"

namespace fs = std::filesystem;
using Eigen::MatrixXd;

namespace kfx::cli {

TimeSeries ReadKnownInput(const std::string& path, const Model& model, int steps) {
  TimeSeries g(0, 0);
  try {
    if (!path.empty()) g = ReadTimeSeries(path);
    RequireKnownInput(model, g, steps);
  } catch (const Error& e) {
    throw Error("--input: " + std::string(e.what()) +
                (path.empty() ? " (the model has fields G, D: give the known input with --input)" : ""));
  }
  return g;
}

namespace {

std::string Fmt(const MatrixXd& m) {
  static const Eigen::IOFormat f(6, 0, "  ", "\n", "    [", "]");
  std::ostringstream os;
  os << m.format(f);
  return os.str();
}

}  // namespace

void MakeDir(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw Error("-o/--out: cannot create directory '" + dir + "': " + ec.message());
}

std::string Join(const std::string& dir, const std::string& name) { return (fs::path(dir) / name).string(); }

void WriteText(const std::string& path, const std::string& text) {
  AtomicOutputFile file(path);
  file.stream() << text << "\n";
  file.Commit();
}

void PrintMatrix(const std::string& name, const MatrixXd& m, Eigen::Index max_size) {
  if (m.rows() <= max_size && m.cols() <= max_size) {
    std::cout << "  " << name << " (" << ShapeString(m) << "):\n" << Fmt(m) << "\n";
  } else {
    std::cout << "  " << name << " (" << ShapeString(m) << "), |.|_F = " << m.norm();
    if (m.rows() == m.cols()) {
      std::cout << ", trace " << m.trace() << ", diagonal:\n" << Fmt(m.diagonal().transpose()) << "\n";
    } else {
      std::cout << " (all entries with --json)\n";
    }
  }
}

nlohmann::ordered_json ToJson(const MatrixXd& m) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace kfx::cli
