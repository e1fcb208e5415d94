// kfx/blas_info.hpp: the kernel decision table (every row), the kernel classification, the self-test of
// the kernel in use, the DGEMM rate and the library query.
#include "kfx/blas_info.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "kfx/error.hpp"

namespace kfx {
namespace {

CpuInfo Cpu(const char* vendor, SimdLevel best) {
  CpuInfo cpu;
  cpu.vendor = vendor;
  cpu.best = best;
  return cpu;
}

TEST(BlasInfo, KernelLevels) {
  EXPECT_EQ(KernelSimdLevel("Prescott"), SimdLevel::kSse);
  EXPECT_EQ(KernelSimdLevel("NEHALEM"), SimdLevel::kSse);
  EXPECT_EQ(KernelSimdLevel("Sandybridge"), SimdLevel::kAvx);
  EXPECT_EQ(KernelSimdLevel("Haswell"), SimdLevel::kAvx2);
  EXPECT_EQ(KernelSimdLevel("zen"), SimdLevel::kAvx2);
  EXPECT_EQ(KernelSimdLevel("SkylakeX"), SimdLevel::kAvx512);
  EXPECT_EQ(KernelSimdLevel("Cooperlake"), SimdLevel::kAvx512);
  EXPECT_EQ(KernelSimdLevel("NeoverseN1"), SimdLevel::kUnknown);
  EXPECT_EQ(KernelSimdLevel(""), SimdLevel::kUnknown);
  EXPECT_STREQ(ToString(SimdLevel::kAvx512), "AVX-512");
}

// The decision table of docs/performance.md, one row per case.
TEST(BlasInfo, ChooseKernelDecisionTable) {
  const CpuInfo intel512 = Cpu("GenuineIntel", SimdLevel::kAvx512), amd512 = Cpu("AuthenticAMD", SimdLevel::kAvx512);
  const CpuInfo intel2 = Cpu("GenuineIntel", SimdLevel::kAvx2), amd2 = Cpu("AuthenticAMD", SimdLevel::kAvx2);
  const CpuInfo avx = Cpu("GenuineIntel", SimdLevel::kAvx), sse = Cpu("GenuineIntel", SimdLevel::kSse);
  // A fallback kernel below the CPU: the CPU's best kernel of the same library.
  EXPECT_EQ(ChooseBlasKernel("Prescott", intel512, "", false).coretype, "SkylakeX");
  EXPECT_EQ(ChooseBlasKernel("Haswell", amd512, "", false).coretype, "SkylakeX");
  EXPECT_EQ(ChooseBlasKernel("Prescott", intel2, "", false).coretype, "Haswell");
  EXPECT_EQ(ChooseBlasKernel("Barcelona", amd2, "", false).coretype, "Zen");
  EXPECT_EQ(ChooseBlasKernel("Core2", avx, "", false).coretype, "Sandybridge");
  // A kernel at or above the CPU's level: kept.
  EXPECT_EQ(ChooseBlasKernel("SkylakeX", intel512, "", false).coretype, "");
  EXPECT_EQ(ChooseBlasKernel("Haswell", intel2, "", false).coretype, "");
  EXPECT_EQ(ChooseBlasKernel("Zen", amd2, "", false).coretype, "");
  EXPECT_EQ(ChooseBlasKernel("Prescott", sse, "", false).coretype, "");
  // The user decides, or turned the choice off; not OpenBLAS; unknown kernel or CPU: kept.
  EXPECT_EQ(ChooseBlasKernel("Prescott", intel512, "Prescott", false).coretype, "");
  EXPECT_EQ(ChooseBlasKernel("Prescott", intel512, "", true).coretype, "");
  EXPECT_EQ(ChooseBlasKernel("", intel512, "", false).coretype, "");
  EXPECT_EQ(ChooseBlasKernel("NeoverseN1", intel512, "", false).coretype, "");
  EXPECT_EQ(ChooseBlasKernel("Prescott", Cpu("", SimdLevel::kUnknown), "", false).coretype, "");
  // Every outcome says why.
  EXPECT_NE(ChooseBlasKernel("Prescott", intel512, "", false).reason.find("below"), std::string::npos);
  EXPECT_NE(ChooseBlasKernel("Prescott", intel512, "Haswell", false).reason.find("OPENBLAS_CORETYPE"),
            std::string::npos);
}

TEST(BlasInfo, CpuDetectionIsConsistent) {
  const CpuInfo cpu = DetectCpu();
#if defined(__x86_64__)
  EXPECT_FALSE(cpu.vendor.empty());
  EXPECT_GE(cpu.best, SimdLevel::kSse);
#ifdef __AVX2__
  EXPECT_GE(cpu.best, SimdLevel::kAvx2);  // this test itself was compiled for AVX2 and runs
#endif
#endif
}

TEST(BlasInfo, KernelInUsePassesItsSelfTest) {
  double err = -1;
  EXPECT_TRUE(CheckBlasKernel(&err));
  EXPECT_GE(err, 0.0);
  EXPECT_LE(err, 1.0);
}

TEST(BlasInfo, DgemmRateIsPositiveAndFinite) {
  const double rate = MeasureDgemmRate(64, 0.01);
  EXPECT_TRUE(std::isfinite(rate));
  EXPECT_GT(rate, 0.0);
  EXPECT_THROW(MeasureDgemmRate(0, 0.1), Error);
  EXPECT_THROW(MeasureDgemmRate(64, 0.0), Error);
  EXPECT_THROW(MeasureDgemmRate(64, 100.0), Error);
}

TEST(BlasInfo, QueryFindsTheLibraries) {
  const BlasInfo info = QueryBlasInfo();
  EXPECT_FALSE(info.blas_library.empty());
  EXPECT_FALSE(info.lapack_library.empty());
  if (info.openblas) {  // kfx's default build links OpenBLAS
    EXPECT_FALSE(info.core_name.empty());
    EXPECT_NE(info.config.find("OpenBLAS"), std::string::npos);
    EXPECT_GE(info.threads, 1);
  }
}

}  // namespace
}  // namespace kfx
