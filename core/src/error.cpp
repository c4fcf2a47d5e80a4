#include "ajar/core/error.hpp"

#include <array>

#include "ajar/core/words.hpp"

namespace ajar {
namespace {

constexpr std::array kErrorTable{
#define AJAR_ERROR_ROW(enumerator, code, name, meaning, action) \
  ErrorInfo{ErrorCode::enumerator, #name, meaning, action},
    AJAR_ERROR_CODES(AJAR_ERROR_ROW)
#undef AJAR_ERROR_ROW
};

constexpr bool in_code_order() noexcept {
  for (std::size_t i = 1; i < kErrorTable.size(); ++i) {
    if (kErrorTable[i - 1].value >= kErrorTable[i].value) return false;
  }
  return true;
}
static_assert(in_code_order(), "the error table lists each code once, in code order");
static_assert(words_are_unique(kErrorTable), "every error code has its own name");

}  // namespace

std::span<const ErrorInfo> error_table() noexcept {
  return kErrorTable;
}

const ErrorInfo* error_info(ErrorCode code) noexcept {
  for (const auto& row : kErrorTable) {
    if (row.value == code) return &row;
  }
  return nullptr;
}

std::string_view to_string(ErrorCode code) noexcept {
  return word_of(kErrorTable, code, "UNKNOWN");
}

std::optional<ErrorCode> error_code_from_string(std::string_view name) noexcept {
  return value_of(kErrorTable, name);
}

}  // namespace ajar
