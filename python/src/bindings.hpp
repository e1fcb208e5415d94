#pragma once
// The declarations shared by the translation units of the kfx._core module: the helpers (Stack,
// Unstack, MatrixList, OrEmpty; defined in bindings.cpp) and one Bind function per header group,
// which module.cpp calls in layer order. Conventions (docs/python.md): numpy float64 in and out,
// time-major sequences (T, n), stacks of matrices as (K, rows, cols); kfx::Error -> kfx.Error (a
// ValueError), kfx::NumericalError -> kfx.NumericalError (an ArithmeticError).
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

// The one array conversion (its casters replace pybind11's Eigen casters in every binding).
#include "array_caster.hpp"

namespace kfx::python {

namespace py = pybind11;

/// A (K, rows, cols) float64 array of K matrices of one shape, from index `begin` on.
py::array_t<double> Stack(const std::vector<Eigen::MatrixXd>& matrices, size_t begin = 0);
/// Stack, built once: moves the matrices from index `begin` on into a new read-only (K, rows, cols) array,
/// freeing each as it is copied (peak memory one stack plus one matrix), and clears `matrices` (none: a
/// (0, 0, 0) array). For results whose property returns the same array on every access.
py::object TakeStack(std::vector<Eigen::MatrixXd>* matrices, size_t begin = 0);
/// K matrices from a (K, rows, cols) array (any memory order). @throws kfx::Error naming `name`.
std::vector<Eigen::MatrixXd> Unstack(const py::array& stack, const std::string& name);
/// A list of matrices from a Python sequence of 2-D arrays or a (K, rows, cols) array.
std::vector<Eigen::MatrixXd> MatrixList(const py::object& seq, const std::string& name);
/// An empty matrix for None.
inline Eigen::MatrixXd OrEmpty(const std::optional<Eigen::MatrixXd>& m) { return m ? *m : Eigen::MatrixXd(); }

// One per header group, each in bind_<group>.cpp (module.cpp registers the exceptions and kfx.Summary).
void BindRiccati(py::module_& m);               // riccati.hpp
void BindModel(py::module_& m);                 // model.hpp, simulation.hpp, discretize.hpp
void BindPerformance(py::module_& m);           // linear_filter.hpp, performance.hpp
void BindKalmanFilter(py::module_& m);          // kalman_filter.hpp: functions
void BindFilterPyKalmanFilter(py::module_& m);  // kalman_filter.hpp: the class kfx.KalmanFilter
void BindSubspaceFilter(py::module_& m);        // 000: subspace_filter.hpp, damped_wave.hpp
void BindReducedOrder(py::module_& m);          // 001: reduced_order.hpp, spring_mass_chain.hpp
void BindMismatch(py::module_& m);              // 002: mismatch.hpp
void BindContinuous(py::module_& m);            // 003: continuous.hpp, sampling_convergence.hpp
void BindBlockDiagonal(py::module_& m);         // 004: block_diagonal.hpp
void BindReproduce(py::module_& m);             // reproduce.hpp

}  // namespace kfx::python
