#pragma once
// The coupled model file of `kfx blockdiag` (docs/formats.md, "Coupled model files"): a coupled system
// of n subsystems (paper 004, include/kfx/block_diagonal.hpp) whose per-subsystem matrices may sit in
// .npy files that each process reads only its slice of.
#include <Eigen/Dense>
#include <string>

#include "kfx/block_diagonal.hpp"

namespace kfx {

/// A coupled model file (docs/formats.md, "Coupled model"): JSON with n, c, d, r and the matrices F,
/// H, V, R, G, U, m0, P0, each either inline (the same for every subsystem) or {"npy": "file.npy"} with
/// a leading dimension n (one block per subsystem; read by offset, only the slice's part).
struct CoupledModelHeader {
  Eigen::Index n = 0, c = 0, d = 0, r = 0;
  Eigen::MatrixXd U;  ///< r x r, always inline
};
/// @throws kfx::Error naming the file and the field.
CoupledModelHeader ReadCoupledModelHeader(const std::string& path);
/// The slice [first, first + count) of a coupled model file, reading only that part of per-subsystem .npy
/// files. @throws kfx::Error naming the file and the field.
CoupledSystem LoadCoupledModelSlice(const std::string& path, Eigen::Index first, Eigen::Index count);
/// Writes a coupled model file (per-subsystem fields as .npy files <stem>.<field>.npy beside it).
void SaveCoupledModel(const std::string& path, const CoupledSystem& system);

}  // namespace kfx
