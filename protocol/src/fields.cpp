// visit_fields(): the message tables walked (walk.hpp) by an IO that hands each scalar's wire name
// and value to a FieldVisitor (fields.hpp), with the same stops as the Writer.
#include "ajar/protocol/fields.hpp"

#include <type_traits>

#include "walk.hpp"

namespace ajar::protocol {

using namespace detail;

namespace {

class Visiting {
 public:
  Visiting(FieldVisitor& visitor, std::uint8_t minor) noexcept : visitor_(visitor), minor_(minor) {}
  std::uint8_t minor() const noexcept { return minor_; }
  bool since(std::uint8_t m) const noexcept { return minor_ >= m; }

  template <typename W, typename V>
  void scalar(const V& v, const char* name) noexcept {
    visitor_.field(name, value_of(v));
  }
  template <std::size_t N>
  void str(const FixedString<N>& s, const char* name) noexcept {
    visitor_.field(name, FieldText{s.view()});
  }
  template <std::size_t N>
  void bytes(const FixedBytes<N>& b, const char* name) noexcept {
    visitor_.field(name, std::span<const std::uint8_t>(b.bytes.data(), b.length));
  }
  // A field that sizes the payload: past an invalid one the layout is not defined (Writer: same).
  bool sizes(bool valid, ErrorCode, const char*, std::uint64_t, const char*) noexcept {
    ok_ = ok_ && valid;
    return ok_;
  }
  template <typename T>
  const T* body(const AckBody& b) noexcept {
    const T* p = std::get_if<T>(&b);
    ok_ = ok_ && p != nullptr;
    return p;
  }
  bool ok() const noexcept { return ok_; }

 private:
  template <typename V>
  static FieldValue value_of(const V& v) noexcept {
    if constexpr (std::is_same_v<V, bool>) {
      return v;
    } else if constexpr (std::is_same_v<V, float> || std::is_same_v<V, double>) {
      return v;
    } else if constexpr (std::is_enum_v<V>) {
      // to_string by argument-dependent lookup: protocol's EnumWords, core's, ErrorCode's names,
      // MessageType's message names. A code or type this version does not know (a newer peer's):
      // no word, its raw value.
      const auto raw = static_cast<std::uint16_t>(v);
      if constexpr (std::is_same_v<V, MessageType>) {
        return FieldWord{find_message(v) != nullptr ? to_string(v) : "", raw};
      } else if constexpr (std::is_same_v<V, ErrorCode>) {
        const std::string_view word = to_string(v);
        return FieldWord{error_code_from_string(word) == v ? word : "", raw};
      } else {
        const std::string_view word = to_string(v);
        return FieldWord{word == "unknown" ? "" : word, raw};
      }
    } else if constexpr (std::is_signed_v<V>) {
      return static_cast<std::int64_t>(v);
    } else {
      static_assert(std::is_unsigned_v<V>);
      return static_cast<std::uint64_t>(v);
    }
  }
  FieldVisitor& visitor_;
  std::uint8_t minor_;
  bool ok_ = true;
};

}  // namespace

bool visit_fields(const Message& m, FieldVisitor& visitor, std::uint8_t minor) {
  if (minor > kVersionMinor || minor_of(type_of(m)) > minor) return false;
  Visiting io(visitor, minor);
  // A walk also ends early where this minor's layout ends; only a refused size field is a refusal.
  std::visit([&io](const auto& v) { walk<Text("")>(io, v); }, m);
  return io.ok();
}

void visit_fields(const AckBody& body, FieldVisitor& visitor) {
  Visiting io(visitor, kVersionMinor);
  std::visit([&io](const auto& b) { walk<Text("")>(io, b); }, body);
}

}  // namespace ajar::protocol
