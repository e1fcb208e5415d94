#pragma once
// Each paper's reproduction (`kfx reproduce <id>`), one src/reproduce/<paper>.cpp per paper, referenced
// from the table in src/reproduce/reproduce.cpp, and the rows they build.
#include <optional>
#include <string>
#include <utility>

#include "kfx/reproduce.hpp"

namespace kfx::detail {

/// One row of a reproduction: the paper's number `published` (if it prints one) beside kfx's `value`;
/// "reproduced" when their relative difference is at most `tolerance` (ReproduceItem::status).
inline ReproduceItem Item(std::string key, std::string description, std::optional<double> published, double value,
                          double tolerance, std::string note = "") {
  ReproduceItem it;
  it.key = std::move(key);
  it.description = std::move(description);
  it.published = published;
  it.value = value;
  it.tolerance = tolerance;
  it.note = std::move(note);
  return it;
}

/// A row the paper prints no number for (status "new").
inline ReproduceItem NewItem(std::string key, std::string description, double value, std::string note = "") {
  return Item(std::move(key), std::move(description), std::nullopt, value, 0.0, std::move(note));
}

PaperReport ReproduceAaltoSpatial(const ReproduceOptions& options);   // aalto_spatial.cpp
PaperReport ReproduceBernstein(const ReproduceOptions& options);      // bernstein.cpp
PaperReport ReproducePatelToda(const ReproduceOptions& options);      // patel_toda.cpp
PaperReport ReproduceBlockDiagonal(const ReproduceOptions& options);  // block_diagonal.cpp
PaperReport ReproduceAaltoTemporal(const ReproduceOptions& options);  // aalto_temporal.cpp

}  // namespace kfx::detail
