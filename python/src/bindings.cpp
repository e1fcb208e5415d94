// The shared helpers of the kfx._core bindings (declared in bindings.hpp and array_caster.hpp): the one
// conversion of array input, numpy stacks of matrices to and from lists of Eigen matrices.
#include <limits>
#if defined(__GLIBC__)
#include <malloc.h>  // malloc_trim
#endif

#include "bindings.hpp"
#include "kfx/error.hpp"

namespace kfx::python {

std::string NumpyShapeString(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

py::array ToFloatArray(py::handle src) {
  const py::module_ np = py::module_::import("numpy");
  py::object obj = py::reinterpret_borrow<py::object>(src);
  auto check_kind = [](const py::object& o) {
    const py::dtype dt = o.attr("dtype").cast<py::dtype>();
    const char kind = dt.kind();
    if (kind != 'f' && kind != 'i' && kind != 'u' && kind != 'b') {
      throw Error("expected an array of real numbers, got dtype " + py::str(py::object(dt)).cast<std::string>() +
                  (kind == 'c' ? " (kfx does not drop imaginary parts: pass .real if that is meant)" : ""));
    }
  };
  if (py::isinstance(obj, np.attr("ma").attr("MaskedArray"))) {
    check_kind(obj);  // masked entries are missing values: NaN, never the hidden data
    obj = obj.attr("astype")(np.attr("float64")).attr("filled")(std::numeric_limits<double>::quiet_NaN());
  }
  if (!py::isinstance<py::array>(obj)) {
    try {
      obj = np.attr("asarray")(obj);
    } catch (py::error_already_set& e) {
      throw Error("expected an array of real numbers, got " +
                  py::str(py::object(py::type::of(src))).cast<std::string>() + " (" +
                  std::string(e.what()).substr(0, 200) + ")");
    }
  }
  check_kind(obj);
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
}

Eigen::VectorXd ArrayToVector(const py::array& a, const std::string& name) {
  const std::string who = name.empty() ? "" : name + ": ";
  const auto f = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  if (f.ndim() == 1 || (f.ndim() == 2 && f.shape(1) == 1)) {
    return Eigen::Map<const Eigen::VectorXd>(f.data(), static_cast<Eigen::Index>(f.shape(0)));
  }
  throw Error(who + "expected a 1-D array (a vector), got shape " + NumpyShapeString(f));
}

Eigen::MatrixXd ArrayToMatrix(const py::array& a, const std::string& name) {
  const std::string who = name.empty() ? "" : name + ": ";
  const auto f = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  if (f.ndim() == 2) {
    return Eigen::Map<const RowMajor>(f.data(), static_cast<Eigen::Index>(f.shape(0)),
                                      static_cast<Eigen::Index>(f.shape(1)));
  }
  if (f.ndim() == 1) return Eigen::Map<const Eigen::VectorXd>(f.data(), static_cast<Eigen::Index>(f.shape(0)));
  throw Error(who + "expected a 2-D array (a matrix), got shape " + NumpyShapeString(f));
}

Eigen::VectorXd VectorArgument(py::handle src, const std::string& name) {
  try {
    return ArrayToVector(ToFloatArray(src), name);
  } catch (const Error& e) {
    const std::string what = e.what();
    if (what.rfind(name + ": ", 0) == 0) throw;
    throw Error(name + ": " + what);
  }
}

py::array_t<double> Stack(const std::vector<Eigen::MatrixXd>& matrices, size_t begin) {
  const size_t K = matrices.size() > begin ? matrices.size() - begin : 0;
  const Eigen::Index r = K ? matrices[begin].rows() : 0, c = K ? matrices[begin].cols() : 0;
  py::array_t<double> out({static_cast<py::ssize_t>(K), static_cast<py::ssize_t>(r), static_cast<py::ssize_t>(c)});
  auto a = out.mutable_unchecked<3>();
  for (size_t k = 0; k < K; ++k) {
    const Eigen::MatrixXd& M = matrices[begin + k];
    if (M.rows() != r || M.cols() != c) throw Error("internal: matrices of different shapes in a stack");
    for (Eigen::Index i = 0; i < r; ++i)
      for (Eigen::Index j = 0; j < c; ++j) a(static_cast<py::ssize_t>(k), i, j) = M(i, j);
  }
  return out;
}

py::object TakeStack(std::vector<Eigen::MatrixXd>* matrices, size_t begin) {
  std::vector<Eigen::MatrixXd>& v = *matrices;
  const size_t K = v.size() > begin ? v.size() - begin : 0;
  const Eigen::Index r = K ? v[begin].rows() : 0, c = K ? v[begin].cols() : 0;
  py::array_t<double> out({static_cast<py::ssize_t>(K), static_cast<py::ssize_t>(r), static_cast<py::ssize_t>(c)});
  double* data = out.mutable_data();
  {
    py::gil_scoped_release release;  // a copy into memory no other thread sees yet
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
#if defined(__GLIBC__)
    const size_t bytes = static_cast<size_t>(r * c) * sizeof(double);
    size_t freed = 0;
#endif
    for (size_t k = 0; k < K; ++k) {
      Eigen::MatrixXd& M = v[begin + k];
      KFX_ASSERT(M.rows() == r && M.cols() == c);
      Eigen::Map<RowMajor>(data + static_cast<Eigen::Index>(k) * r * c, r, c) = M;
      Eigen::MatrixXd().swap(M);
#if defined(__GLIBC__)
      // Matrices below glibc's mmap threshold (32 MiB at most) are freed into the heap, where free()
      // returns only its top to the system: hand the freed pages back as the stack fills.
      if ((freed += bytes) >= (64u << 20)) {
        malloc_trim(0);
        freed = 0;
      }
#endif
    }
  }
  std::vector<Eigen::MatrixXd>().swap(v);
  out.attr("flags").attr("writeable") = false;
  return std::move(out);
}

std::vector<Eigen::MatrixXd> Unstack(const py::array& stack, const std::string& name) {
  py::array arr;
  try {
    arr = ToFloatArray(stack);
  } catch (const Error& e) {
    throw Error(name + ": " + e.what());
  }
  if (arr.ndim() != 3)
    throw Error(name + ": expected a (K, rows, cols) float array, got shape " + NumpyShapeString(arr));
  auto a = arr.unchecked<double, 3>();
  std::vector<Eigen::MatrixXd> out(static_cast<size_t>(a.shape(0)), Eigen::MatrixXd(a.shape(1), a.shape(2)));
  for (py::ssize_t k = 0; k < a.shape(0); ++k)
    for (py::ssize_t i = 0; i < a.shape(1); ++i)
      for (py::ssize_t j = 0; j < a.shape(2); ++j) out[static_cast<size_t>(k)](i, j) = a(k, i, j);
  return out;
}

std::vector<Eigen::MatrixXd> MatrixList(const py::object& seq, const std::string& name) {
  if (py::isinstance<py::array>(seq) && seq.cast<py::array>().ndim() == 3) return Unstack(seq, name);
  std::vector<Eigen::MatrixXd> out;
  size_t i = 0;
  for (const auto& item : seq) {
    try {
      out.push_back(item.cast<Eigen::MatrixXd>());
    } catch (const py::cast_error&) {
      throw Error(name + "[" + std::to_string(i) + "]: expected a 2-D float array");
    } catch (const Error& e) {
      throw Error(name + "[" + std::to_string(i) + "]: " + e.what());
    }
    ++i;
  }
  return out;
}

}  // namespace kfx::python
