#include "ajar/daemon/config.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "ajar/core/geometry.hpp"

namespace ajar::daemon {
namespace {

namespace fs = std::filesystem;

class ConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "ajar-config-XXXXXX").string();
    ASSERT_NE(mkdtemp(pattern.data()), nullptr);
    dir_ = pattern;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& yaml) {
    const std::string path = (dir_ / "ajard.yaml").string();
    std::ofstream(path) << yaml;
    return path;
  }

  // The ConfigError message for `yaml`, or "" when it loads.
  std::string error_for(const std::string& yaml) {
    const std::string path = write(yaml);
    try {
      (void)load_config(path);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

std::string repo_file(const char* relative) {
  return std::string(AJAR_SOURCE_DIR) + "/" + relative;
}

TEST_F(ConfigTest, ShippedSimConfigLoadsWithThePapersTransformInMetres) {
  const Config c = load_config(repo_file("config/ajard.yaml"));
  EXPECT_EQ(c.network.bind_address, "127.0.0.1");
  EXPECT_EQ(c.network.port, 7450);
  EXPECT_EQ(c.drivers.kind, drivers::DriverKind::kSim);
  EXPECT_TRUE(c.camera_to_base_m.isApprox(core::paper_camera_to_base_m(), 1e-12));
  EXPECT_DOUBLE_EQ(c.camera_to_base_m(0, 3), 0.15);
  EXPECT_DOUBLE_EQ(c.camera_to_base_m(2, 3), -0.22);
  EXPECT_EQ(c.base.left.card_axis, 1);
  EXPECT_EQ(c.base.right.polarity, -1);
  EXPECT_DOUBLE_EQ(c.limits.max_door_width_m, 1.5);
  EXPECT_DOUBLE_EQ(c.limits.arm.max_reach_m, 1.0);
}

TEST_F(ConfigTest, ShippedRobotConfigSelectsTheRealDrivers) {
  const Config c = load_config(repo_file("config/ajard.robot.yaml"));
  EXPECT_EQ(c.drivers.kind, drivers::DriverKind::kReal);
  EXPECT_EQ(c.drivers.card.library_path, "/opt/googoltech/lib/libgts.so");
  EXPECT_TRUE(c.control.realtime);
  EXPECT_EQ(c.state.directory, "/var/lib/ajar");
}

TEST_F(ConfigTest, EmptyFileGivesTheDefaults) {
  const Config c = load_config(write(""));
  EXPECT_EQ(c.network.port, 7450);
  EXPECT_TRUE(c.camera_to_base_m.isApprox(core::paper_camera_to_base_m(), 1e-12));
  EXPECT_DOUBLE_EQ(c.control.rate_hz, 500);
}

TEST_F(ConfigTest, MisspelledKeyIsNamedWithItsPathLineAndSuggestion) {
  const std::string e = error_for("base:\n  wheel_radius_m: 0.1\n  wheel_radus_m: 0.2\n");
  EXPECT_NE(e.find(dir_.string() + "/ajard.yaml:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("base.wheel_radus_m: unknown key"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'wheel_radius_m'"), std::string::npos) << e;
}

TEST_F(ConfigTest, UnknownTopLevelSectionIsRefused) {
  const std::string e = error_for("netwrok:\n  port: 1\n");
  EXPECT_NE(e.find("netwrok: unknown key"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'network'"), std::string::npos) << e;
}

TEST_F(ConfigTest, WrongTypeNamesKeyValueAndAllowedRange) {
  const std::string e = error_for("network:\n  port: seventy\n");
  EXPECT_NE(e.find("network.port: must be a whole number"), std::string::npos) << e;
  EXPECT_NE(e.find("'seventy'"), std::string::npos) << e;
  EXPECT_NE(e.find("0..65535"), std::string::npos) << e;
  EXPECT_NE(error_for("network:\n  port: 74.5\n").find("network.port"), std::string::npos);
  EXPECT_NE(error_for("control:\n  realtime: maybe\n").find("control.realtime: must be true or"),
            std::string::npos);
  EXPECT_NE(error_for("base: 3\n").find("base: must be a map"), std::string::npos);
}

TEST_F(ConfigTest, OutOfRangeValuesAreRefused) {
  EXPECT_NE(
      error_for("base:\n  wheel_radius_m: -0.1\n").find("base.wheel_radius_m: is out of range"),
      std::string::npos);
  EXPECT_NE(error_for("network:\n  port: 70000\n").find("network.port: is out of range"),
            std::string::npos);
  EXPECT_NE(error_for("control:\n  rate_hz: .nan\n").find("control.rate_hz: must be finite"),
            std::string::npos);
  EXPECT_NE(error_for("limits:\n  door_width_m: [1.5, 0.6]\n")
                .find("limits.door_width_m: must be [min, max] with min < max"),
            std::string::npos);
  EXPECT_NE(error_for("limits:\n  door_width_m: [0.6]\n").find("must be a list of 2 numbers"),
            std::string::npos);
  EXPECT_NE(error_for("base:\n  right_wheel: {card_axis: 1, polarity: -1}\n")
                .find("base.right_wheel.card_axis: must differ"),
            std::string::npos);
  EXPECT_NE(error_for("base:\n  left_wheel: {card_axis: 1, polarity: 0}\n")
                .find("base.left_wheel.polarity: must be +1 or -1"),
            std::string::npos);
  EXPECT_NE(
      error_for("drivers:\n  arm: {baud: 12345}\n").find("drivers.arm.baud: is not a standard"),
      std::string::npos);
  EXPECT_NE(error_for("network:\n  bind_address: localhost-ish\n")
                .find("network.bind_address: is not an IP address"),
            std::string::npos);
}

TEST_F(ConfigTest, UnknownEnumWordListsTheAllowedOnes) {
  const std::string e = error_for("drivers:\n  kind: simulated\n");
  EXPECT_NE(e.find("drivers.kind: is not one of the allowed values (got 'simulated'; allowed: sim, "
                   "mock, real)"),
            std::string::npos)
      << e;
}

TEST_F(ConfigTest, RealDriversNeedTheVendorLibrary) {
  const std::string e = error_for("drivers:\n  kind: real\n");
  EXPECT_NE(e.find("drivers.card.library: is required when drivers.kind is real"),
            std::string::npos)
      << e;
}

std::string transform_yaml(const std::string& rows) {
  return "frames:\n  camera_to_base_m:\n" + rows;
}

TEST_F(ConfigTest, NonRigidTransformsAreRefusedWithTheKey) {
  // A scaled rotation (the paper's matrix left in centimetres is rigid; scaling R is not).
  const std::string scaled = transform_yaml(
      "    - [0, 0, 2, 0.15]\n    - [-1, 0, 0, 0.015]\n    - [0, -1, 0, -0.22]\n"
      "    - [0, 0, 0, 1]\n");
  std::string e = error_for(scaled);
  EXPECT_NE(e.find("frames.camera_to_base_m: is not a rigid transform"), std::string::npos) << e;

  // A reflection: orthonormal but det = -1.
  e = error_for(
      transform_yaml("    - [0, 0, 1, 0.15]\n    - [1, 0, 0, 0.015]\n    - [0, -1, 0, -0.22]\n"
                     "    - [0, 0, 0, 1]\n"));
  EXPECT_NE(e.find("frames.camera_to_base_m: is not a rigid transform"), std::string::npos) << e;
  EXPECT_NE(e.find("determinant"), std::string::npos) << e;

  // Bottom row not 0 0 0 1.
  e = error_for(
      transform_yaml("    - [0, 0, 1, 0.15]\n    - [-1, 0, 0, 0.015]\n    - [0, -1, 0, -0.22]\n"
                     "    - [0, 0, 0.1, 1]\n"));
  EXPECT_NE(e.find("bottom_row"), std::string::npos) << e;

  // Wrong shape and a non-number.
  EXPECT_NE(error_for(transform_yaml("    - [0, 0, 1]\n")).find("must be a 4x4 matrix"),
            std::string::npos);
  EXPECT_NE(error_for(transform_yaml("    - [0, 0, 1, x]\n    - [0, 0, 1, 0]\n    - [0, 0, 1, 0]\n"
                                     "    - [0, 0, 0, 1]\n"))
                .find("frames.camera_to_base_m[0][3]: must be a number"),
            std::string::npos);
}

TEST_F(ConfigTest, ARigidCustomTransformIsAccepted) {
  const double c = std::cos(0.3), s = std::sin(0.3);
  std::ostringstream rows;
  rows.precision(17);
  rows << "    - [" << c << ", " << -s << ", 0, 0.1]\n    - [" << s << ", " << c
       << ", 0, 0.2]\n    - [0, 0, 1, 0.3]\n    - [0, 0, 0, 1]\n";
  const Config cfg = load_config(write(transform_yaml(rows.str())));
  EXPECT_NEAR(cfg.camera_to_base_m(1, 0), s, 1e-15);
  EXPECT_DOUBLE_EQ(cfg.camera_to_base_m(2, 3), 0.3);
}

TEST_F(ConfigTest, MissingFileAndBrokenYamlNameTheFile) {
  try {
    (void)load_config((dir_ / "nope.yaml").string());
    FAIL() << "no error for a missing file";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("nope.yaml: cannot open"), std::string::npos);
  }
  const std::string e = error_for("network: [1, 2\n");
  EXPECT_NE(e.find("ajard.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("not valid YAML"), std::string::npos) << e;
}

TEST_F(ConfigTest, EffectiveConfigRoundTrips) {
  const Config original = load_config(repo_file("config/ajard.yaml"));
  const std::string yaml = to_yaml(original);
  const Config again = load_config(write(yaml));
  EXPECT_EQ(to_yaml(again), yaml);
  EXPECT_TRUE(again.camera_to_base_m.isApprox(original.camera_to_base_m, 0));
  EXPECT_EQ(again.drivers.arm.parity, original.drivers.arm.parity);
}

TEST_F(ConfigTest, ChangedKeysNameEveryDifferenceByItsPath) {
  const Config a = load_config(repo_file("config/ajard.yaml"));
  EXPECT_TRUE(changed_keys(a, a).empty());
  Config b = a;
  b.logging.level = a.logging.level == LogLevel::kDebug ? LogLevel::kInfo : LogLevel::kDebug;
  b.network.port = static_cast<std::uint16_t>(a.network.port + 1);
  b.base.right.card_axis = a.base.right.card_axis + 1;
  b.camera_to_base_m(0, 3) += 0.01;
  EXPECT_EQ(changed_keys(a, b),
            (std::vector<std::string>{"network.port", "frames.camera_to_base_m",
                                      "base.right_wheel.card_axis", "logging.level"}));
}

TEST_F(ConfigTest, ADuplicateKeyIsRefusedWithTheLinesOfBoth) {
  // yaml-cpp keeps the first of two equal keys silently: the second would be ignored.
  const std::string e = error_for(
      "base:\n  wheel_radius_m: 0.1\n  gear_ratio: 50\n"
      "  wheel_radius_m: 0.2\n");
  EXPECT_NE(e.find("ajard.yaml:4: base.wheel_radius_m: is given twice (lines 2 and 4)"),
            std::string::npos)
      << e;
  const std::string item =
      error_for("network:\n  tls:\n    identities:\n      - {cn: a, role: observer, cn: b}\n");
  EXPECT_NE(item.find("network.tls.identities[0].cn: is given twice"), std::string::npos) << item;
}

TEST_F(ConfigTest, ADuplicateSectionIsRefusedWithTheLinesOfBoth) {
  const std::string e = error_for(
      "logging:\n  level: debug\nstate:\n  directory: s\n"
      "logging:\n  level: info\n");
  EXPECT_NE(e.find("ajard.yaml:5: logging: is given twice (lines 1 and 5)"), std::string::npos)
      << e;
}

TEST_F(ConfigTest, NoneMeansNoFaultAndNoLogging) {
  const Config c = load_config(
      write("drivers:\n  mock: {card_fault: none, arm_fault: stuck}\nlogging:\n  level: none\n"));
  EXPECT_EQ(c.drivers.mock.card_fault, drivers::MockFault::kNone);
  EXPECT_EQ(c.drivers.mock.arm_fault, drivers::MockArmFault::kStuck);
  EXPECT_EQ(c.logging.level, LogLevel::kNone);
  const std::string yaml = to_yaml(c);
  EXPECT_NE(yaml.find("card_fault: none"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("level: none"), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find(": off"), std::string::npos) << yaml;
}

TEST_F(ConfigTest, TheRetiredWordOffAndTheFalseYaml11ToolsWriteForItSayWhatWasMeant) {
  for (const char* yaml :
       {"drivers:\n  mock:\n    card_fault: off\n", "drivers:\n  mock:\n    card_fault: false\n"}) {
    const std::string e = error_for(yaml);
    EXPECT_NE(e.find("ajard.yaml:3: drivers.mock.card_fault: means 'none'"), std::string::npos)
        << e;
    EXPECT_NE(e.find("PyYAML"), std::string::npos) << e;
    EXPECT_NE(e.find("allowed: none, stuck, slow, error, intermittent, garbage"), std::string::npos)
        << e;
  }
  EXPECT_NE(error_for("logging:\n  level: off\n").find("logging.level: means 'none'"),
            std::string::npos);
  // Where `none` is not a word of the key, `off` is just not allowed.
  EXPECT_NE(error_for("drivers:\n  kind: off\n").find("drivers.kind: is not one of the allowed"),
            std::string::npos);
}

TEST_F(ConfigTest, AnIdentityNeedsItsRole) {
  const std::string e = error_for("network:\n  tls:\n    identities:\n      - {cn: a}\n");
  EXPECT_NE(e.find("network.tls.identities[0].role: is required"), std::string::npos) << e;
}

TEST_F(ConfigTest, DefaultsRoundTripAndEveryKeyIsPrinted) {
  const Config defaults = default_config();
  const std::string yaml = to_yaml(defaults);
  const Config again = load_config(write(yaml));
  EXPECT_EQ(to_yaml(again), yaml);
  EXPECT_TRUE(changed_keys(defaults, again).empty());
  for (const auto& key : config_keys(defaults)) {
    const std::string leaf = key.path.substr(key.path.rfind('.') + 1);
    EXPECT_NE(yaml.find(leaf + ":"), std::string::npos) << key.path;
  }
}

TEST_F(ConfigTest, ChangedKeysSeeListsAndWords) {
  const Config a = default_config();
  Config b = a;
  b.network.tls.identities.push_back({{TlsIdentity::Kind::kCommonName, "op"}, true, true});
  b.drivers.mock.arm_fault = drivers::MockArmFault::kGarbage;
  b.limits.max_depth_m = 5;
  EXPECT_EQ(changed_keys(a, b),
            (std::vector<std::string>{"network.tls.identities", "limits.depth_m",
                                      "drivers.mock.arm_fault"}));
}

// docs/configuration.md's tables: `| `key` | `default` | allowed | meaning |` under a heading whose
// first word is the section ("## base", "### network.tls (...)"). Each row must be the key's row of
// config_fields.hpp: its default, what the reader allows and its meaning, and every key must have
// its row (ajard.yaml(5) is generated from these tables).
TEST_F(ConfigTest, TheReferenceInDocsConfigurationMdIsTheKeyList) {
  const auto keys = config_keys(default_config());
  auto is_section = [&](const std::string& s) {
    for (const auto& k : keys) {
      if (k.path.starts_with(s + ".")) return true;
    }
    return false;
  };
  struct Row {
    std::string value, allowed, meaning;
    int line;
  };
  std::map<std::string, Row> rows;
  std::ifstream doc(repo_file("docs/configuration.md"));
  ASSERT_TRUE(doc) << "docs/configuration.md";
  std::string line, section;
  for (int number = 1; std::getline(doc, line); ++number) {
    if (line.starts_with("#")) {
      std::istringstream words(line.substr(line.find_first_not_of('#')));
      words >> section;
      if (!is_section(section)) section.clear();
      continue;
    }
    if (section.empty() || !line.starts_with("| `")) continue;
    std::vector<std::string> cells;  // split at '|' not escaped as '\|'
    std::string cell;
    for (std::size_t i = 1; i < line.size(); ++i) {
      if (line[i] == '|' && line[i - 1] != '\\') {
        cells.push_back(cell.substr(1, cell.size() - 2));  // the spaces around
        cell.clear();
      } else if (!(line[i] == '\\' && i + 1 < line.size() && line[i + 1] == '|')) {
        cell += line[i];
      }
    }
    ASSERT_EQ(cells.size(), 4u) << "docs/configuration.md:" << number << ": " << line;
    const std::string key = section + "." + cells[0].substr(1, cells[0].size() - 2);
    EXPECT_EQ(rows.count(key), 0u) << "docs/configuration.md:" << number << ": " << key << " twice";
    rows[key] = {cells[1], cells[2], cells[3], number};
  }
  for (const auto& k : keys) {
    const std::string expected_value = "`" + k.value + "`";
    std::string meaning = k.meaning;  // a '|' in a cell is written '\|'
    for (std::size_t at = meaning.find('|'); at != std::string::npos;
         at = meaning.find('|', at + 2))
      meaning.insert(at, "\\");
    const std::string expected_row = "| `" + k.path.substr(k.path.find('.') + 1) + "` | " +
                                     expected_value + " | " + k.allowed + " | " + meaning + " |";
    EXPECT_FALSE(k.meaning.empty()) << k.path << " has no meaning in config_fields.hpp";
    const auto row = rows.find(k.path);
    if (row == rows.end()) {
      ADD_FAILURE() << "docs/configuration.md has no row for " << k.path << ":\n" << expected_row;
      continue;
    }
    EXPECT_EQ(row->second.value, expected_value) << "docs/configuration.md:" << row->second.line
                                                 << ": default of " << k.path << ", expected\n"
                                                 << expected_row;
    EXPECT_EQ(row->second.allowed, k.allowed) << "docs/configuration.md:" << row->second.line
                                              << ": allowed values of " << k.path << ", expected\n"
                                              << expected_row;
    EXPECT_EQ(row->second.meaning, k.meaning)
        << "docs/configuration.md:" << row->second.line << ": meaning of " << k.path
        << " (config_fields.hpp), expected\n"
        << expected_row;
    rows.erase(row);
  }
  for (const auto& [key, row] : rows) {
    ADD_FAILURE() << "docs/configuration.md:" << row.line << ": " << key << " is not a key";
  }
}

}  // namespace
}  // namespace ajar::daemon
