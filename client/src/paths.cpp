// Where ajarctl finds its installed files (cmake/install_paths.hpp.in).
#include <filesystem>
#include <system_error>

#include "ajar/client/cli.hpp"
#include "ajar/install_paths.hpp"

namespace ajar::client {

std::string default_vectors_dir() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path installed = install::beside_executable(install::kBinToPkgData, "vectors");
  if (!installed.empty() && fs::is_directory(installed, ec)) return installed.string();
#ifdef AJAR_SOURCE_VECTORS_DIR
  if (fs::is_directory(AJAR_SOURCE_VECTORS_DIR, ec)) return AJAR_SOURCE_VECTORS_DIR;
#endif
  if (fs::is_directory("tests/conformance/vectors", ec)) return "tests/conformance/vectors";
  return installed.empty() ? std::string("tests/conformance/vectors") : installed.string();
}

}  // namespace ajar::client
