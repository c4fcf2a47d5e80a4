// The channel table (channels.hpp): every JSON channel's schema is JSON, its title is the schema
// name, every required property is described; ids and topics are unique.
#include "ajar/recorder/channels.hpp"

#include <set>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace ajar::recorder {
namespace {

TEST(Channels, EveryJsonSchemaParsesAndDescribesItsRequiredProperties) {
  for (const auto& c : kChannels) {
    SCOPED_TRACE(std::string(c.topic));
    if (c.message_encoding != "json") {
      EXPECT_EQ(c.schema_id, 0);
      EXPECT_TRUE(c.schema.empty());
      continue;
    }
    EXPECT_EQ(c.schema_encoding, "jsonschema");
    ASSERT_NE(c.schema_id, 0);
    const auto schema = nlohmann::json::parse(c.schema);
    EXPECT_EQ(schema.at("title"), c.schema_name);
    EXPECT_EQ(schema.at("type"), "object");
    for (const auto& key : schema.at("required")) {
      EXPECT_TRUE(schema.at("properties").contains(key.get<std::string>())) << key;
    }
  }
}

TEST(Channels, IdsTopicsAndSchemaIdsAreUnique) {
  std::set<std::string_view> topics;
  std::set<std::uint16_t> schemas;
  for (const auto& c : kChannels) {
    EXPECT_TRUE(topics.insert(c.topic).second) << c.topic;
    if (c.schema_id != 0) {
      EXPECT_TRUE(schemas.insert(c.schema_id).second) << c.topic;
    }
    EXPECT_EQ(channel_by_id(c.id), &c);
    EXPECT_EQ(find_channel(c.topic), &c);
  }
  EXPECT_EQ(find_channel("/nope"), nullptr);
  EXPECT_EQ(channel_by_id(0), nullptr);
}

}  // namespace
}  // namespace ajar::recorder
