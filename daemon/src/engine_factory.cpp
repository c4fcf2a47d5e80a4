// make_engine(config): the drivers the config selects. Kept apart from engine.cpp so that tests
// over injected drivers do not need the driver factory.
#include "ajar/daemon/config.hpp"
#include "ajar/daemon/engine.hpp"

namespace ajar::daemon {

std::unique_ptr<Engine> make_engine(const Config& config) {
  drivers::DriverSet set;
  try {
    set = drivers::make_drivers(config.drivers, config.base);
  } catch (const drivers::DriverStartupError& e) {
    throw StartupError(std::string("drivers: ") + e.what());
  }
  return make_engine(config, std::move(set));
}

}  // namespace ajar::daemon
