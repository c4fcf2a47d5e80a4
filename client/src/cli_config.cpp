// ajarctl --client-config FILE (cli_detail.hpp).
#include <filesystem>
#include <tuple>

#include <yaml-cpp/yaml.h>

#include "cli_detail.hpp"

namespace ajar::client::detail {

std::string load_client_config(const std::string& path, GlobalOptions& o) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    return "--client-config " + path + ": " + e.what();
  }
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  auto text = [&](const YAML::Node& map, const char* key, std::string& out,
                  bool is_path) -> std::string {
    const YAML::Node n = map[key];
    if (!n) return {};
    if (!n.IsScalar() || n.Scalar().empty())
      return path + ": " + key + ": must be a non-empty string";
    std::filesystem::path value = n.Scalar();
    out = is_path && value.is_relative() ? (folder / value).string() : value.string();
    return {};
  };
  if (!root.IsMap()) return path + ": must be a map (connect, tls)";
  for (const auto& entry : root) {
    const auto key = entry.first.as<std::string>();
    if (key != "connect" && key != "tls") return path + ": unknown key '" + key + "'";
  }
  std::string connect;
  if (auto e = text(root, "connect", connect, false); !e.empty()) return e;
  if (!connect.empty()) {
    auto endpoint = parse_endpoint(connect);
    if (!endpoint) return path + ": connect: wants HOST:PORT, got '" + connect + "'";
    o.endpoint = *endpoint;
  }
  if (const YAML::Node tls = root["tls"]) {
    if (!tls.IsMap()) return path + ": tls: must be a map";
    for (const auto& entry : tls) {
      const auto key = entry.first.as<std::string>();
      if (key != "ca" && key != "certificate" && key != "private_key" && key != "server_name")
        return path + ": tls." + key + ": unknown key (allowed: ca, certificate, private_key, " +
               "server_name)";
    }
    for (auto [key, out, is_path] :
         {std::tuple<const char*, std::string*, bool>{"ca", &o.tls.ca, true},
          {"certificate", &o.tls.certificate, true},
          {"private_key", &o.tls.private_key, true},
          {"server_name", &o.tls.server_name, false}}) {
      if (auto e = text(tls, key, *out, is_path); !e.empty()) return e;
    }
  }
  return {};
}

}  // namespace ajar::client::detail
