#pragma once
// Each paper's reproduction (`kfx reproduce <id>`), one src/reproduce/<paper>.cpp per paper, referenced
// from the table in src/reproduce/reproduce.cpp.
#include "kfx/reproduce.hpp"

namespace kfx::detail {

PaperReport ReproduceAaltoSpatial(const ReproduceOptions& options);   // aalto_spatial.cpp
PaperReport ReproduceBernstein(const ReproduceOptions& options);      // bernstein.cpp
PaperReport ReproducePatelToda(const ReproduceOptions& options);      // patel_toda.cpp
PaperReport ReproduceBlockDiagonal(const ReproduceOptions& options);  // block_diagonal.cpp
PaperReport ReproduceAaltoTemporal(const ReproduceOptions& options);  // aalto_temporal.cpp

}  // namespace kfx::detail
