#pragma once
// One way to turn kfx's enums into text and back. Each enum E has, next to its declaration,
// `const char* ToString(E)` and the list of its values `EnumValues<E>::kAll`; ParseEnum reads what
// ToString writes (the CLI's and the Python bindings' option strings), and names the argument when the
// text is none of them.
#include <string>
#include <vector>

#include "kfx/error.hpp"

namespace kfx {

/// Specialized next to each enum: `static constexpr E kAll[] = {...};`.
template <typename E>
struct EnumValues;

/// The texts of every value of E, in declaration order.
template <typename E>
std::vector<std::string> EnumNames() {
  std::vector<std::string> names;
  for (E v : EnumValues<E>::kAll) names.emplace_back(ToString(v));
  return names;
}

/// The value of E whose ToString is `text`.
/// @throws kfx::Error "<argument>: expected one of 'a', 'b', ..., got '<text>'".
template <typename E>
E ParseEnum(const std::string& argument, const std::string& text) {
  std::string expected;
  for (E v : EnumValues<E>::kAll) {
    if (text == ToString(v)) return v;
    expected += (expected.empty() ? "'" : ", '") + std::string(ToString(v)) + "'";
  }
  throw Error(argument + ": expected one of " + expected + ", got '" + text + "'");
}

}  // namespace kfx
