// The shared helpers of the kfx._core bindings (declared in bindings.hpp): numpy stacks of matrices to
// and from lists of Eigen matrices.
#include "bindings.hpp"
#include "kfx/error.hpp"

namespace kfx::python {

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

std::vector<Eigen::MatrixXd> Unstack(const py::array& stack, const std::string& name) {
  auto arr = py::array_t<double, py::array::forcecast>::ensure(stack);
  if (!arr || arr.ndim() != 3) throw Error(name + ": expected a (K, rows, cols) float array");
  auto a = arr.unchecked<3>();
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
    }
    ++i;
  }
  return out;
}

}  // namespace kfx::python
