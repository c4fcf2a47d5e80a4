#include "ajar/console/page_message.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

namespace ajar::console {
namespace {

constexpr std::size_t kMaxBytes = 4096;
constexpr std::size_t kMaxFields = 64;

using Json = nlohmann::json;

// nlohmann-json reads the text; this keeps one flat object's fields and refuses anything else.
class FlatObject final : public nlohmann::json_sax<Json> {
 public:
  explicit FlatObject(std::map<std::string, PageValue>& fields) : fields_(fields) {}
  const std::string& error() const { return error_; }

  bool null() override { return put(nullptr); }
  bool boolean(bool v) override { return put(v); }
  bool number_integer(number_integer_t v) override { return put(static_cast<double>(v)); }
  bool number_unsigned(number_unsigned_t v) override { return put(static_cast<double>(v)); }
  bool number_float(number_float_t v, const string_t&) override { return put(v); }
  bool string(string_t& v) override { return put(std::move(v)); }
  bool binary(binary_t&) override { return fail("binary values are not JSON"); }
  bool start_object(std::size_t) override {
    if (depth_++ == 0) return true;
    return fail("\"" + key_ + "\": nested objects and arrays are not accepted");
  }
  bool key(string_t& k) override {
    key_ = std::move(k);
    return true;
  }
  bool end_object() override {
    --depth_;
    return true;
  }
  bool start_array(std::size_t) override {
    return fail(depth_ == 0 ? "expected '{'"
                            : "\"" + key_ + "\": nested objects and arrays are not accepted");
  }
  bool end_array() override { return true; }
  // `position` counts the bytes read up to the one that made the text wrong: name that byte.
  bool parse_error(std::size_t position, const std::string&,
                   const nlohmann::detail::exception& e) override {
    // "[json.exception.parse_error.101] parse error at line 1, column 5: syntax error ...; last
    // read: ..." or "[json.exception.out_of_range.406] number overflow parsing '1e999'".
    std::string what = e.what();
    if (const auto tag = what.find("] "); tag != std::string::npos) what.erase(0, tag + 2);
    if (what.rfind("parse error", 0) == 0) {
      if (const auto colon = what.find(": "); colon != std::string::npos) what.erase(0, colon + 2);
    }
    if (const auto last_read = what.find("; last read"); last_read != std::string::npos)
      what.erase(last_read);
    error_ =
        "PAGE_MESSAGE: " + what + " at byte " + std::to_string(position > 0 ? position - 1 : 0);
    return false;
  }

 private:
  bool put(PageValue v) {
    if (depth_ == 0) return fail("expected '{'");
    if (fields_.size() >= kMaxFields && fields_.count(key_) == 0)
      return fail("too many fields (at most 64)");
    fields_[key_] = std::move(v);
    return true;
  }
  bool fail(const std::string& what) {
    error_ = "PAGE_MESSAGE: " + what;
    return false;
  }

  std::map<std::string, PageValue>& fields_;
  std::string key_;
  int depth_ = 0;
  std::string error_;
};

}  // namespace

std::optional<PageMessage> PageMessage::parse(std::string_view text, std::string& error) {
  if (text.size() > kMaxBytes) {
    error = "PAGE_MESSAGE: message longer than 4096 bytes";
    return std::nullopt;
  }
  PageMessage m;
  FlatObject reader(m.fields_);
  if (!Json::sax_parse(text, &reader)) {
    error = reader.error();
    return std::nullopt;
  }
  return m;
}

std::optional<double> PageMessage::number(const std::string& key) const {
  const auto it = fields_.find(key);
  if (it == fields_.end()) return std::nullopt;
  const auto* v = std::get_if<double>(&it->second);
  if (v == nullptr || !std::isfinite(*v)) return std::nullopt;
  return *v;
}

std::optional<std::string> PageMessage::text(const std::string& key) const {
  const auto it = fields_.find(key);
  if (it == fields_.end()) return std::nullopt;
  const auto* v = std::get_if<std::string>(&it->second);
  if (v == nullptr) return std::nullopt;
  return *v;
}

std::optional<bool> PageMessage::flag(const std::string& key) const {
  const auto it = fields_.find(key);
  if (it == fields_.end()) return std::nullopt;
  const auto* v = std::get_if<bool>(&it->second);
  if (v == nullptr) return std::nullopt;
  return *v;
}

}  // namespace ajar::console
