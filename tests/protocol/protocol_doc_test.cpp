// docs/protocol.md against the message tables: the message type table (section 4), the enum words
// (4.1) and every payload layout table of section 5 (offsets, wire types, field names, the sizes
// in the headings, what 1.1 appended) must say what the codec encodes. The document is parsed,
// its structure rows expanded into wire fields, and compared with payload_layout(); the error
// table (section 8) must be core's error table, row by row.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/layout.hpp"
#include "ajar/protocol/message_table.hpp"

namespace ajar::protocol {
namespace {

std::string read_doc() {
  std::ifstream f(AJAR_PROTOCOL_DOC);
  std::stringstream text;
  text << f.rdbuf();
  return text.str();
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);)
    lines.push_back(line);
  return lines;
}

std::vector<std::string> cells(const std::string& row) {
  std::vector<std::string> out;
  std::string cell;
  for (std::size_t i = 1; i < row.size(); ++i) {
    if (row[i] == '|' && row[i - 1] != '\\') {
      const auto first = cell.find_first_not_of(' ');
      const auto last = cell.find_last_not_of(' ');
      out.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
      cell.clear();
    } else {
      cell += row[i];
    }
  }
  return out;
}

// One row of a layout table: offset (an expression of i for arrays), type, field, the rest.
struct DocRow {
  std::string offset, type, field, meaning;
};
struct DocTable {
  std::string heading;  // the line that introduces the table
  std::vector<DocRow> rows;
};

// Every table whose header starts with "| offset | type | field |", with the line above it that
// names it (a "### 5.x" heading or a "**Struct** (N bytes...)" paragraph).
std::vector<DocTable> layout_tables(const std::vector<std::string>& lines) {
  std::vector<DocTable> tables;
  std::string heading;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (l.starts_with("### ") || l.starts_with("**")) heading = l;
    if (!l.starts_with("| offset | type | field |")) continue;
    DocTable t{heading, {}};
    for (i += 2; i < lines.size() && lines[i].starts_with("|"); ++i) {
      const auto c = cells(lines[i]);
      t.rows.push_back({c.at(0), c.at(1), c.at(2), c.size() > 3 ? c.back() : ""});
    }
    tables.push_back(t);
  }
  return tables;
}

std::optional<std::size_t> primitive_size(const std::string& type) {
  static const std::map<std::string, std::size_t> sizes = {{"u8", 1},  {"i8", 1},  {"bool", 1},
                                                           {"u16", 2}, {"u32", 4}, {"u64", 8},
                                                           {"i64", 8}, {"f32", 4}, {"f64", 8}};
  if (const auto it = sizes.find(type); it != sizes.end()) return it->second;
  std::smatch m;
  if (std::regex_match(type, m, std::regex(R"(str<(\d+)>)"))) return 1 + std::stoul(m[1]);
  if (std::regex_match(type, m, std::regex(R"(bytes<(\d+)>)"))) return 2 + std::stoul(m[1]);
  return std::nullopt;
}

struct Leaf {
  std::size_t offset;
  std::string type, name;
  bool since_1_1;
  friend bool operator==(const Leaf&, const Leaf&) = default;
};
std::ostream& operator<<(std::ostream& o, const Leaf& l) {
  return o << l.offset << ' ' << l.type << ' ' << l.name << (l.since_1_1 ? " (1.1)" : "");
}

class Doc {
 public:
  Doc() : lines_(lines_of(read_doc())), tables_(layout_tables(lines_)) {
    // Structures: "**Name** (N bytes...)" with a table, or inline ("`x`, `y`, `z` as three `f64`
    // at offsets 0, 8, 16").
    std::string paragraph;
    for (const auto& l : lines_) {
      paragraph = l.empty() ? "" : paragraph + " " + l;
      std::smatch m;
      if (std::regex_search(
              paragraph, m,
              std::regex(
                  R"(\*\*(\w+)\*\* \(\d+ bytes[^)]*\): (.*) as \w+ `(\w+)` at offsets ([\d, ]+))"))) {
        std::vector<DocRow> rows;
        const std::string names = m[2], type = m[3];
        std::stringstream offsets(m[4]);
        const std::regex name_re("`(\\w+)`");
        for (auto it = std::sregex_iterator(names.begin(), names.end(), name_re);
             it != std::sregex_iterator(); ++it) {
          std::string offset;
          std::getline(offsets, offset, ',');
          rows.push_back({offset, type, (*it)[1], ""});
        }
        structures_[m[1]] = rows;
        paragraph.clear();
      }
    }
    for (const auto& t : tables_) {
      std::smatch m;
      if (std::regex_search(t.heading, m, std::regex(R"(^\*\*(\w+)\*\*)")))
        structures_[m[1]] = t.rows;
    }
  }

  // The wire fields of `rows` at `base`, names prefixed, `i` substituted in array rows; a row
  // "9 + 67·i" whose meaning says "i = 0..7" is a fixed array: every element.
  void expand(const std::vector<DocRow>& rows, std::size_t base, const std::string& prefix,
              bool since_1_1, std::vector<Leaf>& out, std::size_t i = 0) const {
    for (const DocRow& r : rows) {
      std::smatch fixed;
      if (r.offset.ends_with("·i") &&
          std::regex_search(r.meaning, fixed, std::regex(R"(i = 0\.\.(\d+))"))) {
        for (std::size_t k = 0; k <= std::stoul(fixed[1]); ++k)
          expand_row(r, base, prefix, since_1_1, out, k);
      } else {
        expand_row(r, base, prefix, since_1_1, out, i);
      }
    }
  }
  void expand_row(const DocRow& r, std::size_t base, const std::string& prefix, bool since_1_1,
                  std::vector<Leaf>& out, std::size_t i) const {
    const std::string index = std::string("[").append(std::to_string(i)).append("]");
    const std::string field = std::regex_replace(r.field, std::regex(R"(\[i\])"), index);
    const bool appended = since_1_1 || r.meaning.starts_with("1.1") ||
                          r.meaning.starts_with("1.2") || r.field == "(1.1)";
    std::size_t offset = 0;
    std::smatch m;
    if (std::regex_match(r.offset, m, std::regex(R"((\d+) \+ (\d+)·i)"))) {
      offset = std::stoul(m[1]) + std::stoul(m[2]) * i;
    } else {
      offset = std::stoul(r.offset);
    }
    if (std::regex_match(r.type, m, std::regex(R"((\d+) × (\w+))"))) {  // 12 × f64 name[0..11]
      const std::string name = field.substr(0, field.find('['));
      for (std::size_t k = 0; k < std::stoul(m[1]); ++k) {
        out.push_back({base + offset + k * *primitive_size(m[2]), m[2],
                       prefix + name + "[" + std::to_string(k) + "]", appended});
      }
    } else if (const auto size = primitive_size(r.type)) {
      out.push_back({base + offset, r.type, prefix + field, appended});
    } else {
      const auto s = structures_.find(r.type);
      EXPECT_NE(s, structures_.end()) << "no structure " << r.type;
      if (s == structures_.end()) return;
      expand(s->second, base + offset, field.starts_with("(") ? prefix : prefix + field + ".",
             appended, out);
    }
  }
  const std::vector<DocTable>& tables() const { return tables_; }
  const std::vector<std::string>& lines() const { return lines_; }
  const std::vector<DocRow>& structure(const std::string& name) const {
    return structures_.at(name);
  }

 private:
  std::vector<std::string> lines_;
  std::vector<DocTable> tables_;
  std::map<std::string, std::vector<DocRow>> structures_;
};

const Doc& the_doc() {
  static const Doc doc;
  return doc;
}

std::vector<Leaf> leaves_of(const Message& m, std::uint8_t minor) {
  std::vector<Leaf> out;
  for (const auto& f : payload_layout(m, minor))
    out.push_back({f.offset, std::string(f.type), std::string(f.name), f.since > 0});
  return out;
}
// Names the first row where the document and the codec differ (the lists are long).
void expect_same(const std::vector<Leaf>& codec, const std::vector<Leaf>& doc) {
  for (std::size_t i = 0; i < std::min(codec.size(), doc.size()); ++i) {
    if (!(codec[i] == doc[i])) {
      ADD_FAILURE() << "field " << i << ": the codec has '" << codec[i] << "', the document '"
                    << doc[i] << "'";
      return;
    }
  }
  EXPECT_EQ(codec.size(), doc.size()) << "fields in the codec vs in the document";
}

std::size_t size_of(const std::vector<FieldLayout>& layout) {
  return layout.empty() ? 0 : layout.back().offset + layout.back().size;
}

template <std::size_t... I>
std::map<MessageType, Message> one_of_each(std::index_sequence<I...>) {
  std::map<MessageType, Message> out;
  (out.emplace(type_of(Message(std::in_place_index<I>)), Message(std::in_place_index<I>)), ...);
  return out;
}
const std::map<MessageType, Message>& all_types() {
  static const auto all = one_of_each(std::make_index_sequence<std::variant_size_v<Message>>{});
  return all;
}

TEST(Layout, OffsetsFollowTheMinorAndTheValue) {
  Hello hello;
  EXPECT_EQ(offset_of(hello, "client_name"), 12);
  EXPECT_EQ(offset_of(hello, "no_such_field"), -1);
  EXPECT_EQ(offset_of(Welcome{}, "driver_kind"), 72);
  EXPECT_EQ(offset_of(Welcome{}, "driver_kind", 0), -1);                        // appended by 1.1
  EXPECT_TRUE(payload_layout(Drive{}, 0).empty());                              // 1.0 has no Drive
  EXPECT_TRUE(payload_layout(Ack{MessageType::kStop, {}, SpanAck{}}).empty());  // wrong body
  EXPECT_TRUE(payload_layout(MeasureDoorPlane{}).empty());                      // count 0
  MeasureDoorPlane plane;
  plane.count = 16;
  EXPECT_EQ(offset_of(plane, "points[15].z"), 1 + 15 * 25 + 17);
  const auto status = payload_layout(Status{});
  ASSERT_FALSE(status.empty());
  EXPECT_EQ(status.back().name, "recorder.last_write_ns");
  EXPECT_EQ(status.back().since, 2);
  EXPECT_EQ(offset_of(Status{}, "base_motion"), 464);
  EXPECT_EQ(offset_of(Status{}, "recorder.enabled"), 465);
  EXPECT_EQ(offset_of(Status{}, "recorder.enabled", 1), -1);
  EXPECT_EQ(payload_layout(Status{}, 1).back().name, "realtime.memory_locked");
  EXPECT_EQ(payload_layout(Status{}, 1).back().since, 1);
  EXPECT_EQ(status.front().since, 0);
}

TEST(ProtocolDoc, MessageTypeTableIsTheCodecs) {
  const Doc& doc = the_doc();
  std::set<MessageType> seen;
  for (const auto& line : doc.lines()) {
    std::smatch m;
    if (!std::regex_match(
            line, m,
            std::regex(R"(\| `0x([0-9A-F]{4})` \| (\w+)( \(1\.(\d)\))? \| (host|daemon) → .*)")))
      continue;
    const auto t = static_cast<MessageType>(std::stoul(m[1], nullptr, 16));
    SCOPED_TRACE(line);
    EXPECT_EQ(to_string(t), m[2].str());
    EXPECT_EQ(minor_of(t), m[3].matched ? std::stoi(m[4]) : 0);
    EXPECT_EQ(is_request(t), m[5] == "host");
    seen.insert(t);
  }
  EXPECT_EQ(seen.size(), all_types().size());
}

template <typename E>
void expect_words(const Doc& doc, const std::string& name) {
  for (const auto& line : doc.lines()) {
    std::smatch m;
    if (!std::regex_match(line, m, std::regex("\\| " + name + R"(( \(1\.\d\))? \| (.*) \|)")))
      continue;
    // "0 sim (simulated hardware), 1 mock (...), 2 real (...)": the words, parentheses dropped.
    const std::string values = std::regex_replace(m[2].str(), std::regex(R"( \([^)]*\))"), "");
    std::stringstream in(values);
    std::size_t count = 0;
    for (std::string item; std::getline(in, item, ',');) {
      std::stringstream words(item);
      std::size_t value = 0;
      std::string word;
      words >> value >> word;
      EXPECT_EQ(value, count) << name;
      EXPECT_EQ(to_string(static_cast<E>(value)), word) << name;
      ++count;
    }
    EXPECT_EQ(to_string(static_cast<E>(count)), "unknown") << name << " has more values";
    return;
  }
  ADD_FAILURE() << "no row for " << name << " in section 4.1";
}

TEST(ProtocolDoc, EnumWordsAreTheCodecs) {
  const Doc& doc = the_doc();
  expect_words<Role>(doc, "Role");
  expect_words<ProcedureState>(doc, "ProcedureState");
  expect_words<EventKind>(doc, "EventKind");
  expect_words<ArmState>(doc, "ArmState");
  expect_words<DriverState>(doc, "DriverState");
  expect_words<DriverKind>(doc, "DriverKind");
  expect_words<SchedulingPolicy>(doc, "SchedulingPolicy");
  expect_words<BaseMotion>(doc, "BaseMotion");
}

// "### 5.10 Welcome `0x0201` (73 bytes; 72 in 1.0)": the table, expanded, is payload_layout() in
// 1.1; its rows not marked 1.1 are the 1.0 layout; the heading's sizes are the layouts' sizes.
TEST(ProtocolDoc, PayloadTablesAreTheCodecsLayouts) {
  const Doc& doc = the_doc();
  std::set<MessageType> checked;
  for (const auto& t : doc.tables()) {
    std::smatch m;
    if (!std::regex_search(
            t.heading, m,
            std::regex(R"(^### 5\.\d+ (\w+) `0x([0-9A-F]{4})` \((\d+) bytes(; (\d+) in 1\.0)?)")))
      continue;
    SCOPED_TRACE(t.heading);
    const auto type = static_cast<MessageType>(std::stoul(m[2], nullptr, 16));
    ASSERT_TRUE(all_types().count(type));
    const Message& message = all_types().at(type);
    std::vector<Leaf> expected;
    doc.expand(t.rows, 0, "", minor_of(type) > 0, expected);
    // The doc marks a 1.1 type's own fields as 1.1 by the heading; the tables mark appended ones.
    std::vector<Leaf> actual = leaves_of(message, kVersionMinor);
    if (minor_of(type) > 0) {
      for (auto& l : actual)
        l.since_1_1 = true;
    }
    expect_same(actual, expected);
    EXPECT_EQ(size_of(payload_layout(message)), std::stoul(m[3]));
    if (minor_of(type) == 0) {
      std::vector<Leaf> old_rows;
      for (const auto& l : expected)
        if (!l.since_1_1) old_rows.push_back(l);
      expect_same(leaves_of(message, 0), old_rows);
      EXPECT_EQ(size_of(payload_layout(message, 0)),
                m[5].matched ? std::stoul(m[5]) : std::stoul(m[3]));
    }
    checked.insert(type);
  }
  EXPECT_GE(checked.size(), 15u);
}

// The Ack (3 + body): one row per body kind in the table of section 5.12, with the payload length
// and the body's structure table at offset 3.
TEST(ProtocolDoc, AckBodiesAreTheCodecs) {
  const Doc& doc = the_doc();
  const DocTable* ack = nullptr;
  for (const auto& t : doc.tables()) {
    if (t.heading.find("Ack `0x0203`") != std::string::npos) ack = &t;
  }
  ASSERT_NE(ack, nullptr);
  const std::map<std::string, AckBody> bodies = {{"SpanBody", SpanAck{}},
                                                 {"PlaneBody", PlaneAck{}},
                                                 {"ContactBody", ContactAck{}},
                                                 {"ApproachBody", ApproachAck{}},
                                                 {"(none)", EmptyAck{}}};
  std::map<std::string, MessageType> by_name;
  for (const auto& [t, m] : all_types())
    by_name[std::string(to_string(t))] = t;
  std::size_t rows = 0;
  for (const auto& line : doc.lines()) {
    std::smatch m;
    if (!std::regex_match(line, m, std::regex(R"(\| (.+) \| (\w+Body|\(none\)) \| (\d+) \|)"))) {
      continue;
    }
    SCOPED_TRACE(line);
    std::vector<MessageType> acknowledged;
    if (m[1] == "any other request type") {
      acknowledged = {MessageType::kStop, MessageType::kAlignBase, MessageType::kDrive};
    } else {
      std::stringstream names(std::regex_replace(m[1].str(), std::regex(R"( \(1\.\d\))"), ""));
      for (std::string name; std::getline(names >> std::ws, name, ',');)
        acknowledged.push_back(by_name.at(name));
    }
    for (const MessageType t : acknowledged) {
      const Message message = Ack{t, ProcedureState::kAwaitingWidth, bodies.at(m[2])};
      std::vector<Leaf> expected;
      for (const auto& r : ack->rows) {
        if (r.type == "body") {
          if (m[2] != "(none)")
            doc.expand(doc.structure(m[2]), std::stoul(r.offset), "", false, expected);
        } else {
          doc.expand({r}, 0, "", false, expected);
        }
      }
      std::vector<Leaf> actual = leaves_of(message, kVersionMinor);
      for (auto& l : actual)
        l.since_1_1 = false;  // a 1.1 body: the Ack of a 1.1 request
      SCOPED_TRACE(to_string(t));
      expect_same(actual, expected);
      EXPECT_EQ(size_of(payload_layout(message)), std::stoul(m[3])) << to_string(t);
    }
    ++rows;
  }
  EXPECT_EQ(rows, bodies.size());
}

// MeasureDoorPlane (1 + 25·count): count, then `count` points.
TEST(ProtocolDoc, DoorPlaneTableIsTheCodecs) {
  const Doc& doc = the_doc();
  const DocTable* plane = nullptr;
  for (const auto& t : doc.tables()) {
    if (t.heading.find("MeasureDoorPlane `0x0112`") != std::string::npos) plane = &t;
  }
  ASSERT_NE(plane, nullptr);
  ASSERT_EQ(plane->rows.size(), 2u);
  for (const std::uint8_t count : {std::uint8_t{3}, std::uint8_t{7}, std::uint8_t{16}}) {
    MeasureDoorPlane m;
    m.count = count;
    std::vector<Leaf> expected;
    doc.expand({plane->rows[0]}, 0, "", false, expected);
    for (std::size_t i = 0; i < count; ++i)
      doc.expand({plane->rows[1]}, 0, "", false, expected, i);
    expect_same(leaves_of(m, kVersionMinor), expected);
    EXPECT_EQ(size_of(payload_layout(m)), 1u + 25u * count);
  }
}

// Section 2's header table is kHeaderFields (codec.hpp): each field's offset, size and name, in
// order, then the payload at kHeaderSize.
TEST(ProtocolDoc, HeaderTableIsTheCodecsOffsets) {
  const Doc& doc = the_doc();
  std::vector<std::vector<std::string>> rows;
  bool in_table = false;
  for (const auto& line : doc.lines()) {
    if (line.starts_with("| offset | size | type | field |")) {
      in_table = true;
      continue;
    }
    if (in_table && !line.starts_with("|")) break;
    if (in_table && !line.starts_with("| ---")) rows.push_back(cells(line));
  }
  ASSERT_EQ(rows.size(), kHeaderFields.size() + 1) << "section 2: one row per field + payload";
  for (std::size_t i = 0; i < kHeaderFields.size(); ++i) {
    const HeaderField& f = kHeaderFields[i];
    EXPECT_EQ(rows[i].at(0), std::to_string(f.offset)) << f.name;
    EXPECT_EQ(rows[i].at(1), std::to_string(f.size)) << f.name;
    EXPECT_EQ(rows[i].at(3), f.name);
    if (i + 1 < kHeaderFields.size()) {
      EXPECT_EQ(f.offset + f.size, kHeaderFields[i + 1].offset);
    }
  }
  EXPECT_EQ(rows.back().at(0), std::to_string(kHeaderSize));
  EXPECT_EQ(rows.back().at(3), "payload");
}

// Section 8 is the error table (core/include/ajar/core/error.hpp, AJAR_ERROR_CODES) row by row:
// code, name, meaning and what to do (the doc's `code` marks aside), every code once, both ways.
TEST(ProtocolDoc, ErrorTableIsTheErrorCodes) {
  const Doc& doc = the_doc();
  const auto plain = [](std::string text) {
    std::erase(text, '`');
    return text;
  };
  std::map<unsigned, std::vector<std::string>> documented;
  bool in_section = false;
  for (const auto& line : doc.lines()) {
    if (line.starts_with("## ")) in_section = line.starts_with("## 8. Error codes");
    if (!in_section || !std::regex_search(line, std::regex(R"(^\| \d+ \|)"))) continue;
    const auto c = cells(line);
    ASSERT_EQ(c.size(), 4u) << line;
    EXPECT_TRUE(documented.emplace(std::stoul(c[0]), c).second) << "twice: " << line;
  }
  for (const ErrorInfo& row : error_table()) {
    const auto code = static_cast<unsigned>(row.value);
    const std::string expected = "| " + std::to_string(code) + " | " + std::string(row.word) +
                                 " | " + std::string(row.meaning) + " | " +
                                 std::string(row.action) + " |";
    const auto it = documented.find(code);
    if (it == documented.end()) {
      ADD_FAILURE() << "section 8 lacks code " << code << "; expected the row\n" << expected;
      continue;
    }
    const auto& c = it->second;
    EXPECT_EQ(c[1], row.word) << "code " << code << ", expected\n" << expected;
    EXPECT_EQ(plain(c[2]), row.meaning) << "code " << code << ", expected\n" << expected;
    EXPECT_EQ(plain(c[3]), row.action) << "code " << code << ", expected\n" << expected;
    EXPECT_EQ(error_code_from_string(row.word), row.value);
    EXPECT_EQ(to_string(row.value), row.word);
    documented.erase(it);
  }
  for (const auto& [code, c] : documented)
    ADD_FAILURE() << "section 8 lists code " << code << " (" << c[1]
                  << "), which error.hpp does not have";
  EXPECT_EQ(to_string(static_cast<ErrorCode>(999)), "UNKNOWN");
  EXPECT_EQ(error_code_from_string("UNKNOWN"), std::nullopt);
}

// Every type has its section; those "(0 bytes" have no payload.
TEST(ProtocolDoc, EveryTypeHasItsSection) {
  const Doc& doc = the_doc();
  std::set<MessageType> documented;
  for (const auto& line : doc.lines()) {
    if (!line.starts_with("### 5.")) continue;
    const std::regex code_re("`0x([0-9A-F]{4})`");
    for (auto it = std::sregex_iterator(line.begin(), line.end(), code_re);
         it != std::sregex_iterator(); ++it) {
      const auto t = static_cast<MessageType>(std::stoul((*it)[1], nullptr, 16));
      documented.insert(t);
      if (line.find("(0 bytes") != std::string::npos) {
        ASSERT_TRUE(all_types().count(t)) << line;
        EXPECT_TRUE(payload_layout(all_types().at(t)).empty()) << line;
      }
    }
  }
  for (const auto& [t, m] : all_types())
    EXPECT_TRUE(documented.count(t)) << to_string(t) << " has no section 5.x";
}

// Section 4.2 is the message table's policy columns (message_table.hpp), row by row: who may send
// each request, whether a repeat is executed again, whether its Ack waits for the save, whether it
// starts a motion, whether it waits for the wheels to be at rest; every request once.
TEST(ProtocolDoc, PolicyTableIsTheMessageTables) {
  const Doc& doc = the_doc();
  const auto yes_no = [](bool b) { return std::string(b ? "yes" : "no"); };
  std::map<std::string, std::vector<std::string>> documented;
  bool in_section = false;
  for (const auto& line : doc.lines()) {
    if (line.starts_with("### ") || line.starts_with("## ")) {
      in_section = line.starts_with("### 4.2 ");
    }
    if (!in_section || !line.starts_with("| ") || line.starts_with("| message") ||
        line.starts_with("| ---")) {
      continue;
    }
    const auto c = cells(line);
    ASSERT_EQ(c.size(), 6u) << line;
    // "Drive (1.1)": the name; the minor is section 4's.
    const std::string name = c[0].substr(0, c[0].find(' '));
    EXPECT_TRUE(documented.emplace(name, c).second) << "twice: " << line;
  }
  for (const auto& [type, message] : all_types()) {
    if (!is_request(type)) {
      EXPECT_EQ(policy_of(type).sender, Sender::kDaemon) << to_string(type);
      continue;
    }
    const MessagePolicy& p = policy_of(type);
    const std::string expected =
        "| " + std::string(to_string(type)) + " | " + std::string(word_of(kSenderWords, p.sender)) +
        " | " + yes_no(p.deduplicated) + " | " + yes_no(p.durable_ack) + " | " +
        yes_no(p.starts_motion) + " | " + yes_no(p.needs_wheels_at_rest) + " |";
    const auto it = documented.find(std::string(to_string(type)));
    if (it == documented.end()) {
      ADD_FAILURE() << "section 4.2 lacks " << to_string(type) << "; expected the row\n"
                    << expected;
      continue;
    }
    const auto& c = it->second;
    EXPECT_EQ(c[1], word_of(kSenderWords, p.sender)) << "expected\n" << expected;
    EXPECT_EQ(c[2], yes_no(p.deduplicated)) << "expected\n" << expected;
    EXPECT_EQ(c[3], yes_no(p.durable_ack)) << "expected\n" << expected;
    EXPECT_EQ(c[4], yes_no(p.starts_motion)) << "expected\n" << expected;
    EXPECT_EQ(c[5], yes_no(p.needs_wheels_at_rest)) << "expected\n" << expected;
    documented.erase(it);
  }
  for (const auto& [name, c] : documented)
    ADD_FAILURE() << "section 4.2 lists " << name << ", which is not a host -> daemon message";
  // The readers' shorthands say what the rows say.
  EXPECT_TRUE(needs_controller(MessageType::kMeasureDoorWidth));
  EXPECT_FALSE(needs_controller(MessageType::kStop));
  EXPECT_TRUE(is_stop(MessageType::kEmergencyStop));
  EXPECT_FALSE(is_stop(MessageType::kGetStatus));
  EXPECT_EQ(policy_of(static_cast<MessageType>(0x01FF)).sender, Sender::kDaemon);
}

// Section 4.3 is the message table's refusal column (message_table.hpp), row by row: for each
// request the codes it is refused with naming no field, and the codes naming a field (a pattern:
// `points[i].{x,y,z}`); every request once, each refusal once, nothing the table does not hold.
std::string refusal_word(const Refusal& r) {
  std::string word(to_string(r.code));
  return r.field.empty() ? word : word + " `" + field_pattern(r) + "`";
}
// A cell's entries, separated by ", " ("–": none; `{x,y,z}` has no space).
std::vector<std::string> entries(const std::string& cell) {
  std::vector<std::string> out;
  if (cell == "–") return out;
  std::size_t from = 0;
  for (std::size_t at; (at = cell.find(", ", from)) != std::string::npos; from = at + 2)
    out.push_back(cell.substr(from, at - from));
  out.push_back(cell.substr(from));
  return out;
}

TEST(ProtocolDoc, RefusalTableIsTheMessageTables) {
  const Doc& doc = the_doc();
  std::map<std::string, std::vector<std::string>> documented;
  bool in_section = false;
  for (const auto& line : doc.lines()) {
    if (line.starts_with("### ") || line.starts_with("## ")) {
      in_section = line.starts_with("### 4.3 ");
    }
    if (!in_section || !line.starts_with("| ") || line.starts_with("| message") ||
        line.starts_with("| ---")) {
      continue;
    }
    const auto c = cells(line);
    ASSERT_EQ(c.size(), 3u) << line;
    const std::string name = c[0].substr(0, c[0].find(' '));
    EXPECT_TRUE(documented.emplace(name, c).second) << "twice: " << line;
  }
  for (const auto& [type, message] : all_types()) {
    if (!is_request(type)) {
      EXPECT_TRUE(refusals_of(type).empty()) << to_string(type);
      continue;
    }
    std::vector<std::string> no_field, named;
    for (const Refusal& r : refusals_of(type))
      (r.field.empty() ? no_field : named).push_back(refusal_word(r));
    const auto joined = [](const std::vector<std::string>& v) {
      std::string s;
      for (const auto& w : v)
        s += (s.empty() ? "" : ", ") + w;
      return s.empty() ? std::string("–") : s;
    };
    const std::string name(to_string(type));
    const std::string expected =
        "| " + name +
        (minor_of(type) > 0 ? " (1." + std::to_string(minor_of(type)) + ")" : std::string()) +
        " | " + joined(no_field) + " | " + joined(named) + " |";
    const auto it = documented.find(name);
    if (it == documented.end()) {
      ADD_FAILURE() << "section 4.3 lacks " << name << "; expected the row\n" << expected;
      continue;
    }
    for (int column : {1, 2}) {
      const auto& want = column == 1 ? no_field : named;
      const auto got = entries(it->second[static_cast<std::size_t>(column)]);
      const std::set<std::string> want_set(want.begin(), want.end());
      const std::set<std::string> got_set(got.begin(), got.end());
      EXPECT_EQ(got.size(), got_set.size()) << "an entry twice in " << name;
      for (const auto& w : want_set)
        EXPECT_TRUE(got_set.count(w)) << name << ": the doc lacks " << w << "; expected\n"
                                      << expected;
      for (const auto& g : got_set)
        EXPECT_TRUE(want_set.count(g))
            << name << ": the doc lists " << g << ", the table does not; expected\n"
            << expected;
    }
    documented.erase(it);
  }
  for (const auto& [name, c] : documented)
    ADD_FAILURE() << "section 4.3 lists " << name << ", which is not a host -> daemon message";
}

// The patterns the refusals' fields stand for.
TEST(MessageTable, RefusalFieldPatterns) {
  const Refusal point{ErrorCode::kNonFinite, "points", true, true};
  EXPECT_TRUE(names_field(point, "points[0].x"));
  EXPECT_TRUE(names_field(point, "points[15].z"));
  EXPECT_FALSE(names_field(point, "points[].x"));
  EXPECT_FALSE(names_field(point, "points[1]"));
  EXPECT_FALSE(names_field(point, "points[a].x"));
  EXPECT_FALSE(names_field(point, "points.x"));
  EXPECT_FALSE(names_field(point, "points[1].w"));
  EXPECT_EQ(field_pattern(point), "points[i].{x,y,z}");
  const Refusal plain{ErrorCode::kPointsTooClose, "p2"};
  EXPECT_TRUE(names_field(plain, "p2"));
  EXPECT_FALSE(names_field(plain, "p2.x"));
  EXPECT_FALSE(names_field(plain, "p"));
  const Refusal none{ErrorCode::kQueueFull, ""};
  EXPECT_TRUE(names_field(none, ""));
  EXPECT_FALSE(names_field(none, "arm"));
  EXPECT_EQ(field_pattern(none), "–");
  EXPECT_NE(find_refusal(MessageType::kMeasureDoorWidth, ErrorCode::kPointsTooClose, "p2"),
            nullptr);
  EXPECT_EQ(find_refusal(MessageType::kMeasureDoorWidth, ErrorCode::kPointsTooClose, "p1"),
            nullptr);
  EXPECT_EQ(find_refusal(MessageType::kStatus, ErrorCode::kQueueFull, ""), nullptr);
  EXPECT_TRUE(refusals_of(static_cast<MessageType>(0x01FF)).empty());
}

}  // namespace
}  // namespace ajar::protocol
