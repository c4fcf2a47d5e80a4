#include "serial_arm_port.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <libserial/SerialPort.h>

#include <cerrno>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace ajar::drivers {
namespace {

// The settings' numbers and letters in libserial's enums.
template <typename Key, typename Value, std::size_t N>
std::optional<Value> lookup(const std::pair<Key, Value> (&table)[N], Key key) {
  for (const auto& [k, v] : table) {
    if (k == key) return v;
  }
  return std::nullopt;
}

using B = LibSerial::BaudRate;
constexpr std::pair<int, B> kBaudRates[] = {{9600, B::BAUD_9600},     {19200, B::BAUD_19200},
                                            {38400, B::BAUD_38400},   {57600, B::BAUD_57600},
                                            {115200, B::BAUD_115200}, {230400, B::BAUD_230400},
                                            {460800, B::BAUD_460800}, {921600, B::BAUD_921600}};
using C = LibSerial::CharacterSize;
constexpr std::pair<int, C> kCharacterSizes[] = {
    {5, C::CHAR_SIZE_5}, {6, C::CHAR_SIZE_6}, {7, C::CHAR_SIZE_7}, {8, C::CHAR_SIZE_8}};
using P = LibSerial::Parity;
constexpr std::pair<char, P> kParities[] = {
    {'N', P::PARITY_NONE}, {'E', P::PARITY_EVEN}, {'O', P::PARITY_ODD}};
using S = LibSerial::StopBits;
constexpr std::pair<int, S> kStopBits[] = {{1, S::STOP_BITS_1}, {2, S::STOP_BITS_2}};

}  // namespace

// Opens and configures the device with libserial and returns our own descriptor for it.
//
// libserial 1.0's SerialPort::Close() (also run by its destructor) restores the termios saved at
// Open() with tcsetattr() and throws if that fails -- which it does with EIO on a hung-up tty
// (cable pulled, pty master closed), so a SerialPort destroyed after a hang-up terminates the
// process. We therefore keep libserial's descriptor only for opening and configuring: we dup() it,
// take its termios, Close() the SerialPort while the device is healthy, and re-apply the termios on
// our duplicate, which we read with poll()/read() (EIO, hang-up and EOF are visible there).
Result<int> open_arm_port(const SerialArmSettings& s) {
  const auto baud = lookup(kBaudRates, s.baud);
  const auto size = lookup(kCharacterSizes, s.data_bits);
  const auto par = lookup(kParities, s.parity);
  const auto stop = lookup(kStopBits, s.stop_bits);
  const std::string where = "serial arm " + s.device + ": ";
  if (!baud) return make_error(ErrorCode::kDriverError, "baud", where + "unsupported baud rate");
  if (!size) return make_error(ErrorCode::kDriverError, "data_bits", where + "data bits not 5..8");
  if (!par) return make_error(ErrorCode::kDriverError, "parity", where + "parity not N, E or O");
  if (!stop) return make_error(ErrorCode::kDriverError, "stop_bits", where + "stop bits not 1/2");

  auto* port = new LibSerial::SerialPort;
  int fd = -1;
  try {
    port->Open(s.device);
    port->SetBaudRate(*baud);
    port->SetCharacterSize(*size);
    port->SetParity(*par);
    port->SetStopBits(*stop);
    port->SetFlowControl(LibSerial::FlowControl::FLOW_CONTROL_NONE);
    fd = ::fcntl(port->GetFileDescriptor(), F_DUPFD_CLOEXEC, 0);
    if (fd < 0) throw std::runtime_error(std::string("dup: ") + std::strerror(errno));
    termios tio{};
    if (::tcgetattr(fd, &tio) != 0) {
      throw std::runtime_error(std::string("tcgetattr: ") + std::strerror(errno));
    }
    port->Close();
    delete port;
    port = nullptr;
    if (::tcsetattr(fd, TCSANOW, &tio) != 0 || ::tcflush(fd, TCIOFLUSH) != 0) {
      throw std::runtime_error(std::string("tcsetattr: ") + std::strerror(errno));
    }
    // O_NONBLOCK (set by libserial's open) is shared by the duplicate: reads never block.
    return fd;
  } catch (const std::exception& e) {
    if (fd >= 0) ::close(fd);
    if (port != nullptr) {
      if (port->IsOpen()) {
        try {
          port->Close();
          delete port;
        } catch (const std::exception&) {
          // Close() failed (hung-up device): close the descriptor ourselves and leak the small
          // SerialPort object, whose destructor would throw again and terminate the process.
          ::close(port->GetFileDescriptor());
        }
      } else {
        delete port;
      }
    }
    return make_error(ErrorCode::kArmDisconnected, "device", where + e.what());
  }
}

}  // namespace ajar::drivers
