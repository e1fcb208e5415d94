// The kfx model file: JSON with matrices inline or in .npy files beside it.
// Format: docs/formats.md, "Model files". Every error names the file and the field.
#include <charconv>
#include <climits>
#include <cstring>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/io_internal.hpp"
#include "io/json_matrix.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

constexpr const char* kFormatName = "kfx-model";
constexpr int kFormatVersion = 1;
// Upper bound on the doubles a loaded time-varying model may hold (8 GiB): a horizon of 10^9 in a
// ten-line file must give an error, not an out-of-memory kill. Each step also costs a fixed
// overhead (shared pointer, six matrix headers), counted as kStepOverhead doubles.
constexpr std::int64_t kMaxModelEntries = std::int64_t{1} << 30;
constexpr std::int64_t kStepOverhead = 64;

// A matrix-valued field: one matrix, or one per step (time-varying).
struct MatrixField {
  bool present = false;
  bool time_varying = false;
  std::vector<Eigen::MatrixXd> values;  // one (constant) or T (time-varying)

  Eigen::Index rows() const { return values.front().rows(); }
  Eigen::Index cols() const { return values.front().cols(); }
  const Eigen::MatrixXd& at(std::size_t k) const { return values[time_varying ? k : 0]; }
};

// The optional fields of issue 22: known-input matrices G, D and the cross-covariance S.
struct Extras {
  MatrixField G, D, S;
};

class ModelFileReader {
 public:
  explicit ModelFileReader(const std::string& path) : path_(path) {}

  Model Load() {
    const Json root = detail::ReadJsonObject(path_, kFormatName);
    CheckHeader(root);

    MatrixField A = ReadMatrixField(root, "A", true, true);
    const Eigen::Index n = A.rows();
    for (std::size_t k = 0; k < A.values.size(); ++k) {
      if (A.values[k].rows() != A.values[k].cols()) {
        FailField("A", StepLabel(A, k) + "expected a square matrix, got " + ShapeString(A.values[k]));
      }
    }
    MatrixField C = ReadMatrixField(root, "C", true, true);
    if (C.cols() != n) {
      FailField("C", "expected a matrix with " + std::to_string(n) + " columns (the state dimension, from 'A'), got " +
                         ShapeString(C.values.front()));
    }
    const Eigen::Index m = C.rows();
    MatrixField R = ReadMatrixField(root, "R", true, true);
    RequireFieldShape("R", R, m, m);
    MatrixField B = ReadMatrixField(root, "B", false, true);
    MatrixField U = ReadMatrixField(root, "U", false, true);
    if (B.present != U.present)
      FailField(B.present ? "U" : "B", B.present ? "required with field 'B'" : "required with field 'U'");
    if (B.present) {
      if (B.rows() != n) {
        FailField("B", "expected a matrix with " + std::to_string(n) + " rows (the state dimension, from 'A'), got " +
                           ShapeString(B.values.front()));
      }
      RequireFieldShape("U", U, B.cols(), B.cols());
    }
    MatrixField Q = ReadMatrixField(root, "Q", false, true);
    if (!Q.present && !B.present) Fail("missing field 'Q' (or the noise input 'B' with its covariance 'U')");
    if (Q.present) RequireFieldShape("Q", Q, n, n);
    // Known input g_k (x_k gets G g_k, y_k gets D g_k) and the cross-covariance S (issue 22), all optional.
    Extras extras{ReadMatrixField(root, "G", false, true), ReadMatrixField(root, "D", false, true),
                  ReadMatrixField(root, "S", false, true)};
    if (extras.G.present && extras.G.rows() != n) {
      FailField("G", "expected a matrix with " + std::to_string(n) + " rows (the state dimension, from 'A'), got " +
                         ShapeString(extras.G.values.front()));
    }
    if (extras.D.present) RequireFieldShape("D", extras.D, m, extras.G.present ? extras.G.cols() : extras.D.cols());
    if (extras.S.present) RequireFieldShape("S", extras.S, n, m);

    const Eigen::VectorXd m0 = ReadVectorField(root, "m0");
    if (m0.size() != n) {
      FailField("m0", "expected a vector of length " + std::to_string(n) + " (the state dimension), got length " +
                          std::to_string(m0.size()));
    }
    MatrixField P0 = ReadMatrixField(root, "P0", true, false);
    RequireFieldShape("P0", P0, n, n);

    // The horizon: agreed by every time-varying field and by "horizon".
    long long steps = -1;
    std::string steps_from;
    for (const auto& f :
         {std::make_pair("A", &A), std::make_pair("C", &C), std::make_pair("Q", &Q), std::make_pair("R", &R),
          std::make_pair("B", &B), std::make_pair("U", &U), std::make_pair("G", &extras.G),
          std::make_pair("D", &extras.D), std::make_pair("S", &extras.S)}) {
      const MatrixField& field = *f.second;
      if (!field.present || !field.time_varying) continue;
      const auto t = static_cast<long long>(field.values.size());
      if (steps < 0) {
        steps = t;
        steps_from = f.first;
      } else if (t != steps) {
        FailField(f.first, "expected " + std::to_string(steps) + " steps (as field '" + steps_from + "'), got " +
                               std::to_string(t));
      }
    }
    if (root.contains("horizon")) {
      const Json& h = root["horizon"];
      if (!h.is_number_integer() || h.get<long long>() < 1 || h.get<long long>() > INT_MAX) {
        FailField("horizon", "expected a positive integer number of steps, got " + detail::JsonBrief(h));
      }
      const long long horizon = h.get<long long>();
      if (steps >= 0 && horizon != steps) {
        FailField("horizon", "expected " + std::to_string(steps) + " (the number of steps of the time-varying field '" +
                                 steps_from + "'), got " + std::to_string(horizon));
      }
      steps = horizon;
    }
    if (steps > INT_MAX) Fail("a time-varying model of " + std::to_string(steps) + " steps is too long");

    try {
      if (steps < 0) return Model(MakeStepAt(A, C, Q, R, B, U, extras, 0), m0, P0.values.front());
      std::int64_t per_step = kStepOverhead;
      for (const MatrixField* f : {&A, &C, &Q, &R, &B, &U, &extras.G, &extras.D, &extras.S}) {
        if (f->present) per_step += static_cast<std::int64_t>(f->rows() * f->cols());
      }
      if (B.present && !Q.present) per_step += static_cast<std::int64_t>(n * n);
      if (per_step > kMaxModelEntries / steps) {
        Fail(std::string(root.contains("horizon") ? "field 'horizon': " : "") + "a time-varying model of " +
             std::to_string(steps) + " steps with " + std::to_string(per_step) +
             " numbers per step is too large to hold in memory (limit " + std::to_string(kMaxModelEntries) +
             " numbers)");
      }
      std::vector<ModelStep> sequence;
      sequence.reserve(static_cast<std::size_t>(steps));
      for (long long k = 0; k < steps; ++k) {
        try {
          sequence.push_back(MakeStepAt(A, C, Q, R, B, U, extras, static_cast<std::size_t>(k)));
        } catch (const Error& e) {
          throw Error("step " + std::to_string(k + 1) + ": " + e.what());
        }
      }
      return Model(std::move(sequence), m0, P0.values.front());
    } catch (const Error& e) {
      const std::string what = e.what();
      if (what.compare(0, path_.size() + 2, path_ + ": ") == 0) throw;
      Fail(NameField(what));
    }
  }

 private:
  [[noreturn]] void Fail(const std::string& what) const { throw Error(path_ + ": " + what); }
  [[noreturn]] void FailField(const std::string& field, const std::string& what) const {
    Fail("field '" + field + "': " + what);
  }

  // Rewrites a validation message "[step k: ]X: what" of the Model (X a field name) as
  // "field 'X': [step k: ]what", the form of this reader's own messages.
  static std::string NameField(const std::string& what) {
    std::string step;
    std::string rest = what;
    if (rest.compare(0, 5, "step ") == 0) {
      const std::size_t colon = rest.find(": ");
      if (colon == std::string::npos) return what;
      step = rest.substr(0, colon + 2);
      rest = rest.substr(colon + 2);
    }
    for (const char* name : {"A", "C", "Q", "R", "B", "U", "G", "D", "S", "m0", "P0"}) {
      const std::string prefix = std::string(name) + ": ";
      if (rest.compare(0, prefix.size(), prefix) == 0) {
        return "field '" + std::string(name) + "': " + step + rest.substr(prefix.size());
      }
      const std::string qualified = std::string(name) + " (";  // "S (the joint covariance ...): ..."
      if (rest.compare(0, qualified.size(), qualified) == 0) {
        return "field '" + std::string(name) + "': " + step + rest.substr(std::string(name).size() + 1);
      }
    }
    return what;
  }

  static std::string StepLabel(const MatrixField& f, std::size_t k) {
    return f.time_varying ? "step " + std::to_string(k + 1) + ": " : std::string();
  }

  void CheckHeader(const Json& root) const {
    detail::CheckJsonFormat(root, path_, kFormatName, /*required=*/false);
    detail::CheckJsonVersion(root, path_, kFormatVersion);
    for (const char* key : {"name", "description"}) {
      if (root.contains(key) && !root[key].is_string()) {
        FailField(key, "expected a string, got " + detail::JsonBrief(root[key]));
      }
    }
  }

  void RequireFieldShape(const char* name, const MatrixField& f, Eigen::Index rows, Eigen::Index cols) const {
    for (std::size_t k = 0; k < f.values.size(); ++k) {
      if (f.values[k].rows() != rows || f.values[k].cols() != cols) {
        FailField(name, StepLabel(f, k) + "expected a " + ShapeString(rows, cols) + " matrix, got " +
                            ShapeString(f.values[k]));
      }
    }
  }

  NpyArray ReadReference(const Json& v, const std::string& name) const {
    const std::string file = detail::JsonNpyReference(v, {path_, name, ""});
    try {
      return ReadNpy(file);
    } catch (const Error& e) {
      FailField(name, e.what());
    }
  }

  MatrixField ReadMatrixField(const Json& root, const char* name, bool required, bool allow_time) const {
    MatrixField f;
    if (!root.contains(name)) {
      if (required) Fail(std::string("missing field '") + name + "'");
      return f;
    }
    f.present = true;
    const Json& v = root[name];
    if (v.is_object()) {
      const NpyArray a = ReadReference(v, name);
      const std::size_t rank = a.shape.size();
      if (rank == 0) {
        f.values.push_back(Eigen::MatrixXd::Constant(1, 1, a.data[0]));
      } else if (rank == 2 || (rank == 3 && allow_time)) {
        const std::int64_t steps = rank == 3 ? a.shape[0] : 1;
        const auto rows = static_cast<Eigen::Index>(a.shape[rank - 2]);
        const auto cols = static_cast<Eigen::Index>(a.shape[rank - 1]);
        if (rank == 3 && (steps == 0 || steps > INT_MAX || rows == 0 || cols == 0)) {
          FailField(name,
                    "expected a time-varying field of shape (T, rows, cols) with 1 <= T <= " + std::to_string(INT_MAX) +
                        " and non-empty matrices, got shape " + detail::NpyShapeText(a.shape));
        }
        f.time_varying = rank == 3;
        const double* p = a.data.data();
        for (std::int64_t k = 0; k < steps; ++k) {
          Eigen::MatrixXd m(rows, cols);
          for (Eigen::Index i = 0; i < rows; ++i)
            for (Eigen::Index j = 0; j < cols; ++j) m(i, j) = *p++;
          f.values.push_back(std::move(m));
        }
      } else {
        FailField(name, std::string("expected a 2-D array") +
                            (allow_time ? " (or 3-D (T, rows, cols) for a time-varying field)" : "") + ", got shape " +
                            detail::NpyShapeText(a.shape) + " in " + v["npy"].get<std::string>());
      }
      return f;
    }
    const int depth = detail::JsonListDepth(v);
    if (depth == 3 && allow_time) {
      f.time_varying = true;
      for (std::size_t k = 0; k < v.size(); ++k) {
        const std::string where = "step " + std::to_string(k + 1) + ": ";
        f.values.push_back(detail::JsonMatrix(v[k], {path_, name, where}));
        if (k > 0 && (f.values[k].rows() != f.values[0].rows() || f.values[k].cols() != f.values[0].cols())) {
          FailField(name, where + "expected a " + ShapeString(f.values[0]) + " matrix (as step 1), got " +
                              ShapeString(f.values[k]));
        }
      }
    } else if (depth <= 2) {
      f.values.push_back(detail::JsonMatrix(v, {path_, name, ""}));
    } else {
      FailField(name,
                std::string("expected a matrix (a list of rows)") +
                    (allow_time ? " or a list of matrices (time-varying)" : " (this field cannot be time-varying)") +
                    ", got lists nested " + std::to_string(depth) + " deep");
    }
    return f;
  }

  Eigen::VectorXd ReadVectorField(const Json& root, const char* name) const {
    if (!root.contains(name)) Fail(std::string("missing field '") + name + "'");
    const Json& v = root[name];
    if (v.is_object()) {
      const NpyArray a = ReadReference(v, name);
      const bool column = a.shape.size() == 2 && a.shape[1] == 1;
      if (a.shape.size() > 1 && !column) {
        FailField(name, "expected a vector (a 1-D array), got shape " + detail::NpyShapeText(a.shape));
      }
      return Eigen::Map<const Eigen::VectorXd>(a.data.data(), static_cast<Eigen::Index>(a.data.size()));
    }
    return detail::JsonVector(v, {path_, name, ""});
  }

  static ModelStep MakeStepAt(const MatrixField& A, const MatrixField& C, const MatrixField& Q, const MatrixField& R,
                              const MatrixField& B, const MatrixField& U, const Extras& extras, std::size_t k) {
    ModelStep s;
    if (!B.present) {
      s = MakeStep(A.at(k), C.at(k), Q.at(k), R.at(k));
    } else if (!Q.present) {
      s = MakeStepWithNoiseInput(A.at(k), B.at(k), U.at(k), C.at(k), R.at(k));
    } else {  // Q given with B and U: kept as written (the Model checks Q = B U B^T).
      s = MakeStep(A.at(k), C.at(k), Q.at(k), R.at(k));
      s.B = B.at(k);
      s.U = U.at(k);
    }
    if (extras.G.present) s.G = extras.G.at(k);
    if (extras.D.present) s.D = extras.D.at(k);
    if (extras.S.present) s.S = extras.S.at(k);
    return s;
  }

  std::string path_;
};

// ----- Writing ----------------------------------------------------------------------------------

bool BitwiseEqual(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0);
}

// Shortest text that reads back to the same double, always with a '.' or an exponent so that JSON
// readers take it as a floating-point number (nlohmann reads "-0" as the integer 0, losing the sign).
std::string NumberText(double x) {
  char buf[64];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, x);
  std::string s(buf, r.ptr);
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

std::string RowText(const Eigen::MatrixXd& m, Eigen::Index i) {
  std::string s = "[";
  for (Eigen::Index j = 0; j < m.cols(); ++j) s += (j > 0 ? ", " : "") + NumberText(m(i, j));
  return s + "]";
}

// "[[1.0, 2.0],\n<indent> [3.0, 4.0]]", continuation rows aligned under the first.
std::string MatrixText(const Eigen::MatrixXd& m, const std::string& indent) {
  std::string s = "[";
  for (Eigen::Index i = 0; i < m.rows(); ++i) s += (i > 0 ? ",\n" + indent + " " : "") + RowText(m, i);
  return s + "]";
}

class ModelFileWriter {
 public:
  ModelFileWriter(const std::string& path, const SaveModelOptions& options) : path_(path), options_(options) {
    const fs::path p(path);
    dir_ = p.parent_path();
    stem_ = p.extension() == ".json" ? p.stem().string() : p.filename().string();
  }

  void Save(const Model& model) {
    std::vector<StepPtr> steps;
    int horizon = -1;
    try {
      if (model.time_invariant()) {
        steps.push_back(model.step(1));
      } else {
        horizon = model.ResolveSteps(options_.steps, "SaveModelOptions::steps");
        if (horizon < 1)
          throw Error("SaveModelOptions::steps: expected at least one step, got " + std::to_string(horizon));
        steps.reserve(static_cast<std::size_t>(horizon));
        for (int k = 1; k <= horizon; ++k) steps.push_back(model.step(k));
      }
    } catch (const Error& e) {
      throw Error(path_ + ": " + e.what());
    }

    const auto has_input = [](const StepPtr& s) { return s->B.size() > 0 || s->U.size() > 0; };
    const bool with_input = has_input(steps.front());
    for (std::size_t k = 0; k < steps.size(); ++k) {
      if (has_input(steps[k]) != with_input) {
        throw Error(path_ + ": cannot save a model whose steps mix a noise input (B, U) with a plain Q (step " +
                    std::to_string(k + 1) + ")");
      }
      if (with_input && steps[k]->B.cols() != steps.front()->B.cols()) {
        throw Error(path_ + ": cannot save a model whose noise input B changes width (step " + std::to_string(k + 1) +
                    ": " + ShapeString(steps[k]->B) + ", step 1: " + ShapeString(steps.front()->B) + ")");
      }
    }
    // With a noise input, Q is written only when it is not exactly what loading recomputes.
    bool write_q = !with_input;
    for (std::size_t k = 0; k < steps.size() && !write_q; ++k) {
      const ModelStep& s = *steps[k];
      write_q = !BitwiseEqual(MakeStepWithNoiseInput(s.A, s.B, s.U, s.C, s.R).Q, s.Q);
    }

    std::string json = "{\n";
    json += "  \"format\": \"" + std::string(kFormatName) + "\",\n";
    json += "  \"version\": " + std::to_string(kFormatVersion) + ",\n";
#ifdef KFX_VERSION
    json += "  \"generator\": \"kfx " KFX_VERSION "\",\n";
#endif
    if (horizon >= 0) json += "  \"horizon\": " + std::to_string(horizon) + ",\n";
    AddField(&json, "A", steps, [](const ModelStep& s) -> const Eigen::MatrixXd& { return s.A; });
    AddField(&json, "C", steps, [](const ModelStep& s) -> const Eigen::MatrixXd& { return s.C; });
    if (write_q) AddField(&json, "Q", steps, [](const ModelStep& s) -> const Eigen::MatrixXd& { return s.Q; });
    AddField(&json, "R", steps, [](const ModelStep& s) -> const Eigen::MatrixXd& { return s.R; });
    if (with_input) {
      AddField(&json, "B", steps, [](const ModelStep& s) -> const Eigen::MatrixXd& { return s.B; });
      AddField(&json, "U", steps, [](const ModelStep& s) -> const Eigen::MatrixXd& { return s.U; });
    }
    AddExtras(&json, steps, model.input_dim());
    // m0 and P0.
    const Eigen::VectorXd& m0 = model.m0();
    if (Inline(m0.size())) {
      json += "  \"m0\": " + RowText(m0.transpose(), 0) + ",\n";
    } else {
      WriteNpyVector(NpyPath("m0"), m0);
      json += "  \"m0\": " + Reference("m0") + ",\n";
    }
    AddMatrix(&json, "P0", model.P0());
    json.erase(json.size() - 2);  // the last ",\n"
    json += "\n}\n";

    AtomicOutputFile file(path_);
    file.stream() << json;
    file.Commit();
  }

 private:
  bool Inline(std::int64_t entries) const { return entries <= options_.inline_max_entries; }
  std::string FileName(const std::string& field) const { return stem_ + "." + field + ".npy"; }
  std::string NpyPath(const std::string& field) const { return (dir_ / FileName(field)).string(); }
  std::string Reference(const std::string& field) const { return "{\"npy\": " + Json(FileName(field)).dump() + "}"; }

  void AddMatrix(std::string* json, const std::string& name, const Eigen::MatrixXd& m) const {
    const std::string prefix = "  \"" + name + "\": ";
    if (Inline(static_cast<std::int64_t>(m.size())) && m.rows() > 0 && m.cols() > 0) {
      *json += prefix + MatrixText(m, std::string(prefix.size(), ' ')) + ",\n";
    } else {
      WriteNpyMatrix(NpyPath(name), m);
      *json += prefix + Reference(name) + ",\n";
    }
  }

  // G, D and S (issue 22), each written when some step has it; a step without it gets zeros of the
  // same shape (which mean the same: no input through that matrix, no cross-covariance).
  void AddExtras(std::string* json, const std::vector<StepPtr>& steps, Eigen::Index q) const {
    const Eigen::Index n = steps.front()->A.rows(), m = steps.front()->C.rows();
    const auto add = [&](const char* name, Eigen::MatrixXd ModelStep::*member, Eigen::Index rows, Eigen::Index cols) {
      bool any = false;
      for (const StepPtr& s : steps) any = any || ((*s).*member).size() > 0;
      if (!any || cols == 0) return;
      std::vector<StepPtr> view;  // only the one matrix of each step, zeros where absent
      for (const StepPtr& s : steps) {
        ModelStep f;
        f.*member = ((*s).*member).size() > 0 ? ((*s).*member) : Eigen::MatrixXd::Zero(rows, cols);
        view.push_back(std::make_shared<const ModelStep>(std::move(f)));
      }
      AddField(json, name, view, [member](const ModelStep& s) -> const Eigen::MatrixXd& { return s.*member; });
    };
    add("G", &ModelStep::G, n, q);
    add("D", &ModelStep::D, m, q);
    add("S", &ModelStep::S, n, m);
  }

  template <typename Get>
  void AddField(std::string* json, const std::string& name, const std::vector<StepPtr>& steps, Get get) const {
    const Eigen::MatrixXd& first = get(*steps.front());
    bool constant = true;
    for (const StepPtr& s : steps) constant = constant && BitwiseEqual(get(*s), first);
    if (constant) {
      AddMatrix(json, name, first);
      return;
    }
    const auto T = static_cast<std::int64_t>(steps.size());
    const std::int64_t r = first.rows(), c = first.cols();
    const std::string prefix = "  \"" + name + "\": ";
    if (Inline(T * r * c) && r > 0 && c > 0) {
      *json += prefix + "[\n";
      for (std::size_t k = 0; k < steps.size(); ++k) {
        *json += "    " + MatrixText(get(*steps[k]), "    ") + (k + 1 < steps.size() ? ",\n" : "\n");
      }
      *json += "  ],\n";
      return;
    }
    std::vector<double> data;
    data.reserve(static_cast<std::size_t>(T * r * c));
    for (const StepPtr& s : steps) {
      const Eigen::MatrixXd& m = get(*s);
      for (Eigen::Index i = 0; i < m.rows(); ++i)
        for (Eigen::Index j = 0; j < m.cols(); ++j) data.push_back(m(i, j));
    }
    WriteNpy(NpyPath(name), {T, r, c}, data.data());
    *json += prefix + Reference(name) + ",\n";
  }

  std::string path_;
  SaveModelOptions options_;
  fs::path dir_;
  std::string stem_;
};

}  // namespace

Model LoadModel(const std::string& path) { return ModelFileReader(path).Load(); }

void SaveModel(const std::string& path, const Model& model, const SaveModelOptions& options) {
  ModelFileWriter(path, options).Save(model);
}

}  // namespace kfx
