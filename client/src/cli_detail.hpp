// ajarctl's command line inside ajar_ctl: the command table and the CLI11 parsers that cli.cpp
// parses with and cli_help.cpp prints --help and the completion from (one description each).
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

#include "ajar/client/cli.hpp"

namespace ajar::client::detail {

// Every ajarctl command, once: the --help list, `ajarctl help CMD` / `CMD --help`, did-you-mean and
// the bash completion (ajarctl --complete) are all made from this table and the command's parser.
// `words` lists its fixed first arguments, or "@file" / "@dir", for completion.
struct CommandInfo {
  std::string_view name;
  std::string_view synopsis;     // one line: "ping [-n N] [-i S]"
  std::string_view summary;      // one line, for the list in --help
  std::string_view details;      // `ajarctl help CMD`: what it does, its arguments, its role
  std::string_view own_options;  // conformance, simulate: options their own parser reads
  std::string_view words;        // first-argument words, "@file" or "@dir", for completion
};
std::span<const CommandInfo> commands();
const CommandInfo* find_command(std::string_view name);

// What a command's options and arguments are bound to while it is parsed.
struct CommandArgs {
  Command command;
  std::vector<std::string> words;  // positional arguments, checked after parsing
  bool no_wait = false;            // align, engage, approach
  bool velocity = false;           // drive: --linear or --angular given
  bool clear = false;              // reset
};

// The global options, bound to `o` (in command-line order: a later --connect overrides
// --client-config's and the other way round). Parsing stops at the first word that is not an
// option; an unknown option is left there too (cli.cpp refuses it).
std::unique_ptr<CLI::App> global_parser(GlobalOptions& o);
// COMMAND's options and positional arguments, bound to `a`; nullptr for the commands that take
// their words as they are (help; conformance, simulate and script have their own parsers).
std::unique_ptr<CLI::App> command_parser(const CommandInfo& info, core::Frame& frame,
                                         CommandArgs& a);

// --client-config FILE: `connect: HOST:PORT` and `tls: {ca, certificate, private_key,
// server_name}` into `o`; relative paths are taken from the file's folder. Empty, or what is wrong
// (naming the file and the key). cli_config.cpp.
std::string load_client_config(const std::string& path, GlobalOptions& o);

// The closest name within a third of the word's length (at least 1, at most 3 edits), or one the
// word is a prefix of; empty if none is close.
std::string closest(std::string_view word, const std::vector<std::string>& names);

}  // namespace ajar::client::detail
