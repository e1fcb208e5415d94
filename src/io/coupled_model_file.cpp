// The coupled model file of `kfx blockdiag` (include/kfx/coupled_model_file.hpp; format: docs/formats.md,
// "Coupled model files"): the header, a slice read by offset, and the writer.
#include "kfx/coupled_model_file.hpp"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/validation.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
namespace fs = std::filesystem;

namespace {

using nlohmann::json;

[[noreturn]] void FailField(const std::string& path, const std::string& field, const std::string& what) {
  throw Error(path + ": field '" + field + "': " + what);
}

json ReadJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open file for reading");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw Error(path + ": not valid JSON (" + e.what() + ")");
  }
}

Index PositiveField(const std::string& path, const json& j, const char* key, Index min) {
  if (!j.contains(key) || !j[key].is_number_integer() || j[key].get<long long>() < min) {
    FailField(path, key, "expected an integer >= " + std::to_string(min));
  }
  return j[key].get<Index>();
}

// An inline matrix: a number (1 x 1), a list (a vector, rows x 1 or 1 x cols), or a list of rows.
MatrixXd InlineMatrix(const std::string& path, const std::string& field, const json& v, Index rows, Index cols) {
  MatrixXd m(rows, cols);
  auto number = [&](const json& x) {
    if (!x.is_number()) FailField(path, field, "expected numbers, got " + x.dump());
    return x.get<double>();
  };
  const std::string want = "expected a " + ShapeString(rows, cols) + " matrix";
  if (v.is_number() && rows == 1 && cols == 1) {
    m(0, 0) = number(v);
  } else if (v.is_array() && !v.empty() && !v[0].is_array() && (rows == 1 || cols == 1) &&
             static_cast<Index>(v.size()) == rows * cols) {
    for (Index i = 0; i < rows * cols; ++i) m(i) = number(v[static_cast<size_t>(i)]);
  } else if (v.is_array() && static_cast<Index>(v.size()) == rows) {
    for (Index i = 0; i < rows; ++i) {
      const json& row = v[static_cast<size_t>(i)];
      if (!row.is_array() || static_cast<Index>(row.size()) != cols) FailField(path, field, want);
      for (Index j = 0; j < cols; ++j) m(i, j) = number(row[static_cast<size_t>(j)]);
    }
  } else {
    FailField(path, field, want + " (list of rows) or {\"npy\": \"file.npy\"}");
  }
  RequireFinite(path + ": " + field, m);
  return m;
}

// Blocks [first, first + count) of a per-subsystem field (a x b each) as packed a x (count b), or the
// inline a x b matrix repeated.
MatrixXd FieldBlocks(const std::string& path, const json& j, const std::string& field, Index n, Index a, Index b,
                     Index first, Index count) {
  if (!j.contains(field)) FailField(path, field, "missing");
  const json& v = j[field];
  if (v.is_object()) {
    if (v.size() != 1 || !v.contains("npy") || !v["npy"].is_string()) {
      FailField(path, field, "expected {\"npy\": \"file.npy\"}, got " + v.dump());
    }
    fs::path file = v["npy"].get<std::string>();
    if (file.is_relative()) file = fs::path(path).parent_path() / file;
    const NpyArray arr = ReadNpySlice(file.string(), 0, first, count);
    const bool vector_field = b == 1;
    const bool ok = (arr.shape.size() == 3 && arr.shape[0] == count && arr.shape[1] == a && arr.shape[2] == b) ||
                    (vector_field && arr.shape.size() == 2 && arr.shape[0] == count && arr.shape[1] == a);
    if (!ok || arr.shape.empty()) {
      FailField(path, field,
                "expected an array of shape (" + std::to_string(n) + ", " + std::to_string(a) + ", " +
                    std::to_string(b) + ")" +
                    (vector_field ? " or (" + std::to_string(n) + ", " + std::to_string(a) + ")" : "") + " in " +
                    file.string());
    }
    MatrixXd m(a, count * b);
    for (Index i = 0; i < count; ++i) {
      for (Index p = 0; p < a; ++p) {
        for (Index q = 0; q < b; ++q) m(p, i * b + q) = arr.data[static_cast<size_t>((i * a + p) * b + q)];
      }
    }
    RequireFinite(file.string(), m);
    return m;
  }
  return InlineMatrix(path, field, v, a, b).replicate(1, count);
}

}  // namespace

CoupledModelHeader ReadCoupledModelHeader(const std::string& path) {
  const json j = ReadJson(path);
  if (!j.is_object() || !j.contains("format") || j["format"] != "kfx-coupled-model") {
    throw Error(path + ": expected a coupled model file (\"format\": \"kfx-coupled-model\")");
  }
  CoupledModelHeader h;
  h.n = PositiveField(path, j, "n", 1);
  h.c = PositiveField(path, j, "c", 1);
  h.d = PositiveField(path, j, "d", 1);
  h.r = PositiveField(path, j, "r", 0);
  if (!j.contains("U")) FailField(path, "U", "missing");
  h.U = InlineMatrix(path, "U", j["U"], h.r, h.r);
  return h;
}

CoupledSystem LoadCoupledModelSlice(const std::string& path, Index first, Index count) {
  const CoupledModelHeader h = ReadCoupledModelHeader(path);
  if (first < 0 || count < 1 || first + count > h.n) {
    throw Error(path + ": slice [" + std::to_string(first) + ", " + std::to_string(first + count) +
                ") is outside the model's " + std::to_string(h.n) + " subsystems");
  }
  const json j = ReadJson(path);
  const Index c = h.c, d = h.d, r = h.r;
  CoupledStep s;
  s.F = FieldBlocks(path, j, "F", h.n, c, c, first, count);
  s.H = FieldBlocks(path, j, "H", h.n, d, c, first, count);
  s.V = FieldBlocks(path, j, "V", h.n, c, c, first, count);
  s.R = FieldBlocks(path, j, "R", h.n, d, d, first, count);
  const MatrixXd Gb = FieldBlocks(path, j, "G", h.n, c, r, first, count);  // c x (count r)
  s.G.resize(count * c, r);
  for (Index i = 0; i < count; ++i) s.G.middleRows(i * c, c) = Gb.middleCols(i * r, r);
  s.U = h.U;
  VectorXd m0 = VectorXd::Zero(count * c);
  if (j.contains("m0")) m0 = FieldBlocks(path, j, "m0", h.n, c, 1, first, count).reshaped();
  const MatrixXd P0 = FieldBlocks(path, j, "P0", h.n, c, c, first, count);
  try {
    return CoupledSystem(std::move(s), std::move(m0), P0);
  } catch (const Error& e) {
    throw Error(path + " (subsystems " + std::to_string(first) + ".." + std::to_string(first + count - 1) +
                "): " + e.what());
  }
}

void SaveCoupledModel(const std::string& path, const CoupledSystem& system) {
  if (!system.time_invariant()) throw Error("system: expected a time-invariant coupled system to save");
  const auto s = system.step(1);
  const Index n = system.n(), c = system.c(), d = system.d(), r = system.r();
  const fs::path p(path);
  const std::string stem = p.stem().string();
  json j;
  j["format"] = "kfx-coupled-model";
  j["n"] = n;
  j["c"] = c;
  j["d"] = d;
  j["r"] = r;
  // Packed a x (n b) blocks -> C-order (n, a, b).
  auto write = [&](const std::string& field, const MatrixXd& blocks, Index b) {
    const Index a = blocks.rows();
    std::vector<double> data(static_cast<size_t>(n * a * b));
    for (Index i = 0; i < n; ++i) {
      for (Index q = 0; q < a; ++q) {
        for (Index t = 0; t < b; ++t) data[static_cast<size_t>((i * a + q) * b + t)] = blocks(q, i * b + t);
      }
    }
    const std::string file = stem + "." + field + ".npy";
    WriteNpy((p.parent_path() / file).string(), {n, a, b}, data.data());
    j[field] = {{"npy", file}};
  };
  write("F", s->F, c);
  write("H", s->H, c);
  write("V", s->V, c);
  write("R", s->R, d);
  MatrixXd Gb(c, n * r);
  for (Index i = 0; i < n; ++i) Gb.middleCols(i * r, r) = s->G.middleRows(i * c, c);
  write("G", Gb, r);
  write("m0", Eigen::Map<const MatrixXd>(system.m0().data(), c, n), 1);
  write("P0", system.P0_blocks(), c);
  json U = json::array();
  for (Index i = 0; i < r; ++i) {
    json row = json::array();
    for (Index t = 0; t < r; ++t) row.push_back(s->U(i, t));
    U.push_back(row);
  }
  j["U"] = U;
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot open file for writing");
  out << j.dump(1) << "\n";
  if (!out) throw Error(path + ": cannot write");
}

}  // namespace kfx
