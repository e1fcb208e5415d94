# BLAS + LAPACK (OpenBLAS preferred) and SLICOT as the targets kfx_blas_lapack and kfx_slicot. Used by
# the build and, installed next to kfxConfig.cmake, by find_package(kfx): the same search both times,
# through CMake's FindBLAS/FindLAPACK and the default library paths (no distribution-specific path).
# Another BLAS: -DBLA_VENDOR=... (FindBLAS names; kfx is tested with OpenBLAS). SLICOT elsewhere:
# -DKFX_SLICOT_LIBRARY=/path/to/libslicot.so or CMAKE_PREFIX_PATH.
# Debian/Ubuntu: libopenblas-dev, libslicot-dev.
include_guard(GLOBAL)
if(NOT TARGET kfx_blas_lapack)
  if(NOT DEFINED BLA_VENDOR)
    set(BLA_VENDOR OpenBLAS)
    set(kfx_default_vendor ON)
  endif()
  find_package(BLAS QUIET)
  find_package(LAPACK QUIET)
  if(kfx_default_vendor AND NOT (BLAS_FOUND AND LAPACK_FOUND))
    unset(BLA_VENDOR)  # no OpenBLAS: any BLAS and LAPACK CMake can find
    find_package(BLAS QUIET)
    find_package(LAPACK QUIET)
  endif()
  unset(kfx_default_vendor)
  if(NOT (BLAS_FOUND AND LAPACK_FOUND))
    message(FATAL_ERROR "kfx: BLAS/LAPACK not found (Debian/Ubuntu: libopenblas-dev; or set BLA_VENDOR)")
  endif()
  add_library(kfx_blas_lapack INTERFACE IMPORTED)
  set_target_properties(kfx_blas_lapack PROPERTIES INTERFACE_LINK_LIBRARIES "LAPACK::LAPACK;BLAS::BLAS")
endif()
if(NOT TARGET kfx_slicot)
  find_library(KFX_SLICOT_LIBRARY NAMES slicot DOC "SLICOT library")
  if(NOT KFX_SLICOT_LIBRARY)
    message(FATAL_ERROR "kfx: SLICOT not found (Debian/Ubuntu: libslicot-dev; or -DKFX_SLICOT_LIBRARY=...)")
  endif()
  add_library(kfx_slicot INTERFACE IMPORTED)
  set_target_properties(kfx_slicot PROPERTIES INTERFACE_LINK_LIBRARIES "${KFX_SLICOT_LIBRARY};kfx_blas_lapack")
endif()
