// `kfx reproduce bernstein`: Chandrasekar, Kim, Bernstein (001), Secs. V-VI: cost ratios of the
// reduced-order and subspace estimators to the full-order Kalman filter/predictor on the spring-
// mass-dashpot chains. Settings (unstated in the paper) and what reproduces: docs/papers/001.md.
// Paper 001: J. Chandrasekar, I. S. Kim, D. S. Bernstein, finite-horizon optimal reduced-order
// estimators for time-varying systems (title unconfirmed; docs/papers/README.md).
//
// Time indexing: 001 measures its x_0 (covariance P0) with y_0. kfx's first measurement is y_1 of
// x_1 = A_1 x_0 + w_1, so the model's step 1 is the identity without noise (x_1 = x_0 ~ N(0, P0))
// and 001's time j is kfx's j + 1. 001's J_k (estimate of L x_{k+1} after y_0..y_k) is kfx's
// predictor cost at k + 2; the data-assimilation J_k (of L x_k after y_0..y_k) is kfx's k + 1.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/reduced_order.hpp"
#include "kfx/spring_mass_chain.hpp"
#include "reproduce/papers.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr int kHorizon = 500;  // 001's k = 0..500 in Figs. 2-3

// 001 (5.2): L(i, i) = 1, every other entry 0.05.
MatrixXd PaperWeight(Index ne, Index n) {
  MatrixXd L = MatrixXd::Constant(ne, n, 0.05);
  for (Index i = 0; i < ne; ++i) L(i, i) = 1.0;
  return L;
}

Model ChainModel(const MatrixXd& Ad, Index p) {
  const Index n = Ad.rows();
  MatrixXd C = MatrixXd::Zero(p, n);
  C.leftCols(p).setIdentity();
  const ModelStep first = MakeStep(MatrixXd::Identity(n, n), C, MatrixXd::Zero(n, n), MatrixXd::Identity(p, p));
  const ModelStep rest = MakeStep(Ad, C, MatrixXd::Identity(n, n), MatrixXd::Identity(p, p));
  return Model(
      n, p, [first, rest](int k) { return k == 1 ? first : rest; }, VectorXd::Zero(n),
      100.0 * MatrixXd::Identity(n, n));
}

// Ratio curves in 001's indexing k = 0..kHorizon.
struct Curves {
  VectorXd reduced_onestep, reduced_da, reduced_f, subspace_onestep, subspace_da, subspace_f;
};

VectorXd PaperRatio(const VectorXd& J, const VectorXd& Jkf, int shift) {
  VectorXd r(kHorizon + 1);
  for (int k = 0; k <= kHorizon; ++k) r(k) = J(k + shift) / Jkf(k + shift);
  return r;
}

// Largest relative difference between a recursion's own cost and the engine's, over k = 1..T.
double Agreement(const VectorXd& recursion, const VectorXd& engine) {
  double d = 0.0;
  for (Index k = 1; k < engine.size(); ++k) d = std::max(d, std::abs(recursion(k) - engine(k)) / engine(k));
  return d;
}

Curves RunChain(const Model& model, const MatrixXd& Ad, Index ne, bool reduced, const ProgressCallback& progress,
                int* done, int total, std::vector<std::string>* notes) {
  const int T = kHorizon + 2;
  const WeightSchedule L(PaperWeight(ne, model.state_dim()));
  ReducedOrderOptions ro;
  ro.steps = T;
  const KalmanWeightedCosts kf = KalmanCosts(model, L, ro);
  auto tick = [&]() {
    if (progress) progress(++*done, total);
  };
  Curves c;
  if (reduced) {
    const ReducedOrderOneStep s1 = ComputeReducedOrderOneStep(model, L, ro);
    const VectorXd J1 = WeightedCost(model, ReducedOrderOneStepAsLinearFilter(s1, L), L, ro);
    c.reduced_onestep = PaperRatio(J1, kf.predictor, 2);
    std::ostringstream os;
    os << "n_e = " << ne << ": reduced one-step recursion vs engine cost, max rel. diff " << Agreement(s1.cost, J1)
       << ", pseudo-inverse at " << s1.singular_steps.size() << " steps";
    notes->push_back(os.str());
    tick();
    const ReducedOrderTwoStep s2 = ComputeReducedOrderTwoStep(model, L, ro);
    c.reduced_da = PaperRatio(
        WeightedCost(model, ReducedOrderTwoStepAsLinearFilter(s2, L, TwoStepOutput::kDataAssimilation), L, ro),
        kf.filter, 1);
    c.reduced_f =
        PaperRatio(WeightedCost(model, ReducedOrderTwoStepAsLinearFilter(s2, L, TwoStepOutput::kForecast), L, ro),
                   kf.predictor, 2);
    tick();
  }
  // Sec. IV partitions L = [L_r, L_s] conformally with x' = (x_r, x_s): for the subspace estimator
  // (5.2) weights the block-triangular coordinates x' = T^T x, i.e. L T^T in kfx's coordinates.
  const InvariantSubspaceBasis b = LeastDampedSubspace(Ad, ne);
  const WeightSchedule Ls(PaperWeight(ne, model.state_dim()) * b.T.transpose());
  const KalmanWeightedCosts kfs = KalmanCosts(model, Ls, ro);
  const SubspaceOneStep u1 = ComputeSubspaceOneStep(model, b.T, ne, Ls, ro);
  const VectorXd Ju = WeightedCost(model, SubspaceOneStepAsLinearFilter(u1, b.T, ne), Ls, ro);
  c.subspace_onestep = PaperRatio(Ju, kfs.predictor, 2);
  std::ostringstream os;
  os << "n_e = " << ne << ": subspace one-step recursion vs engine cost, max rel. diff " << Agreement(u1.cost, Ju)
     << ", triangularity defect " << u1.triangularity_defect;
  notes->push_back(os.str());
  tick();
  const SubspaceTwoStep u2 = ComputeSubspaceTwoStep(model, b.T, ne, Ls, ro);
  c.subspace_da = PaperRatio(
      WeightedCost(model, SubspaceTwoStepAsLinearFilter(u2, b.T, ne, TwoStepOutput::kDataAssimilation), Ls, ro),
      kfs.filter, 1);
  c.subspace_f =
      PaperRatio(WeightedCost(model, SubspaceTwoStepAsLinearFilter(u2, b.T, ne, TwoStepOutput::kForecast), Ls, ro),
                 kfs.predictor, 2);
  tick();
  return c;
}

void WriteCurves(const std::filesystem::path& file, const std::vector<std::pair<std::string, const VectorXd*>>& cols) {
  std::ofstream f(file);
  f << "k";
  for (const auto& c : cols) f << "," << c.first;
  f << "\n";
  f.precision(10);
  for (int k = 0; k <= kHorizon; ++k) {
    f << k;
    for (const auto& c : cols) f << "," << (*c.second)(k);
    f << "\n";
  }
}

}  // namespace

PaperReport ReproduceBernstein(const ReproduceOptions& options) {
  PaperReport report;
  report.paper = "bernstein";
  report.title = "Chandrasekar, Kim, Bernstein: finite-horizon reduced-order estimators (001)";
  const std::string note = "the paper shows curves only (Figs. 2-3); ratio to the full-order Kalman cost";
  int done = 0;
  const int total = 12;

  // Sec. V: 10 masses, fixed-fixed, n = 20, dt = 0.1.
  const SpringMassChain sec5 = BuildSpringMassChain(UniformChain(10, 1.0, 1.0, 0.05, true, true, 0.1));
  Curves c5[2];
  const Index ne5[2] = {8, 16};
  for (int e = 0; e < 2; ++e) {
    const Model model = ChainModel(sec5.Ad, ne5[e]);
    c5[e] = RunChain(model, sec5.Ad, ne5[e], true, options.progress, &done, total, &report.notes);
  }
  // Sec. VI: 20 masses, free-free, mass 11 first, n = 40, C = [I_2 0].
  SpringMassChainOptions o6 = UniformChain(20, 1.0, 1.0, 0.05, false, false, 0.1);
  o6.first_mass = 11;
  const SpringMassChain sec6 = BuildSpringMassChain(o6);
  Curves c6[2];
  const Index ne6[2] = {4, 8};
  for (int e = 0; e < 2; ++e) {
    const Model model = ChainModel(sec6.Ad, 2);
    c6[e] = RunChain(model, sec6.Ad, ne6[e], false, options.progress, &done, total, &report.notes);
  }

  const int Ks[3] = {10, 100, 500};
  for (int e = 0; e < 2; ++e) {
    const std::string E = std::to_string(ne5[e]);
    const std::pair<const char*, const VectorXd*> rows[5] = {{"reduced.onestep", &c5[e].reduced_onestep},
                                                             {"reduced.twostep_da", &c5[e].reduced_da},
                                                             {"reduced.twostep_f", &c5[e].reduced_f},
                                                             {"subspace.onestep", &c5[e].subspace_onestep},
                                                             {"subspace.twostep_da", &c5[e].subspace_da}};
    for (const auto& r : rows) {
      for (int K : Ks) {
        report.items.push_back(
            NewItem("sec5.ne=" + E + "." + r.first + ".k=" + std::to_string(K),
                    std::string("Sec. V, n_e = ") + E + ", " + r.first + ": J_k / J_k^KF at k = " + std::to_string(K),
                    (*r.second)(K), note));
      }
    }
  }
  for (int e = 0; e < 2; ++e) {
    const std::string E = std::to_string(ne6[e]);
    for (int K : Ks) {
      report.items.push_back(
          NewItem("sec6.ne=" + E + ".subspace.onestep.k=" + std::to_string(K),
                  "Sec. VI (free-free), n_e = " + E + ", subspace one-step: J_k / J_k^KF at k = " + std::to_string(K),
                  c6[e].subspace_onestep(K), note));
    }
  }

  if (!options.out_dir.empty()) {
    namespace fs = std::filesystem;
    const fs::path dir(options.out_dir);
    fs::create_directories(dir);
    WriteCurves(dir / "fig2a.csv", {{"onestep_ne8", &c5[0].reduced_onestep},
                                    {"twostep_da_ne8", &c5[0].reduced_da},
                                    {"twostep_f_ne8", &c5[0].reduced_f},
                                    {"onestep_ne16", &c5[1].reduced_onestep},
                                    {"twostep_da_ne16", &c5[1].reduced_da},
                                    {"twostep_f_ne16", &c5[1].reduced_f}});
    WriteCurves(dir / "fig2b.csv", {{"onestep_ne8", &c5[0].subspace_onestep},
                                    {"twostep_da_ne8", &c5[0].subspace_da},
                                    {"twostep_f_ne8", &c5[0].subspace_f},
                                    {"onestep_ne16", &c5[1].subspace_onestep},
                                    {"twostep_da_ne16", &c5[1].subspace_da},
                                    {"twostep_f_ne16", &c5[1].subspace_f}});
    WriteCurves(dir / "fig3.csv", {{"onestep_ne4", &c6[0].subspace_onestep},
                                   {"twostep_da_ne4", &c6[0].subspace_da},
                                   {"twostep_f_ne4", &c6[0].subspace_f},
                                   {"onestep_ne8", &c6[1].subspace_onestep},
                                   {"twostep_da_ne8", &c6[1].subspace_da},
                                   {"twostep_f_ne8", &c6[1].subspace_f}});
    for (const char* f : {"fig2a.csv", "fig2b.csv", "fig3.csv"}) report.figures.push_back((dir / f).string());
    report.notes.push_back("figures: python3 python/kfx_figures.py " + options.out_dir +
                           " renders fig2a.png, fig2b.png and fig3.png from the CSV files");
  }
  report.notes.push_back(
      "settings (001 leaves them unstated): P0 = 100 I, V1 = I, V2 = I in discrete time, dt = 0.1 s, zero-order "
      "hold; L(i, i) = 1, 0.05 elsewhere; subspace = the n_e least damped modes (ordered real Schur form)");
  report.notes.push_back(
      "001's k is kfx's k + 1 (the paper measures x_0); one-step and forecast ratios compare with the Kalman "
      "predictor, data-assimilation ratios with the Kalman filter");
  (void)options.quick;  // the K = 500 horizon is cheap (n = 20, 40): quick and full runs are the same
  return report;
}

}  // namespace kfx::detail
