#pragma once
// Each paper's reproduction (`kfx reproduce <id>`), one src/reproduce_<paper>.cpp per paper, referenced
// from the table in src/reproduce.cpp.
#include "kfx/reproduce.hpp"

namespace kfx::detail {

PaperReport ReproduceAaltoSpatial(const ReproduceOptions& options);   // src/reproduce_aalto_spatial.cpp
PaperReport ReproduceBernstein(const ReproduceOptions& options);      // src/reproduce_bernstein.cpp
PaperReport ReproducePatelToda(const ReproduceOptions& options);      // src/reproduce_patel_toda.cpp
PaperReport ReproduceBlockDiagonal(const ReproduceOptions& options);  // src/reproduce_block_diagonal.cpp
PaperReport ReproduceAaltoTemporal(const ReproduceOptions& options);  // src/reproduce_aalto_temporal.cpp

}  // namespace kfx::detail
