# OpenBLAS (BLAS + LAPACK in one library) and SLICOT, as imported targets.
# Debian: libopenblas-dev, libslicot-dev.
if(NOT TARGET kfx_blas_lapack)
  find_library(KFX_OPENBLAS_LIBRARY NAMES openblas
    PATHS /usr/lib/x86_64-linux-gnu/openblas-pthread /usr/lib/aarch64-linux-gnu/openblas-pthread)
  if(NOT KFX_OPENBLAS_LIBRARY)
    message(FATAL_ERROR "kfx: OpenBLAS not found (Debian package libopenblas-dev)")
  endif()
  add_library(kfx_blas_lapack INTERFACE IMPORTED)
  set_target_properties(kfx_blas_lapack PROPERTIES INTERFACE_LINK_LIBRARIES "${KFX_OPENBLAS_LIBRARY}")
endif()
if(NOT TARGET kfx_slicot)
  find_library(KFX_SLICOT_LIBRARY NAMES slicot)
  if(NOT KFX_SLICOT_LIBRARY)
    message(FATAL_ERROR "kfx: SLICOT not found (Debian package libslicot-dev)")
  endif()
  add_library(kfx_slicot INTERFACE IMPORTED)
  set_target_properties(kfx_slicot PROPERTIES INTERFACE_LINK_LIBRARIES "${KFX_SLICOT_LIBRARY}")
endif()
