// The one enum <-> word mechanism of the code base: a value's word is a row of a constexpr table
// (Word<T>, or any row with `value` and `word` members, such as the error table's), and both
// directions read that table. Wire enums, config words, the arm's serial words, error names and the
// few printed enums (frames, lifecycle states, call outcomes) all are such tables; no switch maps a
// value to its word.
#pragma once

#include <cstddef>
#include <iterator>
#include <optional>
#include <string_view>
#include <type_traits>

namespace ajar {

// A value and the word it is written as.
template <typename T>
struct Word {
  T value;
  std::string_view word;
};

// The word of `value` in `rows`; `unknown` when no row has it (a value from a newer peer).
template <typename Rows, typename T>
constexpr std::string_view word_of(const Rows& rows, const T& value,
                                   std::string_view unknown = "unknown") noexcept {
  for (const auto& row : rows) {
    if (row.value == value) return row.word;
  }
  return unknown;
}

// The value whose word is `word` (exact, case-sensitive); nullopt when no row has it.
template <typename Rows>
constexpr auto value_of(const Rows& rows, std::string_view word) noexcept
    -> std::optional<std::remove_cvref_t<decltype(std::begin(rows)->value)>> {
  for (const auto& row : rows) {
    if (row.word == word) return row.value;
  }
  return std::nullopt;
}

// True when the rows list the values 0, 1, 2, ... in order (a wire enum's table: every value in
// 0..size-1 has its word, and the i-th row is value i).
template <typename Rows>
constexpr bool values_are_indices(const Rows& rows) noexcept {
  std::size_t i = 0;
  for (const auto& row : rows) {
    if (static_cast<std::size_t>(row.value) != i++) return false;
  }
  return true;
}

// True when no two rows share a value or a word.
template <typename Rows>
constexpr bool words_are_unique(const Rows& rows) noexcept {
  for (auto a = std::begin(rows); a != std::end(rows); ++a) {
    for (auto b = std::next(a); b != std::end(rows); ++b) {
      if (a->value == b->value || a->word == b->word) return false;
    }
  }
  return true;
}

}  // namespace ajar
