#pragma once
// Shared helpers of the two translation units of the kfx._core module (bind_core.cpp: models,
// filters, solvers, the exact-performance engine, reproduce; bind_papers.cpp: the paper methods).
// Conventions (docs/python.md): numpy float64 in and out, time-major sequences (T, n), stacks of
// matrices as (K, rows, cols); kfx::Error -> kfx.Error (a ValueError), kfx::NumericalError ->
// kfx.NumericalError (an ArithmeticError).
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

namespace kfx::python {

namespace py = pybind11;

/// A (K, rows, cols) float64 array of K matrices of one shape, from index `begin` on.
py::array_t<double> Stack(const std::vector<Eigen::MatrixXd>& matrices, size_t begin = 0);
/// K matrices from a (K, rows, cols) array (any memory order). @throws kfx::Error naming `name`.
std::vector<Eigen::MatrixXd> Unstack(const py::array& stack, const std::string& name);
/// A list of matrices from a Python sequence of 2-D arrays or a (K, rows, cols) array.
std::vector<Eigen::MatrixXd> MatrixList(const py::object& seq, const std::string& name);
/// An empty matrix for None.
inline Eigen::MatrixXd OrEmpty(const std::optional<Eigen::MatrixXd>& m) { return m ? *m : Eigen::MatrixXd(); }

void BindPapers(py::module_& m);

}  // namespace kfx::python
