// The worked example's files (README, "Every method on your own model"): the damped wave equation of
// paper 000 on a fine P1 mesh (the true model) and a nested coarse mesh, from kfx::BuildDampedWave.
//   kfx_example_wave OUT_DIR [FINE_NODES [COARSE_NODES]]      (defaults 31 and 3; (fine+1) = j (coarse+1))
// writes OUT_DIR/fine.json (x = (z, v) on the fine nodes, n = 2 FINE_NODES, prior the stationary state
// covariance), coarse.json (the coarse Galerkin model, its stationary prior), prolongation.npy (coarse ->
// fine, 2 FINE x 2 COARSE: the basis of the coarse space), gram.npy (W = blkdiag(stiffness, mass), the
// H_0^1 x L^2 inner product) and gram_position.npy (blkdiag(stiffness, 0): the error of the position).
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>

#include "kfx/damped_wave.hpp"
#include "kfx/io.hpp"
#include "kfx/riccati.hpp"

namespace {

kfx::Model StationaryModel(const kfx::ModelStep& step) {
  const kfx::LyapunovSolution s = kfx::SolveDiscreteLyapunov(step.A, step.Q);
  s.summary.RequireOk();
  return kfx::Model(step, Eigen::VectorXd::Zero(step.state_dim()), 0.5 * (s.X + s.X.transpose()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: %s OUT_DIR [FINE_NODES [COARSE_NODES]]\n", argv[0]);
    return 2;
  }
  try {
    const std::string dir = argv[1];
    kfx::DampedWaveOptions o;
    o.fine_nodes = argc > 2 ? std::stoi(argv[2]) : 31;
    o.coarse_nodes = argc > 3 ? std::stoi(argv[3]) : 3;
    const kfx::DampedWaveProblem p = kfx::BuildDampedWave(o);
    std::filesystem::create_directories(dir);
    kfx::SaveModel(dir + "/fine.json", StationaryModel(p.fine.step));
    kfx::SaveModel(dir + "/coarse.json", StationaryModel(p.coarse.step));
    kfx::WriteNpyMatrix(dir + "/prolongation.npy", p.prolongation);
    kfx::WriteNpyMatrix(dir + "/gram.npy", p.fine.gram);
    kfx::WriteNpyMatrix(dir + "/gram_position.npy", p.fine.gram_position);
    std::printf("damped wave: fine mesh %d nodes (n = %d), coarse mesh %d nodes (n = %d); files in %s\n", o.fine_nodes,
                2 * o.fine_nodes, o.coarse_nodes, 2 * o.coarse_nodes, dir.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kfx_example_wave: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
