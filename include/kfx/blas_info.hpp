#pragma once
// The BLAS/LAPACK kfx runs on: which libraries, which kernel, how fast, and whether a better kernel of
// the same library fits the CPU (issue 24; `kfx info`, docs/performance.md). Debian's OpenBLAS is built
// with DYNAMIC_ARCH: it picks its kernels from the CPU when it loads, and falls back to older kernels
// (Prescott, Haswell) on CPUs newer than the library. OPENBLAS_CORETYPE overrides that choice, but only
// when set before the library loads; ChooseBlasKernel() is the decision, CheckBlasKernel() the self-test
// that any choice must pass before it is kept.
#include <string>

namespace kfx {

/// Vector instruction sets, in order: the best one a CPU supports (and its OS enables), or the one a
/// BLAS kernel is written for.
enum class SimdLevel { kUnknown = 0, kSse = 1, kAvx = 2, kAvx2 = 3, kAvx512 = 4 };

/// "unknown", "SSE", "AVX", "AVX2" or "AVX-512".
const char* ToString(SimdLevel level);

/// What the CPU offers (x86 cpuid and xgetbv; kUnknown elsewhere).
struct CpuInfo {
  std::string vendor;                    ///< "GenuineIntel", "AuthenticAMD", ... ("" when unknown)
  std::string model;                     ///< brand string, e.g. "AMD EPYC"
  SimdLevel best = SimdLevel::kUnknown;  ///< best level with OS support (AVX2 needs FMA; AVX-512 F, BW, DQ, VL)
};

/// The CPU this process runs on.
CpuInfo DetectCpu();

/// The instruction set an OpenBLAS kernel ("core name", openblas_get_corename()) is written for:
/// Prescott, Core2, Nehalem, Atom, Opteron, Barcelona, ... -> kSse; Sandybridge, Bulldozer, Piledriver,
/// Steamroller, Excavator -> kAvx; Haswell, Zen -> kAvx2; SkylakeX, Cooperlake, SapphireRapids -> kAvx512;
/// any other name -> kUnknown. Case-insensitive.
SimdLevel KernelSimdLevel(const std::string& core_name);

/// The outcome of ChooseBlasKernel().
struct BlasKernelChoice {
  std::string coretype;  ///< the OPENBLAS_CORETYPE to load the library with; "" = keep the library's choice
  std::string reason;    ///< one sentence: why (shown by `kfx info`)
};

/// The decision table: which OpenBLAS kernel to ask for, given the kernel the library chose by itself
/// (`core_name`, "" when the BLAS is not OpenBLAS) and the CPU. A kernel is asked for only when the CPU
/// supports a better level than the chosen kernel's and neither the user (`user_coretype`, the value of
/// OPENBLAS_CORETYPE, "" when unset) nor `disabled` (KFX_BLAS_KERNEL=library) says otherwise:
/// AVX-512 -> SkylakeX (Cooperlake and SapphireRapids add bfloat16 routines, not faster DGEMM), AVX2 -> Zen on AMD and
/// Haswell elsewhere, AVX -> Sandybridge. Unknown kernel names and unknown CPUs keep the library's choice.
BlasKernelChoice ChooseBlasKernel(const std::string& core_name, const CpuInfo& cpu, const std::string& user_coretype,
                                  bool disabled);

/// The BLAS and LAPACK in this process.
struct BlasInfo {
  std::string blas_library;    ///< the shared object that defines dgemm_ (dladdr), "" when unknown
  std::string lapack_library;  ///< the shared object that defines dgetrf_
  std::string lapack_version;  ///< from ILAVER, e.g. "3.11.0"
  bool openblas = false;       ///< the OpenBLAS query functions exist
  std::string config;          ///< openblas_get_config(), "" for other BLAS
  std::string core_name;       ///< openblas_get_corename(), "" for other BLAS
  int threads = 0;             ///< openblas_get_num_threads(), 0 when unknown
};

/// Queries the libraries loaded in this process. The OpenBLAS functions are declared weak, so that
/// kfx links and runs with any other BLAS (the OpenBLAS fields then stay empty).
BlasInfo QueryBlasInfo();

/// The DGEMM rate in GFLOP/s (2 n^3 flops per product of two n x n matrices, one call repeated for
/// about `seconds`, the best of the calls). Positive and finite.
/// @throws kfx::Error when n < 1 or seconds is not in (0, 60]
double MeasureDgemmRate(int n = 400, double seconds = 0.2);

/// The self-test of the kernel in use: DGEMM (all four transpose cases, sizes 1 to 47, beta != 0) and
/// DSYMV (both triangles, sizes 1 to 33) against plain loops, each entry within 64 n eps of the sum of
/// the absolute values of its terms. True when every entry passes; *max_error (may be null) receives
/// the largest error relative to that bound.
bool CheckBlasKernel(double* max_error = nullptr);

}  // namespace kfx
