#include "ajar/console/page_message.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>

namespace ajar::console {
namespace {

constexpr std::size_t kMaxBytes = 4096;
constexpr std::size_t kMaxFields = 64;

struct Parser {
  std::string_view s;
  std::size_t i = 0;
  std::string error;

  bool fail(const char* what) {
    error = std::string("PAGE_MESSAGE: ") + what + " at byte " + std::to_string(i);
    return false;
  }
  void skip() {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\n' || s[i] == '\r'))
      ++i;
  }
  bool literal(std::string_view word) {
    if (s.substr(i, word.size()) != word) return false;
    i += word.size();
    return true;
  }
  bool string(std::string& out) {
    if (i >= s.size() || s[i] != '"') return fail("expected a string");
    ++i;
    while (i < s.size() && s[i] != '"') {
      char c = s[i++];
      if (static_cast<unsigned char>(c) < 0x20) return fail("control character in a string");
      if (c == '\\') {
        if (i >= s.size()) return fail("unterminated escape");
        const char e = s[i++];
        switch (e) {
          case '"':
            c = '"';
            break;
          case '\\':
            c = '\\';
            break;
          case '/':
            c = '/';
            break;
          case 'n':
            c = '\n';
            break;
          case 't':
            c = '\t';
            break;
          case 'r':
            c = '\r';
            break;
          case 'b':
            c = '\b';
            break;
          case 'f':
            c = '\f';
            break;
          case 'u': {
            if (i + 4 > s.size()) return fail("short \\u escape");
            unsigned code = 0;
            for (int k = 0; k < 4; ++k) {
              const char h = s[i++];
              code <<= 4;
              if (h >= '0' && h <= '9')
                code |= static_cast<unsigned>(h - '0');
              else if (h >= 'a' && h <= 'f')
                code |= static_cast<unsigned>(h - 'a' + 10);
              else if (h >= 'A' && h <= 'F')
                code |= static_cast<unsigned>(h - 'A' + 10);
              else
                return fail("bad \\u escape");
            }
            c = code < 0x80 ? static_cast<char>(code) : '?';  // the page sends ASCII
            break;
          }
          default:
            return fail("bad escape");
        }
      }
      out.push_back(c);
    }
    if (i >= s.size()) return fail("unterminated string");
    ++i;
    return true;
  }
  bool value(PageValue& out) {
    skip();
    if (i >= s.size()) return fail("expected a value");
    if (s[i] == '"') {
      std::string text;
      if (!string(text)) return false;
      out = std::move(text);
      return true;
    }
    if (literal("true")) {
      out = true;
      return true;
    }
    if (literal("false")) {
      out = false;
      return true;
    }
    if (literal("null")) {
      out = nullptr;
      return true;
    }
    const std::size_t start = i;
    while (i < s.size() && (std::isdigit(static_cast<unsigned char>(s[i])) != 0 || s[i] == '-' ||
                            s[i] == '+' || s[i] == '.' || s[i] == 'e' || s[i] == 'E')) {
      ++i;
    }
    if (start == i) return fail("expected a value (nested objects and arrays are not accepted)");
    const std::string number(s.substr(start, i - start));
    char* end = nullptr;
    const double v = std::strtod(number.c_str(), &end);
    if (end != number.c_str() + number.size()) {
      i = start;
      return fail("bad number");
    }
    out = v;
    return true;
  }
};

}  // namespace

std::optional<PageMessage> PageMessage::parse(std::string_view text, std::string& error) {
  Parser p{text, 0, {}};
  if (text.size() > kMaxBytes) {
    error = "PAGE_MESSAGE: message longer than 4096 bytes";
    return std::nullopt;
  }
  PageMessage m;
  p.skip();
  if (p.i >= text.size() || text[p.i] != '{') {
    p.fail("expected '{'");
    error = p.error;
    return std::nullopt;
  }
  ++p.i;
  p.skip();
  if (p.i < text.size() && text[p.i] == '}') {
    ++p.i;
  } else {
    for (;;) {
      p.skip();
      std::string key;
      PageValue v;
      if (!p.string(key)) break;
      p.skip();
      if (p.i >= text.size() || text[p.i] != ':') {
        p.fail("expected ':'");
        break;
      }
      ++p.i;
      if (!p.value(v)) break;
      if (m.fields_.size() >= kMaxFields) {
        p.fail("too many fields");
        break;
      }
      m.fields_[key] = std::move(v);
      p.skip();
      if (p.i < text.size() && text[p.i] == ',') {
        ++p.i;
        continue;
      }
      if (p.i < text.size() && text[p.i] == '}') {
        ++p.i;
        break;
      }
      p.fail("expected ',' or '}'");
      break;
    }
  }
  if (p.error.empty()) {
    p.skip();
    if (p.i != text.size()) p.fail("trailing characters");
  }
  if (!p.error.empty()) {
    error = p.error;
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
