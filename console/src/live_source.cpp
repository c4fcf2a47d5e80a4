#include "ajar/console/openni_source.hpp"

namespace ajar::console {

#ifdef AJAR_CONSOLE_HAVE_OPENNI2
std::unique_ptr<FrameSource> make_openni_source(const std::string& uri, std::string& error);
#endif

std::unique_ptr<FrameSource> make_live_source(const std::string& uri, std::string& error) {
#ifdef AJAR_CONSOLE_HAVE_OPENNI2
  return make_openni_source(uri, error);
#else
  (void)uri;
  error =
      "this ajar-console was built without OpenNI2: install libopenni2-dev (scripts/install-deps) "
      "and rebuild for the live camera, or use --source sim / --source recorded";
  return nullptr;
#endif
}

}  // namespace ajar::console
