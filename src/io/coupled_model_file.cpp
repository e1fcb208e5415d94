// The coupled model file of `kfx blockdiag` (include/kfx/coupled_model_file.hpp; format: docs/formats.md,
// "Coupled model files"): the header, a slice read by offset, and the writer.
#include "kfx/coupled_model_file.hpp"

#include <filesystem>
#include <string>
#include <vector>

#include "io/json_matrix.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/validation.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
namespace fs = std::filesystem;

namespace {

using detail::JsonField;
using json = detail::Json;

constexpr const char* kFormatName = "kfx-coupled-model";

// Blocks [first, first + count) of a per-subsystem field (a x b each) as packed a x (count b), or the
// inline a x b matrix (a vector of length a for `vector`) repeated.
MatrixXd FieldBlocks(const std::string& path, const json& j, const std::string& field, Index n, Index a, Index b,
                     Index first, Index count, bool vector = false) {
  if (!j.contains(field)) throw Error(path + ": missing field '" + field + "'");
  const json& v = j[field];
  const JsonField where{path, field, ""};
  if (!v.is_object() && !vector) return detail::JsonMatrix(v, where, a, b).replicate(1, count);
  if (!v.is_object()) {
    const VectorXd x = detail::JsonVector(v, where);
    if (x.size() != a) {
      where.Fail("expected a vector of length " + std::to_string(a) + ", got length " + std::to_string(x.size()));
    }
    return x.replicate(1, count);
  }
  const std::string file = detail::JsonNpyReference(v, where);
  NpyArray arr;
  try {
    // The header alone first: the file's first dimension must be the model's n (a slice of a longer or
    // shorter array is not this model's field).
    const Index rows = ReadNpySlice(file, 1, 0, 0).shape[0];
    if (rows != n) {
      where.Fail("expected " + std::to_string(n) + " subsystems (the first dimension of " + file + "), got " +
                 std::to_string(rows));
    }
    arr = ReadNpySlice(file, 0, first, count);
  } catch (const Error& e) {
    if (std::string(e.what()).find(path) == 0) throw;  // already names the file and field
    where.Fail(e.what());
  }
  const bool vector_field = b == 1;
  const bool ok = (arr.shape.size() == 3 && arr.shape[0] == count && arr.shape[1] == a && arr.shape[2] == b) ||
                  (vector_field && arr.shape.size() == 2 && arr.shape[0] == count && arr.shape[1] == a);
  if (!ok || arr.shape.empty()) {
    where.Fail("expected an array of shape (" + std::to_string(n) + ", " + std::to_string(a) + ", " +
               std::to_string(b) + ")" +
               (vector_field ? " or (" + std::to_string(n) + ", " + std::to_string(a) + ")" : "") + " in " + file);
  }
  MatrixXd m(a, count * b);
  for (Index i = 0; i < count; ++i) {
    for (Index p = 0; p < a; ++p) {
      for (Index q = 0; q < b; ++q) m(p, i * b + q) = arr.data[static_cast<size_t>((i * a + p) * b + q)];
    }
  }
  RequireFinite(where.Label() + ": " + file, m);
  return m;
}

CoupledModelHeader HeaderOf(const json& j, const std::string& path) {
  detail::CheckJsonFormat(j, path, kFormatName, /*required=*/true);
  CoupledModelHeader h;
  h.n = detail::JsonIndex(j, path, "n", 1);
  h.c = detail::JsonIndex(j, path, "c", 1);
  h.d = detail::JsonIndex(j, path, "d", 1);
  h.r = detail::JsonIndex(j, path, "r", 0);
  if (!j.contains("U")) throw Error(path + ": missing field 'U'");
  h.U = detail::JsonMatrix(j["U"], {path, "U", ""}, h.r, h.r);
  return h;
}

}  // namespace

CoupledModelHeader ReadCoupledModelHeader(const std::string& path) {
  return HeaderOf(detail::ReadJsonObject(path, kFormatName), path);
}

CoupledSystem LoadCoupledModelSlice(const std::string& path, Index first, Index count) {
  const json j = detail::ReadJsonObject(path, kFormatName);  // parsed once
  const CoupledModelHeader h = HeaderOf(j, path);
  if (first < 0 || count < 1 || first > h.n - count) {
    throw Error(path + ": slice [" + std::to_string(first) + ", " + std::to_string(first) + " + " +
                std::to_string(count) + ") is outside the model's " + std::to_string(h.n) + " subsystems");
  }
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
  if (j.contains("m0")) m0 = FieldBlocks(path, j, "m0", h.n, c, 1, first, count, /*vector=*/true).reshaped();
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
  j["format"] = kFormatName;
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
  AtomicOutputFile out(path);  // the JSON last, atomically: it is what makes the .npy files a model
  out.stream() << j.dump(1) << "\n";
  out.Commit();
}

}  // namespace kfx
