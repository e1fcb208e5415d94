// The distributed filters without MPI (include/kfx/distributed.hpp): the partitioned block-diagonal and
// banded filters against the serial filters and against each other (independence of the partition),
// the split Monte Carlo sums against MonteCarloPerformance, the compensated sums against exact
// rational arithmetic, slice reads of .npy files, the coupled model file, and `kfx blockdiag`'s job
// with ranks emulated by threads. tests/mpi/ runs the same under mpirun.
#include "kfx/distributed.hpp"

#include <gtest/gtest.h>

#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "kfx/coupled_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/simulation.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::TestRng;

double Rel(const MatrixXd& a, const MatrixXd& b) {
  EXPECT_EQ(a.rows(), b.rows());
  EXPECT_EQ(a.cols(), b.cols());
  if (a.rows() != b.rows() || a.cols() != b.cols() || a.size() == 0) return a.size() == b.size() ? 0.0 : INFINITY;
  return (a - b).cwiseAbs().maxCoeff() / std::max(b.cwiseAbs().maxCoeff(), 1e-300);
}

CoupledStep RandomStep(TestRng& rng, Index n, Index c, Index d, Index r) {
  CoupledStep s;
  s.F = rng.Gaussian(c, n * c) * 0.6;
  s.H = rng.Gaussian(d, n * c);
  s.V.resize(c, n * c);
  s.R.resize(d, n * d);
  for (Index i = 0; i < n; ++i) {
    s.V.middleCols(i * c, c) = rng.Spd(c, 0.05);
    s.R.middleCols(i * d, d) = rng.Spd(d, 0.2);
  }
  s.G = rng.Gaussian(n * c, r) * 0.7;
  s.U = rng.Spd(r, 0.1);
  return s;
}

CoupledSystem RandomSystem(TestRng& rng, Index n, Index c, Index d, Index r, int T) {
  std::vector<CoupledStep> steps;
  for (int k = 0; k < T; ++k) steps.push_back(RandomStep(rng, n, c, d, r));
  MatrixXd P0(c, n * c);
  for (Index i = 0; i < n; ++i) P0.middleCols(i * c, c) = rng.Spd(c, 0.5);
  return CoupledSystem(std::move(steps), rng.Gaussian(n * c, 1), P0);
}

TEST(PartitionByCost, WholeGranulesCoveringAllSubsystems) {
  const Partition p = PartitionByCost(1000, 3, 64);
  ASSERT_EQ(p.ranks(), 3);
  EXPECT_EQ(p.begin.front(), 0);
  EXPECT_EQ(p.begin.back(), 1000);
  for (int q = 1; q < 3; ++q) EXPECT_EQ(p.first(q) % 64, 0);
  for (int q = 0; q < 3; ++q) EXPECT_NEAR(static_cast<double>(p.count(q)), 1000.0 / 3, 64.0);
  // More ranks than granules: some ranges are empty, none negative, all subsystems covered.
  const Partition e = PartitionByCost(10, 4, 8);
  Index total = 0;
  for (int q = 0; q < 4; ++q) {
    EXPECT_GE(e.count(q), 0);
    total += e.count(q);
  }
  EXPECT_EQ(total, 10);
}

TEST(PartitionByCost, BalancesCostNotCount) {
  // Cost growing as i: equal-cost ranges are ~ n / sqrt(2) and n (1 - 1 / sqrt(2)) long.
  const Index n = 10000;
  const VectorXd cost = VectorXd::LinSpaced(n, 1.0, static_cast<double>(n));
  const Partition p = PartitionByCost(n, 2, 10, cost);
  EXPECT_NEAR(static_cast<double>(p.first(1)), n / std::sqrt(2.0), 10.0);
  const double a = cost.head(p.first(1)).sum(), b = cost.tail(n - p.first(1)).sum();
  EXPECT_NEAR(a / (a + b), 0.5, 1e-3);
  EXPECT_THROW(PartitionByCost(n, 2, 10, VectorXd::Ones(3)), Error);
  EXPECT_THROW(PartitionByCost(n, 0, 10), Error);
  EXPECT_THROW(PartitionByCost(n, 2, 10, -cost), Error);
}

TEST(CompensatedSums, ExactForSumsThatCancel) {
  // 1e16 + 1 - 1e16 in doubles is 0; the compensated pair keeps the 1, whatever the grouping.
  const std::vector<double> terms = {1e16, 1.0, -1e16, 3.5, 1e-20, -3.5};
  double seq[2] = {0.0, 0.0};
  for (double t : terms) CompensatedAccumulate(t, seq);
  EXPECT_EQ(CompensatedValue(seq), 1.0 + 1e-20);
  std::vector<double> a = {0.0, 0.0}, b = {0.0, 0.0};
  for (size_t i = 0; i < terms.size(); ++i) CompensatedAccumulate(terms[i], i % 2 ? a.data() : b.data());
  CompensatedAdd(a.data(), b.data(), 1);
  EXPECT_EQ(CompensatedValue(b.data()), CompensatedValue(seq));
}

struct Config {
  Index n, c, d, r, granule;
};

class Partitioned : public ::testing::TestWithParam<Config> {};

// The partitioned block-diagonal filter at 1, 2, 3, 5 slices: identical to 1e-13 across partitions,
// and equal to the library's serial filter (eqs. (8)-(17), one summation order) to rounding.
TEST_P(Partitioned, BlockDiagonalIndependentOfPartitionAndEqualToSerial) {
  const Config cf = GetParam();
  TestRng rng(300 + cf.n + cf.c * 7 + cf.r);
  const int T = 8;
  const CoupledSystem sys = RandomSystem(rng, cf.n, cf.c, cf.d, cf.r, T);
  const TimeSeries y = SimulateCoupled(sys, {T, 4}).y;
  const CoupledRun serial = RunCoupledFilter(sys, CoupledFilterKind::kBlockDiagonal, y);
  const SlicedRun one = RunCoupledFilterPartitioned(sys, CoupledFilterKind::kBlockDiagonal,
                                                    PartitionByCost(cf.n, 1, cf.granule), cf.granule, y)[0];
  EXPECT_LT(Rel(one.x_filt, serial.x_filt), 1e-11);
  if (cf.r > 0) {
    EXPECT_LT(Rel(one.coupling, serial.coupling), 1e-11);
  }
  for (int P : {2, 3, 5}) {
    const Partition part = PartitionByCost(cf.n, P, cf.granule);
    const std::vector<SlicedRun> runs =
        RunCoupledFilterPartitioned(sys, CoupledFilterKind::kBlockDiagonal, part, cf.granule, y);
    for (int p = 0; p < P; ++p) {
      const Index f = part.first(p), m = part.count(p);
      EXPECT_LE(Rel(runs[p].x_filt, one.x_filt.middleCols(f * cf.c, m * cf.c)), 1e-13) << "P = " << P;
      EXPECT_LE(Rel(runs[p].P_filt, one.P_filt.middleCols(f * cf.c, m * cf.c)), 1e-13) << "P = " << P;
      if (cf.r > 0) {
        EXPECT_LE(Rel(runs[p].coupling, one.coupling), 1e-13) << "P = " << P;
        EXPECT_LE(Rel(runs[p].coupling_cov, one.coupling_cov), 1e-13) << "P = " << P;
      }
    }
  }
}

TEST_P(Partitioned, BandedEqualToSerial) {
  const Config cf = GetParam();
  TestRng rng(400 + cf.n);
  const CoupledSystem sys = RandomSystem(rng, cf.n, cf.c, cf.d, cf.r, 5);
  const TimeSeries y = SimulateCoupled(sys, {5, 8}).y;
  const CoupledRun serial = RunCoupledFilter(sys, CoupledFilterKind::kBanded, y);
  const Partition part = PartitionByCost(cf.n, 3, cf.granule);
  const auto runs = RunCoupledFilterPartitioned(sys, CoupledFilterKind::kBanded, part, cf.granule, y);
  for (int p = 0; p < 3; ++p) {
    EXPECT_LE(Rel(runs[p].x_filt, serial.x_filt.middleCols(part.first(p) * cf.c, part.count(p) * cf.c)), 1e-13);
  }
}

INSTANTIATE_TEST_SUITE_P(Shapes, Partitioned,
                         ::testing::Values(Config{37, 2, 1, 4, 4}, Config{30, 3, 2, 3, 2}, Config{21, 1, 1, 2, 3},
                                           Config{12, 2, 2, 0, 4}, Config{600, 2, 1, 6, 256}),
                         [](const ::testing::TestParamInfo<Config>& i) {
                           const Config& c = i.param;
                           return "n" + std::to_string(c.n) + "c" + std::to_string(c.c) + "d" + std::to_string(c.d) +
                                  "r" + std::to_string(c.r) + "g" + std::to_string(c.granule);
                         });

// No coupling (r = 0): every filter and the simulation avoid products of empty matrices, which Eigen
// sends to BLAS with a leading dimension of 0 (OpenBLAS then prints "On entry to DGEMV parameter number 6
// had an illegal value" on stdout and skips the call), and which the sanitizer build reports as blocks of
// a null pointer (docs/robustness.md, "Sanitizer findings").
TEST(NoCoupling, NoIllegalBlasCallAndBlockDiagonalEqualsBanded) {
  TestRng rng(31);
  const CoupledSystem sys = RandomSystem(rng, 12, 2, 2, 0, 6);
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  const TimeSeries y = SimulateCoupled(sys, {6, 3}).y;
  const CoupledRun serial = RunCoupledFilter(sys, CoupledFilterKind::kBlockDiagonal, y);
  const CoupledRun banded = RunCoupledFilter(sys, CoupledFilterKind::kBanded, y);
  const auto runs =
      RunCoupledFilterPartitioned(sys, CoupledFilterKind::kBlockDiagonal, PartitionByCost(12, 2, 4), 4, y);
  std::fflush(stdout);
  std::fflush(stderr);
  const std::string out = ::testing::internal::GetCapturedStdout() + ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(out.find("illegal"), std::string::npos) << out;
  // Without coupling the block-diagonal filter is exact: it equals the banded filter.
  EXPECT_LT(Rel(serial.x_filt, banded.x_filt), 1e-12);
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].coupling.cols(), 0);
}

TEST(CoupledFilterSlice, RejectsBadInput) {
  EXPECT_THROW(CoupledFilterSlice(CoupledFilterKind::kFull, 0, 4, VectorXd::Zero(2), MatrixXd::Identity(2, 2)), Error);
  EXPECT_THROW(CoupledFilterSlice(CoupledFilterKind::kBlockDiagonal, 3, 4, VectorXd::Zero(2), MatrixXd::Identity(2, 2)),
               Error);  // first not on a granule
  TestRng rng(5);
  const CoupledStep s = RandomStep(rng, 3, 2, 1, 2);
  CoupledFilterSlice f(CoupledFilterKind::kBlockDiagonal, 0, 4, VectorXd::Zero(6), MatrixXd::Identity(2, 6));
  VectorXd y = VectorXd::Zero(3);
  y(1) = INFINITY;  // (NaN is a missing measurement: BlockDiagJob.FewerSubsystemsThanTheGranule...)
  EXPECT_THROW(f.Step(s, y, nullptr), Error);
  EXPECT_THROW(f.Step(s, VectorXd::Zero(4), nullptr), Error);
}

TEST(DistributedMonteCarlo, SplitSumsEqualMonteCarloPerformance) {
  TestRng rng(9);
  const CoupledSystem sys = RandomSystem(rng, 5, 2, 1, 2, 6);
  const Model truth = ToDenseModel(sys);
  const LinearFilter filter = CoupledFilterAsLinearFilter(sys, CoupledFilterKind::kBlockDiagonal, {6});
  MonteCarloOptions opt;
  opt.runs = 23;
  opt.seed = 11;
  opt.store_error_moments = true;
  const MonteCarloResult ref = MonteCarloPerformance(truth, filter, opt);
  // Runs [0, 7), [7, 8), [8, 23) on three "ranks", summed in another order.
  std::vector<double> s = MonteCarloPartialSums(truth, filter, opt, 8, 15);
  CompensatedAdd(MonteCarloPartialSums(truth, filter, opt, 7, 1).data(), s.data(), static_cast<Index>(s.size() / 2));
  CompensatedAdd(MonteCarloPartialSums(truth, filter, opt, 0, 7).data(), s.data(), static_cast<Index>(s.size() / 2));
  const MonteCarloResult split = MonteCarloFromSums(truth, filter, opt, s);
  const MonteCarloResult whole =
      MonteCarloFromSums(truth, filter, opt, MonteCarloPartialSums(truth, filter, opt, 0, opt.runs));
  EXPECT_EQ(split.runs, 23);
  EXPECT_LT(Rel(split.mse, ref.mse), 1e-13);
  EXPECT_LT(Rel(split.mse_std_error, ref.mse_std_error), 1e-10);
  EXPECT_LT(Rel(split.weighted_mse, ref.weighted_mse), 1e-13);
  EXPECT_LT(Rel(split.bias, ref.bias), 1e-12);
  EXPECT_LT(Rel(split.error_moment[6], ref.error_moment[6]), 1e-13);
  EXPECT_LE(Rel(split.mse, whole.mse), 1e-15);
  EXPECT_THROW(MonteCarloPartialSums(truth, filter, opt, 20, 5), Error);
}

// ---- Files ------------------------------------------------------------------------------------------

std::string TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("kfx_distributed_test_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

TEST(ReadNpySlice, MatchesTheFullArrayOnEveryAxisInBothOrders) {
  const std::string dir = TempDir("npy");
  std::vector<double> data(4 * 5 * 3);
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<double>(i) * 0.5 - 3.0;
  WriteNpy(dir + "/c.npy", {4, 5, 3}, data.data());
  // The same array stored in Fortran order (written by hand: kfx writes C order).
  {
    std::vector<double> f(data.size());
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 5; ++j)
        for (int k = 0; k < 3; ++k)
          f[static_cast<size_t>(i + 4 * (j + 5 * k))] = data[static_cast<size_t>((i * 5 + j) * 3 + k)];
    std::string header = "{'descr': '<f8', 'fortran_order': True, 'shape': (4, 5, 3), }";
    header += std::string(118 - header.size(), ' ') + "\n";
    std::ofstream out(dir + "/f.npy", std::ios::binary);
    out.write("\x93NUMPY\x01\x00", 8);
    const unsigned short len = static_cast<unsigned short>(header.size());
    out.put(static_cast<char>(len & 0xff)).put(static_cast<char>(len >> 8));
    out << header;
    out.write(reinterpret_cast<const char*>(f.data()), static_cast<std::streamsize>(f.size() * sizeof(double)));
  }
  for (const std::string file : {"/c.npy", "/f.npy"}) {
    const NpyArray full = ReadNpy(dir + file);
    ASSERT_EQ(full.data, data) << file;
    const std::vector<std::int64_t> shape = {4, 5, 3};
    for (int axis = 0; axis < 3; ++axis) {
      const std::int64_t start = 1, count = shape[static_cast<size_t>(axis)] - 2;
      const NpyArray s = ReadNpySlice(dir + file, axis, start, count);
      std::vector<std::int64_t> want = shape;
      want[static_cast<size_t>(axis)] = count;
      ASSERT_EQ(s.shape, want);
      size_t q = 0;
      for (int i = 0; i < want[0]; ++i)
        for (int j = 0; j < want[1]; ++j)
          for (int k = 0; k < want[2]; ++k) {
            const int ii = i + (axis == 0), jj = j + (axis == 1), kk = k + (axis == 2);
            EXPECT_EQ(s.data[q++], data[static_cast<size_t>((ii * 5 + jj) * 3 + kk)]) << file << " axis " << axis;
          }
    }
    EXPECT_THROW(ReadNpySlice(dir + file, 3, 0, 1), Error);
    EXPECT_THROW(ReadNpySlice(dir + file, 1, 4, 2), Error);
  }
}

TEST(CoupledModelFile, SlicesReadByOffsetEqualTheSlicedSystem) {
  const std::string dir = TempDir("model");
  TestRng rng(12);
  const Index n = 9, c = 2, d = 2, r = 3;
  MatrixXd P0(c, n * c);
  for (Index i = 0; i < n; ++i) P0.middleCols(i * c, c) = rng.Spd(c, 0.5);
  const VectorXd x0 = rng.Gaussian(n * c, 1);  // one draw per statement, in GCC's former order (TestRng)
  const CoupledSystem sys(RandomStep(rng, n, c, d, r), x0, P0);
  SaveCoupledModel(dir + "/m.json", sys);
  const CoupledModelHeader h = ReadCoupledModelHeader(dir + "/m.json");
  EXPECT_EQ(h.n, n);
  EXPECT_EQ(h.r, r);
  for (auto [f, m] : {std::pair<Index, Index>{0, 9}, {2, 4}, {8, 1}}) {
    const CoupledSystem a = LoadCoupledModelSlice(dir + "/m.json", f, m);
    const CoupledSystem b = SliceCoupledSystem(sys, f, m);
    EXPECT_EQ(a.step(1)->F, b.step(1)->F);
    EXPECT_EQ(a.step(1)->H, b.step(1)->H);
    EXPECT_EQ(a.step(1)->V, b.step(1)->V);
    EXPECT_EQ(a.step(1)->R, b.step(1)->R);
    EXPECT_EQ(a.step(1)->G, b.step(1)->G);
    EXPECT_EQ(a.step(1)->U, b.step(1)->U);
    EXPECT_EQ(a.m0(), b.m0());
    EXPECT_EQ(a.P0_blocks(), b.P0_blocks());
  }
  EXPECT_THROW(LoadCoupledModelSlice(dir + "/m.json", 5, 5), Error);
  // Inline (identical) fields.
  std::ofstream(dir + "/inline.json") << R"({"format": "kfx-coupled-model", "n": 4, "c": 1, "d": 1, "r": 1,
    "F": 0.9, "H": 1, "V": 0.1, "R": 0.5, "G": 1, "U": [[0.2]], "P0": 1})";
  const CoupledSystem in = LoadCoupledModelSlice(dir + "/inline.json", 1, 2);
  EXPECT_EQ(in.n(), 2);
  EXPECT_EQ(in.step(1)->F(0, 1), 0.9);
  std::ofstream(dir + "/bad.json") << R"({"format": "kfx-coupled-model", "n": 4, "c": 1, "d": 1, "r": 1,
    "F": [1, 2], "H": 1, "V": 0.1, "R": 0.5, "G": 1, "U": [[0.2]], "P0": 1})";
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LoadCoupledModelSlice(dir + "/bad.json", 0, 4); }, "field 'F'"));
}

// Ranks emulated by threads: a reducer that waits for all of them and adds their buffers.
class ThreadReducer {
 public:
  explicit ThreadReducer(int ranks) : ranks_(ranks) {}
  Reducer For() {
    return [this](std::vector<double>& pairs) {
      std::unique_lock<std::mutex> lock(m_);
      const long gen = generation_;
      if (arrived_ == 0) sum_.assign(pairs.size(), 0.0);
      CompensatedAdd(pairs.data(), sum_.data(), static_cast<Index>(pairs.size() / 2));
      if (++arrived_ == ranks_) {
        result_ = sum_;
        arrived_ = 0;
        ++generation_;
        cv_.notify_all();
      } else {
        cv_.wait(lock, [&] { return generation_ != gen; });
      }
      pairs = result_;
    };
  }

 private:
  int ranks_, arrived_ = 0;
  long generation_ = 0;
  std::vector<double> sum_, result_;
  std::mutex m_;
  std::condition_variable cv_;
};

TEST(BlockDiagJob, SlicedOutputOnThreeRanksEqualsOneRankAndTheSerialFilter) {
  const std::string dir = TempDir("job");
  TestRng rng(13);
  const Index n = 20, c = 2, d = 1, r = 3;
  MatrixXd P0(c, n * c);
  for (Index i = 0; i < n; ++i) P0.middleCols(i * c, c) = rng.Spd(c, 0.5);
  const CoupledSystem sys(RandomStep(rng, n, c, d, r), VectorXd::Zero(n * c), P0);
  SaveCoupledModel(dir + "/m.json", sys);
  const TimeSeries y = SimulateCoupled(sys, {7, 2}).y;
  WriteNpyMatrix(dir + "/y.npy", y);
  BlockDiagJob job;
  job.model = dir + "/m.json";
  job.data = dir + "/y.npy";
  job.granule = 4;
  job.out_dir = dir + "/one";
  RunBlockDiagJob(job, 0, 1, nullptr);
  job.out_dir = dir + "/three";
  ThreadReducer red(3);
  std::vector<std::thread> threads;
  std::vector<std::string> errors(3);
  for (int p = 0; p < 3; ++p) {
    threads.emplace_back([&, p] {
      try {
        RunBlockDiagJob(job, p, 3, red.For());
      } catch (const std::exception& e) {
        errors[static_cast<size_t>(p)] = e.what();
      }
    });
  }
  for (auto& t : threads) t.join();
  for (const auto& e : errors) EXPECT_EQ(e, "");
  const CoupledRun serial = RunCoupledFilter(sys, CoupledFilterKind::kBlockDiagonal, y);
  const TimeSeries x1 = ReadBlockDiagStates(dir + "/one"), x3 = ReadBlockDiagStates(dir + "/three");
  EXPECT_LE(Rel(x3, x1), 1e-13);
  EXPECT_LT(Rel(x1, serial.x_filt), 1e-11);
  EXPECT_LT(Rel(ReadNpyMatrix(dir + "/three/coupling_mean.npy"), serial.coupling), 1e-11);
  int slices = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/three")) {
    slices += e.path().filename().string().rfind("x_filt.", 0) == 0;
  }
  EXPECT_EQ(slices, 3);
  // Bad data on every rank: every rank raises, none waits.
  job.data = dir + "/m.json";
  job.out_dir = dir + "/bad";
  EXPECT_THROW(RunBlockDiagJob(job, 0, 1, nullptr), Error);
}

// Runs the job on `ranks` threads; returns each rank's error message ("" for none).
std::vector<std::string> RunJobOnThreads(const BlockDiagJob& job, int ranks) {
  ThreadReducer red(ranks);
  std::vector<std::thread> threads;
  std::vector<std::string> errors(static_cast<size_t>(ranks));
  for (int p = 0; p < ranks; ++p) {
    threads.emplace_back([&, p] {
      try {
        RunBlockDiagJob(job, p, ranks, red.For());
      } catch (const std::exception& e) {
        errors[static_cast<size_t>(p)] = e.what();
      }
    });
  }
  for (auto& t : threads) t.join();
  return errors;
}

// Issue 20, classes 1 and 14: n = 1 and 3 subsystems with the default granule 1024 on 1, 2 and 4 ranks (ranks
// with no subsystems), both filters, with missing (NaN) measurements: the serial filter's states. Before:
// the empty ranks threw "expected a multiple of the granule" (MPI_ERR_TRUNCATE under mpirun) and NaN was
// rejected.
TEST(BlockDiagJob, FewerSubsystemsThanTheGranuleAndRanksWithMissingMeasurements) {
  const std::string dir = TempDir("few");
  for (const Index n : {Index{1}, Index{3}}) {
    TestRng rng(17 + n);
    const Index c = 2, d = 2, r = 2;
    MatrixXd P0(c, n * c);
    for (Index i = 0; i < n; ++i) P0.middleCols(i * c, c) = rng.Spd(c, 0.5);
    const CoupledSystem sys(RandomStep(rng, n, c, d, r), VectorXd::Zero(n * c), P0);
    const std::string model = dir + "/m" + std::to_string(n) + ".json";
    SaveCoupledModel(model, sys);
    TimeSeries y = SimulateCoupled(sys, {9, 2}).y;
    for (Index i = 0; i < y.size(); i += 5) y.data()[i] = NAN;
    WriteNpyMatrix(dir + "/y.npy", y);
    for (const auto kind : {CoupledFilterKind::kBlockDiagonal, CoupledFilterKind::kBanded}) {
      const CoupledRun serial = RunCoupledFilter(sys, kind, y);
      ASSERT_TRUE(serial.x_filt.allFinite());
      for (const int ranks : {1, 2, 4}) {
        BlockDiagJob job;
        job.model = model;
        job.data = dir + "/y.npy";
        job.kind = kind;
        job.out_dir = dir + "/out-" + std::to_string(n) + ToString(kind) + std::to_string(ranks);
        for (const std::string& e : RunJobOnThreads(job, ranks)) EXPECT_EQ(e, "") << ranks << " ranks";
        EXPECT_LT(Rel(ReadBlockDiagStates(job.out_dir), serial.x_filt), 1e-11) << ranks << " ranks";
      }
    }
  }
}

// Issue 20, class 2: one rank cannot write its slice. Every rank ends (no rank waits), exactly one error is
// the failing rank's own, and the directory, complete from an earlier run, is now visibly incomplete (no
// metadata.json). Before: the other ranks succeeded and rank 0 wrote metadata.json listing the missing file.
TEST(BlockDiagJob, OneRankThatCannotWriteFailsTheJobWithOneMessageAndNoMarker) {
  const std::string dir = TempDir("fail");
  TestRng rng(29);
  const Index n = 12, c = 2, d = 1, r = 2;
  MatrixXd P0(c, n * c);
  for (Index i = 0; i < n; ++i) P0.middleCols(i * c, c) = rng.Spd(c, 0.5);
  const CoupledSystem sys(RandomStep(rng, n, c, d, r), VectorXd::Zero(n * c), P0);
  SaveCoupledModel(dir + "/m.json", sys);
  WriteNpyMatrix(dir + "/y.npy", SimulateCoupled(sys, {5, 2}).y);
  BlockDiagJob job;
  job.model = dir + "/m.json";
  job.data = dir + "/y.npy";
  job.granule = 4;
  job.out_dir = dir + "/out";
  for (const std::string& e : RunJobOnThreads(job, 3)) ASSERT_EQ(e, "");
  ASSERT_TRUE(std::filesystem::exists(job.out_dir + "/metadata.json"));
  const std::string slice1 = job.out_dir + "/x_filt.4-8.npy";  // rank 1's subsystems [4, 8)
  ASSERT_TRUE(std::filesystem::remove(slice1));
  std::filesystem::create_directories(slice1 + "/occupied");
  const std::vector<std::string> errors = RunJobOnThreads(job, 3);
  int own = 0;
  for (const std::string& e : errors) {
    EXPECT_NE(e, "");
    if (e.find("on another rank") == std::string::npos) {
      ++own;
      EXPECT_NE(e.find("x_filt.4-8.npy"), std::string::npos) << e;
    }
  }
  EXPECT_EQ(own, 1);
  EXPECT_NE(errors[1].find("x_filt.4-8.npy"), std::string::npos) << errors[1];
  EXPECT_FALSE(std::filesystem::exists(job.out_dir + "/metadata.json"));
  EXPECT_THROW(ReadBlockDiagStates(job.out_dir), Error);
}

// A malformed metadata.json is a kfx::Error naming it (before: nlohmann's exceptions, or a slice outside n).
TEST(BlockDiagJob, MalformedMetadataIsAnErrorNamingTheFile) {
  const std::string dir = TempDir("meta");
  const std::string head = R"({"format": "kfx-blockdiag-output", "n": 2, "c": 1, "d": 1, "r": 0, "steps": 1, )";
  WriteNpyMatrix(dir + "/x.npy", MatrixXd::Zero(2, 1));
  for (const std::string slices :
       {R"("slices": 3)", R"("slices": [1])", R"("slices": [{"first": "a"}])",
        R"("slices": [{"first": 0, "count": 1}])", R"("slices": [{"first": 0, "count": 1, "x_filt": 7}])",
        R"("slices": [{"first": 1, "count": 9223372036854775807, "x_filt": "x.npy"}])",
        R"("slices": [{"first": 0, "count": 1, "x_filt": "x.npy"}])"}) {
    std::ofstream(dir + "/metadata.json") << head << slices << "}";
    EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadBlockDiagStates(dir); }, dir + "/metadata.json")) << slices;
  }
}

}  // namespace
}  // namespace kfx
