// The messages the page sends over the WebSocket: one flat JSON object per text message, e.g.
// {"op":"pick","u":312.5,"v":240}. Values are strings (UTF-8), numbers, booleans or null; nothing
// nests. docs/console.md lists every op. nlohmann-json reads the text (console/src only). Parsing
// never throws: bad input gives an error naming the byte where the bad token starts, or the field
// that nests.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

namespace ajar::console {

using PageValue = std::variant<std::nullptr_t, bool, double, std::string>;

class PageMessage {
 public:
  // Parses one object. Error: "PAGE_MESSAGE: <what> at byte N" (N from 0) or "PAGE_MESSAGE:
  // \"key\": nested ...". At most 64 fields, 4 KiB; a key given twice keeps its last value.
  static std::optional<PageMessage> parse(std::string_view text, std::string& error);

  std::string op() const { return text("op").value_or(""); }
  std::optional<double> number(const std::string& key) const;  // finite numbers only
  std::optional<std::string> text(const std::string& key) const;
  std::optional<bool> flag(const std::string& key) const;

 private:
  std::map<std::string, PageValue> fields_;
};

}  // namespace ajar::console
