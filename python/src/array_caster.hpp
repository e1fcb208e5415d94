#pragma once
// The one conversion of array input in kfx._core (docs/python.md, "Input arrays"; docs/robustness.md,
// class 13). Every Eigen::MatrixXd, Eigen::VectorXd and kfx::TimeSeries argument of every binding (also
// inside std::optional and lists) is loaded by the type casters below, which call ToFloatArray:
//   - real numbers (float, integer, bool dtypes, and Python lists of them) become float64;
//   - complex, object, string and other dtypes raise kfx.Error (numpy would drop the imaginary part
//     with only a ComplexWarning, and the solver would answer a different problem);
//   - a numpy masked array gives NaN at its masked entries (a missing value wherever kfx reads data,
//     an invalid entry elsewhere), never its hidden data;
//   - a shape the argument cannot take (a (1, m) array for a vector, a 3-D array for a matrix) raises
//     kfx.Error stating the expected and the given shape; the C++ function then checks dimensions and
//     names its argument.
// Included by bindings.hpp, so that every translation unit of the module sees these specializations
// before any use (they replace pybind11's own Eigen casters for these three types).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Dense>
#include <string>

#include "kfx/model.hpp"

namespace kfx::python {

/// src as a C-contiguous float64 numpy array (a new one when a conversion was needed).
/// @throws kfx::Error for complex, object, string, datetime or void dtypes and for objects numpy
///         cannot read as an array of numbers. Masked entries of a numpy.ma.MaskedArray become NaN.
pybind11::array ToFloatArray(pybind11::handle src);
/// "(2, 3)": the shape of a numpy array as numpy writes it.
std::string NumpyShapeString(const pybind11::array& a);
/// Loads a float64 array into a vector (1-D, or 2-D with one column) or a matrix (2-D, or 1-D as one
/// column, as pybind11 does). @throws kfx::Error for any other shape.
/// `name` (may be empty) starts the message.
Eigen::VectorXd ArrayToVector(const pybind11::array& a, const std::string& name = "");
Eigen::MatrixXd ArrayToMatrix(const pybind11::array& a, const std::string& name = "");
/// ToFloatArray then ArrayToVector, every error naming `name` (for bindings that take py::object).
Eigen::VectorXd VectorArgument(pybind11::handle src, const std::string& name);

}  // namespace kfx::python

namespace pybind11::detail {

template <typename Type>
struct KfxEigenCaster {
  using props = EigenProps<Type>;
  PYBIND11_TYPE_CASTER(Type, props::descriptor);

  bool load(handle src, bool convert) {
    // Overload resolution's first pass (no conversion): only float64 arrays; the second pass
    // converts anything array-like, with kfx.Error for what cannot be a real array.
    if (!convert && !isinstance<array_t<double>>(src)) return false;
    if (src.is_none()) return false;  // None selects another overload or std::optional
    const array a = kfx::python::ToFloatArray(src);
    if constexpr (Type::ColsAtCompileTime == 1) {
      value = kfx::python::ArrayToVector(a);
    } else {
      value = kfx::python::ArrayToMatrix(a);
    }
    return true;
  }

  // Output as pybind11's own caster does it: a member read through a property (reference_internal) is
  // a read-only view kept alive by its owner, so `step.A[0, 0] = 5` raises instead of editing a copy
  // that is then lost; other results are numpy arrays owning a copy (or the moved data).
  static handle cast(const Type& src, return_value_policy policy, handle parent) {
    switch (policy) {
      case return_value_policy::reference_internal:
        return eigen_ref_array<props>(src, parent);
      case return_value_policy::reference:
        return eigen_ref_array<props>(src);
      default:
        return eigen_array_cast<props>(src);
    }
  }
  static handle cast(Type&& src, return_value_policy, handle) {
    return eigen_encapsulate<props>(new Type(std::move(src)));
  }
};

template <>
struct type_caster<Eigen::MatrixXd> : KfxEigenCaster<Eigen::MatrixXd> {};
template <>
struct type_caster<Eigen::VectorXd> : KfxEigenCaster<Eigen::VectorXd> {};
template <>
struct type_caster<kfx::TimeSeries> : KfxEigenCaster<kfx::TimeSeries> {};

}  // namespace pybind11::detail
