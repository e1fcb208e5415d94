// The C++ side of `make bench-peers` (bench/peers/peers.py drives it): times kfx and SLICOT
// (SB02OD, SG02AD, SB03MD, called through their Fortran interfaces exactly as a C++ user would) on the
// seeded systems that peers.py wrote as .npy files, writes the solutions back as .npy for the
// checks in peers.py, and prints one JSON object on stdout. Times are process CPU seconds
// (CLOCK_PROCESS_CPUTIME_ID), one BLAS thread (the caller sets OPENBLAS_NUM_THREADS=1).
//
//   kfx_peers blas                       the BLAS in use, its kernel self-test and the kernel ChooseBlasKernel
//                                        would ask for (bench/blas_kernel.py decides with it)
//   kfx_peers dgemm REPS                 single-thread DGEMM rate (n = 1000, Eigen -> OpenBLAS)
//   kfx_peers dare DIR N REPS            SolveFilterDare vs SB02OD on DIR/dare_N_{A,C,Q,R}.npy
//   kfx_peers dare_se DIR N REPS         SolveFilterDare with S and E vs SG02AD and vs SB02OD (L = S after
//                                        E^{-1}) on DIR/dare_se_N_{A,C,Q,R,S,E}.npy
//   kfx_peers lyap DIR N REPS            SolveDiscreteLyapunov vs SB03MD on DIR/lyap_N_{A,Q}.npy
//   kfx_peers kf DIR N REPS COV_STEPS TOL  RunFilter (1000 steps) on DIR/kf_N_*.npy, and the
//                                        covariance recursion alone for COV_STEPS steps
#include <malloc.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "base/lapack_fortran.hpp"
#include "kfx/blas_info.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/riccati.hpp"

namespace {

using Eigen::MatrixXd;

double CpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Peak resident set of this process image: VmHWM of /proc/self/status (getrusage's ru_maxrss would
// include the high-water mark of the Python parent this process was forked from).
double PeakRssMb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  }
  return -1.0;
}

// Current resident set (VmRSS), MB.
double RssMb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  }
  return -1.0;
}

// Resets VmHWM to the current resident set (Linux >= 4.0: "5" to /proc/self/clear_refs).
bool ResetPeakRss() {
  std::ofstream f("/proc/self/clear_refs");
  f << "5";
  f.flush();
  return static_cast<bool>(f);
}

std::string JsonList(const std::vector<double>& v) {
  std::string s = "[";
  char buf[64];
  for (size_t i = 0; i < v.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.6g", i ? ", " : "", v[i]);
    s += buf;
  }
  return s + "]";
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

MatrixXd Load(const std::string& dir, const std::string& name) { return kfx::ReadNpyMatrix(dir + "/" + name + ".npy"); }

// SLICOT SB02OD on the filter DARE (the dual control DARE with A^T, C^T), as kfx's kSchur calls it
// but without kfx's post-processing: the bare peer. Returns info.
// With L (n x m, the cross term S of the filter DARE; JOBL = 'N') when given.
int Sb02od(const MatrixXd& A, const MatrixXd& C, const MatrixXd& Q, const MatrixXd& R, MatrixXd* X,
           const MatrixXd* L = nullptr) {
  const int n = static_cast<int>(A.rows()), m = static_cast<int>(C.rows()), p = 0;
  const int ld_n = std::max(1, n), ld_m = std::max(1, m), ld_st = std::max(1, 2 * n + m), ld_u = std::max(1, 2 * n);
  const int ld_l = L ? ld_n : 1;
  MatrixXd a = A.transpose(), b = C.transpose(), q = Q, r = R;
  std::vector<double> l = L ? std::vector<double>(L->data(), L->data() + L->size()) : std::vector<double>(1, 0.0);
  X->resize(n, n);
  const size_t two_n = static_cast<size_t>(std::max(1, 2 * n));
  std::vector<double> alfar(two_n), alfai(two_n), beta(two_n);
  std::vector<double> s(static_cast<size_t>(ld_st) * static_cast<size_t>(ld_st));
  std::vector<double> t(static_cast<size_t>(ld_st) * two_n), u(static_cast<size_t>(ld_u) * two_n);
  std::vector<int> iwork(static_cast<size_t>(std::max({1, m, 2 * n})));
  std::vector<kfx_fortran_logical> bwork(two_n);
  const int ldwork = std::max({14 * n + 23, 16 * n, 2 * n + m, 3 * m}) + 64 * (2 * n + m);
  std::vector<double> dwork(static_cast<size_t>(ldwork));
  double rcond = 0.0;
  const double tol = 0.0;
  int info = 0;
  sb02od_("D", "B", "N", "U", L ? "N" : "Z", "S", &n, &m, &p, a.data(), &ld_n, b.data(), &ld_n, q.data(), &ld_n,
          r.data(), &ld_m, l.data(), &ld_l, &rcond, X->data(), &ld_n, alfar.data(), alfai.data(), beta.data(), s.data(),
          &ld_st, t.data(), &ld_st, u.data(), &ld_u, &tol, iwork.data(), dwork.data(), &ldwork, bwork.data(), &info, 1,
          1, 1, 1, 1, 1);
  return info;
}

// SLICOT SG02AD on the filter DARE with cross term S and descriptor E (the dual control DARE with
// A^T, E^T, C^T, L = S; SCAL = 'G', ACC = 'R' as kfx's kSchur calls it), the bare peer. Returns info.
int Sg02ad(const MatrixXd& A, const MatrixXd& E, const MatrixXd& C, const MatrixXd& Q, const MatrixXd& R,
           const MatrixXd& S, MatrixXd* X) {
  const int n = static_cast<int>(A.rows()), m = static_cast<int>(C.rows()), p = 0;
  const int ld_n = std::max(1, n), ld_m = std::max(1, m), ld_st = std::max(1, 2 * n + m), ld_u = std::max(1, 2 * n);
  MatrixXd a = A.transpose(), e = E.transpose(), b = C.transpose(), q = Q, r = R, l = S;
  X->resize(n, n);
  const size_t two_n = static_cast<size_t>(std::max(1, 2 * n));
  std::vector<double> alfar(two_n), alfai(two_n), beta(two_n);
  std::vector<double> s(static_cast<size_t>(ld_st) * static_cast<size_t>(ld_st));
  std::vector<double> t(static_cast<size_t>(ld_st) * two_n), u(static_cast<size_t>(ld_u) * two_n);
  std::vector<int> iwork(static_cast<size_t>(std::max({1, m, 2 * n})));
  std::vector<kfx_fortran_logical> bwork(two_n);
  const int ldwork = std::max({14 * n + 23, 16 * n, 2 * n + m, 3 * m}) + 64 * (2 * n + m);
  std::vector<double> dwork(static_cast<size_t>(ldwork));
  double rcond = 0.0;
  const double tol = 0.0;
  int iwarn = 0, info = 0;
  sg02ad_("D", "B", "N", "U", "N", "G", "S", "R", &n, &m, &p, a.data(), &ld_n, e.data(), &ld_n, b.data(), &ld_n,
          q.data(), &ld_n, r.data(), &ld_m, l.data(), &ld_n, &rcond, X->data(), &ld_n, alfar.data(), alfai.data(),
          beta.data(), s.data(), &ld_st, t.data(), &ld_st, u.data(), &ld_u, &tol, iwork.data(), dwork.data(), &ldwork,
          bwork.data(), &iwarn, &info, 1, 1, 1, 1, 1, 1, 1, 1);
  return info;
}

// SB02OD has no E: the user of SB02OD multiplies by E^{-1} (LU) first, A~ = E^{-1} A, Q~ = E^{-1} Q E^{-T},
// L = E^{-1} S, and calls SB02OD with L (timed with the transformation).
int Sb02odWithInverse(const MatrixXd& A, const MatrixXd& E, const MatrixXd& C, const MatrixXd& Q, const MatrixXd& R,
                      const MatrixXd& S, MatrixXd* X) {
  const Eigen::PartialPivLU<MatrixXd> lu(E);
  const MatrixXd At = lu.solve(A), St = lu.solve(S);
  MatrixXd Qt = lu.solve(MatrixXd(lu.solve(Q).transpose()));
  Qt = 0.5 * (Qt + Qt.transpose()).eval();
  return Sb02od(At, C, Qt, R, X, &St);
}

// SLICOT SB03MD on X = A X A^T + Q (TRANA = 'T', C = -Q; X / scale), the bare peer.
int Sb03md(const MatrixXd& A, const MatrixXd& Q, MatrixXd* X) {
  const int n = static_cast<int>(A.rows()), ld = std::max(1, n);
  MatrixXd a = A, u(n, n);
  *X = -Q;
  std::vector<double> wr(static_cast<size_t>(n)), wi(static_cast<size_t>(n));
  std::vector<int> iwork(1);
  const int ldwork = std::max(2 * n * n + 3 * n, 1) + 64 * n;
  std::vector<double> dwork(static_cast<size_t>(ldwork));
  double scale = 1.0, sep = 0.0, ferr = 0.0;
  int info = 0;
  sb03md_("D", "X", "N", "T", &n, a.data(), &ld, u.data(), &ld, X->data(), &ld, &scale, &sep, &ferr, wr.data(),
          wi.data(), iwork.data(), dwork.data(), &ldwork, &info, 1, 1, 1, 1);
  if (info == 0 && scale != 1.0) *X /= scale;
  return info;
}

int Dgemm(int reps) {
  const Eigen::Index n = 1000;
  MatrixXd a = MatrixXd::Random(n, n), b = MatrixXd::Random(n, n), c(n, n);
  double best = 1e300;
  for (int i = 0; i < reps; ++i) {
    const double t0 = CpuSeconds();
    c.noalias() = a * b;
    best = std::min(best, CpuSeconds() - t0);
  }
  std::cout << "{\"n\": 1000, \"best_seconds\": " << Num(best) << ", \"gflops\": " << Num(2e-9 * 1e9 / best)
            << ", \"check\": " << Num(c(0, 0) - a.row(0).dot(b.col(0))) << "}\n";
  return 0;
}

int Dare(const std::string& dir, int n, int reps) {
  const std::string p = "dare_" + std::to_string(n) + "_";
  const MatrixXd A = Load(dir, p + "A"), C = Load(dir, p + "C"), Q = Load(dir, p + "Q"), R = Load(dir, p + "R");
  std::vector<double> t_kfx, t_slicot, ratio;
  kfx::DareSolution sol;
  MatrixXd X;
  int info = 0;
  // One untimed call of each first: the first call in a process pays first-touch page faults and
  // OpenBLAS's buffer setup (measured: up to 10x the warm time at n = 10), whoever goes first.
  sol = kfx::SolveFilterDare(A, C, Q, R);
  info = Sb02od(A, C, Q, R, &X);
  for (int i = 0; i < reps; ++i) {  // interleaved, so that load changes hit both
    double t0 = CpuSeconds();
    sol = kfx::SolveFilterDare(A, C, Q, R);
    t_kfx.push_back(CpuSeconds() - t0);
    t0 = CpuSeconds();
    info = Sb02od(A, C, Q, R, &X);
    t_slicot.push_back(CpuSeconds() - t0);
    ratio.push_back(t_slicot.back() / t_kfx.back());
  }
  kfx::WriteNpyMatrix(dir + "/" + p + "X_kfx.npy", sol.P_pred);
  kfx::WriteNpyMatrix(dir + "/" + p + "X_sb02od.npy", X);
  std::cout << "{\"kfx\": " << JsonList(t_kfx) << ", \"sb02od\": " << JsonList(t_slicot)
            << ", \"paired_ratio\": " << JsonList(ratio) << ", \"sb02od_info\": " << info << ", \"kfx_status\": \""
            << kfx::ToString(sol.summary.termination) << "\", \"kfx_method\": \"" << kfx::ToString(sol.method_used)
            << "\", \"kfx_steps\": " << sol.summary.iterations << ", \"kfx_refine\": " << sol.refinement_steps
            << ", \"kfx_lyapunov_certified\": " << (sol.lyapunov_certified ? "true" : "false")
            << ", \"kfx_eigenvalues_exact\": " << (sol.eigenvalues_exact ? "true" : "false")
            << ", \"kfx_rho_reported\": " << Num(sol.closed_loop_spectral_radius)
            << ", \"kfx_residual\": " << Num(sol.summary.relative_residual) << "}\n";
  return 0;
}

// The filter DARE with cross term S and descriptor E: kfx vs SG02AD and vs SB02OD after E^{-1}.
int DareSE(const std::string& dir, int n, int reps) {
  const std::string p = "dare_se_" + std::to_string(n) + "_";
  const MatrixXd A = Load(dir, p + "A"), C = Load(dir, p + "C"), Q = Load(dir, p + "Q"), R = Load(dir, p + "R");
  const MatrixXd S = Load(dir, p + "S"), E = Load(dir, p + "E");
  std::vector<double> t_kfx, t_sg, t_sb, ratio_sg, ratio_sb;
  kfx::DareSolution sol;
  MatrixXd X_sg, X_sb;
  int info_sg = 0, info_sb = 0;
  sol = kfx::SolveFilterDare(A, C, Q, R, S, E);  // untimed first calls (see Dare)
  info_sg = Sg02ad(A, E, C, Q, R, S, &X_sg);
  info_sb = Sb02odWithInverse(A, E, C, Q, R, S, &X_sb);
  for (int i = 0; i < reps; ++i) {  // interleaved
    double t0 = CpuSeconds();
    sol = kfx::SolveFilterDare(A, C, Q, R, S, E);
    t_kfx.push_back(CpuSeconds() - t0);
    t0 = CpuSeconds();
    info_sg = Sg02ad(A, E, C, Q, R, S, &X_sg);
    t_sg.push_back(CpuSeconds() - t0);
    t0 = CpuSeconds();
    info_sb = Sb02odWithInverse(A, E, C, Q, R, S, &X_sb);
    t_sb.push_back(CpuSeconds() - t0);
    ratio_sg.push_back(t_sg.back() / t_kfx.back());
    ratio_sb.push_back(t_sb.back() / t_kfx.back());
  }
  kfx::WriteNpyMatrix(dir + "/" + p + "X_kfx.npy", sol.P_pred);
  kfx::WriteNpyMatrix(dir + "/" + p + "X_sg02ad.npy", X_sg);
  kfx::WriteNpyMatrix(dir + "/" + p + "X_sb02od.npy", X_sb);
  std::cout << "{\"kfx\": " << JsonList(t_kfx) << ", \"sg02ad\": " << JsonList(t_sg)
            << ", \"sb02od\": " << JsonList(t_sb) << ", \"paired_ratio_sg02ad\": " << JsonList(ratio_sg)
            << ", \"paired_ratio_sb02od\": " << JsonList(ratio_sb) << ", \"sg02ad_info\": " << info_sg
            << ", \"sb02od_info\": " << info_sb << ", \"kfx_status\": \"" << kfx::ToString(sol.summary.termination)
            << "\", \"kfx_method\": \"" << kfx::ToString(sol.method_used)
            << "\", \"kfx_fell_back\": " << (sol.fell_back ? "true" : "false")
            << ", \"kfx_steps\": " << sol.summary.iterations << ", \"kfx_refine\": " << sol.refinement_steps
            << ", \"kfx_lyapunov_certified\": " << (sol.lyapunov_certified ? "true" : "false")
            << ", \"kfx_residual\": " << Num(sol.summary.relative_residual) << "}\n";
  return 0;
}

int Lyap(const std::string& dir, int n, int reps) {
  const std::string p = "lyap_" + std::to_string(n) + "_";
  const MatrixXd A = Load(dir, p + "A"), Q = Load(dir, p + "Q");
  std::vector<double> t_kfx, t_slicot, ratio;
  MatrixXd Xk, Xs;
  int info = 0;
  // One untimed call of each first, as in Dare (first-touch page faults, OpenBLAS's buffer setup).
  Xk = kfx::SolveDiscreteLyapunov(A, Q).X;
  info = Sb03md(A, Q, &Xs);
  for (int i = 0; i < reps; ++i) {
    double t0 = CpuSeconds();
    Xk = kfx::SolveDiscreteLyapunov(A, Q).X;
    t_kfx.push_back(CpuSeconds() - t0);
    t0 = CpuSeconds();
    info = Sb03md(A, Q, &Xs);
    t_slicot.push_back(CpuSeconds() - t0);
    ratio.push_back(t_slicot.back() / t_kfx.back());
  }
  kfx::WriteNpyMatrix(dir + "/" + p + "X_kfx.npy", Xk);
  kfx::WriteNpyMatrix(dir + "/" + p + "X_sb03md.npy", Xs);
  std::cout << "{\"kfx\": " << JsonList(t_kfx) << ", \"sb03md\": " << JsonList(t_slicot)
            << ", \"paired_ratio\": " << JsonList(ratio) << ", \"sb03md_info\": " << info << "}\n";
  return 0;
}

// The same filter step as kfx's conventional form with its defaults (predict; Joseph update; (P + P^T)/2
// after predict and update; the log-likelihood term from the Cholesky factor of S), written the way a
// C++ user with one fixed model size would: Eigen::Matrix<double, N, N>, every size known at compile
// time, no missing-value handling, no checks. The baseline of the "full-step kfx at n = 4" row.
template <int N, int M>
double FixedSizeFilter(const MatrixXd& A_, const MatrixXd& C_, const MatrixXd& Q_, const MatrixXd& R_,
                       const Eigen::VectorXd& m0, const MatrixXd& P0, const kfx::TimeSeries& Y, kfx::TimeSeries* xs) {
  using MatN = Eigen::Matrix<double, N, N>;
  using MatMN = Eigen::Matrix<double, M, N>;
  using MatNM = Eigen::Matrix<double, N, M>;
  using MatM = Eigen::Matrix<double, M, M>;
  const MatN A = A_, Q = Q_;
  const MatMN C = C_;
  const MatM R = R_;
  Eigen::Matrix<double, N, 1> x = m0;
  MatN P = P0;
  const double log2pi = std::log(2.0 * 3.14159265358979323846);
  double loglik = 0.0;
  xs->resize(Y.rows() + 1, N);
  xs->row(0) = x.transpose();
  for (Eigen::Index k = 0; k < Y.rows(); ++k) {
    x = A * x;
    P = A * P * A.transpose() + Q;
    P = 0.5 * (P + P.transpose()).eval();
    const Eigen::Matrix<double, M, 1> nu = Y.row(k).transpose() - C * x;
    const MatNM U = P * C.transpose();
    const Eigen::LLT<MatM> S(C * U + R);
    const MatNM K = S.solve(U.transpose()).transpose();
    x += K * nu;
    const MatN IKC = MatN::Identity() - K * C;
    P = IKC * P * IKC.transpose() + K * R * K.transpose();
    P = 0.5 * (P + P.transpose()).eval();
    const Eigen::Matrix<double, M, 1> w = S.matrixL().solve(nu);
    loglik += -0.5 * (w.squaredNorm() + 2.0 * S.matrixLLT().diagonal().array().log().sum() + M * log2pi);
    xs->row(k + 1) = x.transpose();
  }
  return loglik;
}

int Kf(const std::string& dir, int n, int reps, int cov_steps, double tol) {
  // From here to the memory run (loading included), glibc's thresholds are fixed at 128 KiB (no
  // dynamic mmap threshold): every block over 128 KiB is mapped on allocation and unmapped on
  // free, so the resident set follows the live allocations and a run's growth is not hidden by
  // freed memory that glibc would keep and reuse.
  mallopt(M_MMAP_THRESHOLD, 128 * 1024);
  mallopt(M_TRIM_THRESHOLD, 128 * 1024);
  const std::string p = "kf_" + std::to_string(n) + "_";
  // Loaded straight into the model (no second copy of A, Q, P0 in this process).
  const kfx::Model model(kfx::MakeStep(Load(dir, p + "A"), Load(dir, p + "C"), Load(dir, p + "Q"), Load(dir, p + "R")),
                         Load(dir, p + "m0"), Load(dir, p + "P0"));
  const kfx::TimeSeries Y = Load(dir, p + "Y");
  const MatrixXd& C = model.step(1)->C;
  const Eigen::VectorXd& m0 = model.m0();
  const MatrixXd& P0 = model.P0();
  kfx::FilterRunOptions options;
  options.store_covariances = false;
  options.steady_state_tolerance = tol;
  std::vector<double> t_run;
  kfx::FilterRun run;
  // Memory of one run: the growth of the resident set's high-water mark over the call (reset just
  // before it), and that growth less the outputs RunFilter returns (means, covariance diagonals,
  // innovations: they grow with T): the covariance storage the recursion itself used.
  const bool reset = ResetPeakRss();
  const double rss_before = RssMb();
  run = kfx::RunFilter(model, Y, options);
  const double run_growth = reset ? PeakRssMb() - rss_before : -1.0;
  const double outputs_mb =
      (8.0 * static_cast<double>(run.x_filt.size() + run.x_pred.size() + run.P_filt_diag.size() +
                                 run.P_pred_diag.size() + run.innovations.size() + run.log_likelihood_terms.size()) +
       4.0 * static_cast<double>(run.num_observed.size())) /
      1048576.0;
  const double covariance_mb = 8.0 * static_cast<double>(n) * static_cast<double>(n) / 1048576.0;
  run = kfx::FilterRun();
  // For the timings, glibc's usual steady state: the largest dynamic mmap threshold (32 MiB), so
  // freed blocks are reused from the heap as they would be after a few steps.
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 64 * 1024 * 1024);
  for (int i = 0; i < reps; ++i) {
    run = kfx::FilterRun();
    const double t0 = CpuSeconds();
    run = kfx::RunFilter(model, Y, options);
    t_run.push_back(CpuSeconds() - t0);
  }
  // The same run with every step a full covariance step (no steady-state switch): the honest
  // comparison with peers that do not freeze the gain (numpy, FilterPy, the fixed-size loop below).
  std::vector<double> t_full;
  kfx::FilterRunOptions full_options = options;
  full_options.steady_state_tolerance = 0.0;
  kfx::FilterRun full_run;
  // At n >= 1000 a 1000-step full run is minutes: a 100-step prefix, scaled by the caller.
  const Eigen::Index full_steps = n >= 1000 ? std::min<Eigen::Index>(100, Y.rows()) : Y.rows();
  const kfx::TimeSeries Y_full = Y.topRows(full_steps);
  for (int i = 0; i < reps; ++i) {
    full_run = kfx::FilterRun();
    const double t0 = CpuSeconds();
    full_run = kfx::RunFilter(model, Y_full, full_options);
    t_full.push_back(CpuSeconds() - t0);
  }
  // At n = 4, m = 2: the fixed-size Eigen filter of the same step, timed here, and its distance from
  // kfx's full-step run (relative, max over the means).
  std::vector<double> t_fixed;
  double fixed_diff = -1.0, fixed_loglik_diff = -1.0;
  if (n == 4 && C.rows() == 2) {
    const kfx::ModelStep& st = *model.step(1);
    kfx::TimeSeries xs;
    double ll = 0.0;
    for (int i = 0; i < std::max(reps, 20); ++i) {
      const double t0 = CpuSeconds();
      ll = FixedSizeFilter<4, 2>(st.A, st.C, st.Q, st.R, m0, P0, Y, &xs);
      t_fixed.push_back(CpuSeconds() - t0);
    }
    fixed_diff = (xs - full_run.x_filt).cwiseAbs().maxCoeff() / full_run.x_filt.cwiseAbs().maxCoeff();
    fixed_loglik_diff = std::abs(ll - full_run.log_likelihood) / std::abs(full_run.log_likelihood);
  }
  const double rss = PeakRssMb();
  // The covariance recursion alone (Predict + Update on P, no fast path): its rate in the flops it
  // needs. Needed per step (m = C.rows()): A P A^T with a symmetric result 3 n^3 (one GEMM, half of a
  // second); U = P C^T 2 n^2 m; S = C U (half) n m^2; Cholesky m^3 / 3; K = U S^-1 2 n m^2;
  // P - K U^T (half) n^2 m. The Joseph form and the symmetrization are kfx's choice, not counted.
  std::vector<double> t_cov;
  const kfx::ModelStep& s = *model.step(1);
  kfx::Estimate e{m0, P0};
  const Eigen::VectorXd y0 = Y.row(0).transpose();
  for (int i = 0; i < cov_steps; ++i) {
    const double t0 = CpuSeconds();
    kfx::UpdateResult u = kfx::Update(kfx::Predict(e, s), s, y0);
    t_cov.push_back(CpuSeconds() - t0);
    e = std::move(u.estimate);
  }
  const double nn = n, mm = static_cast<double>(C.rows());
  const double flops = 3 * nn * nn * nn + 3 * nn * nn * mm + 3 * nn * mm * mm + mm * mm * mm / 3;
  kfx::WriteNpyMatrix(dir + "/" + p + "xfilt_kfx.npy", run.x_filt);
  const kfx::TimeSeries last = run.P_filt_diag.bottomRows(1);
  kfx::WriteNpyMatrix(dir + "/" + p + "Pdiag_kfx.npy", last);
  std::cout << "{\"kfx\": " << JsonList(t_run) << ", \"cov_step\": " << JsonList(t_cov)
            << ", \"cov_step_flops\": " << Num(flops) << ", \"peak_rss_mb\": " << Num(rss)
            << ", \"run_rss_growth_mb\": " << Num(run_growth) << ", \"run_outputs_mb\": " << Num(outputs_mb)
            << ", \"covariance_mb\": " << Num(covariance_mb) << ", \"loglik\": " << Num(run.log_likelihood)
            << ", \"steps\": " << Y.rows() << ", \"steady_state_steps\": " << run.steady_state_steps
            << ", \"kfx_full\": " << JsonList(t_full) << ", \"kfx_full_steps_timed\": " << full_steps
            << ", \"eigen_fixed\": " << JsonList(t_fixed) << ", \"eigen_fixed_x_diff\": " << Num(fixed_diff)
            << ", \"eigen_fixed_loglik_diff\": " << Num(fixed_loglik_diff) << "}\n";
  return 0;
}

// One JSON object: the BLAS/LAPACK in this process (kfx/blas_info.hpp) and the kernel the CPU would take.
int Blas() {
  const kfx::BlasInfo b = kfx::QueryBlasInfo();
  const kfx::CpuInfo cpu = kfx::DetectCpu();
  double err = 0;
  const bool ok = kfx::CheckBlasKernel(&err);
  auto q = [](const std::string& s) {
    std::string r = "\"";
    for (char c : s) r += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
    return r + "\"";
  };
  std::cout << "{\"blas_library\": " << q(b.blas_library) << ", \"lapack_library\": " << q(b.lapack_library)
            << ", \"lapack_version\": " << q(b.lapack_version) << ", \"blas_config\": " << q(b.config)
            << ", \"kernel\": " << q(b.core_name)
            << ", \"kernel_simd\": " << q(kfx::ToString(kfx::KernelSimdLevel(b.core_name)))
            << ", \"threads\": " << b.threads << ", \"cpu\": " << q(cpu.model)
            << ", \"cpu_simd\": " << q(kfx::ToString(cpu.best)) << ", \"kernel_self_test\": " << (ok ? "true" : "false")
            << ", \"kernel_self_test_error\": " << err
            << ", \"better_kernel\": " << q(kfx::ChooseBlasKernel(b.core_name, cpu, "", false).coretype) << "}\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> a(argv + 1, argv + argc);
  try {
    if (a.size() == 1 && a[0] == "blas") return Blas();
    if (a.size() == 2 && a[0] == "dgemm") return Dgemm(std::stoi(a[1]));
    if (a.size() == 4 && a[0] == "dare") return Dare(a[1], std::stoi(a[2]), std::stoi(a[3]));
    if (a.size() == 4 && a[0] == "dare_se") return DareSE(a[1], std::stoi(a[2]), std::stoi(a[3]));
    if (a.size() == 4 && a[0] == "lyap") return Lyap(a[1], std::stoi(a[2]), std::stoi(a[3]));
    if (a.size() == 6 && a[0] == "kf")
      return Kf(a[1], std::stoi(a[2]), std::stoi(a[3]), std::stoi(a[4]), std::stod(a[5]));
  } catch (const std::exception& e) {
    std::cerr << "kfx_peers: " << e.what() << "\n";
    return 1;
  }
  std::cerr << "usage: kfx_peers blas | dgemm REPS | dare DIR N REPS | dare_se DIR N REPS | lyap DIR N REPS | kf DIR N "
               "REPS COV_STEPS TOL\n";
  return 2;
}
