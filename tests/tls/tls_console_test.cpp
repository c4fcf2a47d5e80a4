// The operator console over mutual TLS (issue 13): ajar-console's --ca/--cert/--key reach ajard
// through ajar_client; a private key readable by others is refused before the console listens.
#include <utility>  // before Asio (asio issue 944)

#include <sys/stat.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <thread>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <gtest/gtest.h>

#include "ajar/console/server.hpp"
#include "tls_support.hpp"
#include "wall_source.hpp"

namespace ajar::test {
namespace {

namespace asio = boost::asio;
namespace http = boost::beast::http;

// A grey wall 2 m away: the console needs a camera, this test does not look at it.
std::unique_ptr<console::FrameSource> wall() {
  return std::make_unique<console::testing::WallSource>(16, 12, 15.0, 5.0, false);
}

class TlsConsole : public ::testing::Test {
 protected:
  console::ConsoleOptions console_options(const std::string& operator_name) {
    std::ofstream(web_.path() + "/index.html") << "<html>console</html>";
    console::ConsoleOptions o;
    o.daemon = {"127.0.0.1", server_.port()};
    o.listen_port = 0;
    o.web_dir = web_.path();
    o.tls = pki_.client_tls(operator_name);
    return o;
  }

  static std::string state_json(std::uint16_t port) {
    asio::io_context io;
    asio::ip::tcp::socket s(io);
    s.connect({asio::ip::make_address("127.0.0.1"), port});
    http::request<http::string_body> request{http::verb::get, "/api/state", 11};
    request.set(http::field::host, "127.0.0.1:" + std::to_string(port));
    http::write(s, request);
    boost::beast::flat_buffer buffer;
    http::response<http::string_body> response;
    http::read(s, buffer, response);
    return response.body();
  }

  LogCapture log_;
  Pki pki_;
  FakeEngine engine_;
  TlsServer server_{engine_, server_options(pki_)};
  TempDir web_;
};

TEST_F(TlsConsole, TheConsoleConnectsToATlsDaemonWithItsCertificate) {
  console::ConsoleServer console(console_options("alice"), wall(), nullptr);
  const std::uint16_t port = console.listen();
  std::thread runner([&] { console.run(); });
  EXPECT_TRUE(eventually([&] {
    return state_json(port).find("\"connected\":true") != std::string::npos;
  })) << state_json(port);
  EXPECT_TRUE(log_.contains("authenticated as cn:alice", "controller"));
  EXPECT_TRUE(log_.contains("(ajar-console) greeted", "as controller")) << log_.all();
  console.stop();
  runner.join();
}

TEST_F(TlsConsole, AKeyReadableByOthersIsRefusedBeforeTheConsoleListens) {
  ASSERT_EQ(::chmod(pki_.path("alice.key").c_str(), 0640), 0);
  console::ConsoleServer console(console_options("alice"), wall(), nullptr);
  try {
    console.listen();
    ADD_FAILURE() << "a group-readable key was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--key"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("0640"), std::string::npos) << e.what();
  }
  EXPECT_EQ(server_.session_count(), 0U);
}

TEST_F(TlsConsole, ACertificateWithoutItsKeyIsRefused) {
  auto o = console_options("alice");
  o.tls.private_key.clear();
  console::ConsoleServer console(o, wall(), nullptr);
  EXPECT_THROW(console.listen(), std::runtime_error);
}

#ifdef AJAR_CONSOLE_PATH
// ajar-console --client-config FILE (ajarctl's file: relative paths from its folder), run for at
// most `seconds` (then one SIGINT, to the console only: it exits 0). Returns the exit code; output
// in `out`.
int run_console(const std::string& config, int seconds, const std::string& dir, std::string& out) {
  const std::string path = dir + "/console.out";
  const std::string command =
      "timeout --foreground --preserve-status -s INT " + std::to_string(seconds) + " " +
      AJAR_CONSOLE_PATH + " --client-config " + config + " --listen 127.0.0.1:0 >" + path + " 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream in(path);
  out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST_F(TlsConsole, TheConsoleReadsAjarctlsClientConfigAndRefusesAnOpenKeyAtStart) {
  const std::string config = pki_.path("console.yaml");
  std::ofstream(config) << "connect: 127.0.0.1:" << server_.port()
                        << "\ntls: {ca: ca.crt, certificate: alice.crt, private_key: alice.key}\n";
  std::string out;
  EXPECT_EQ(run_console(config, 3, web_.path(), out), 0) << out;
  EXPECT_NE(out.find("(ajard at 127.0.0.1:" + std::to_string(server_.port()) + ", mutual TLS)"),
            std::string::npos)
      << out;

  ASSERT_EQ(::chmod(pki_.path("alice.key").c_str(), 0644), 0);
  EXPECT_EQ(run_console(config, 20, web_.path(), out), 2) << out;
  EXPECT_NE(out.find("--key: '" + pki_.path("alice.key") + "' has mode 0644"), std::string::npos)
      << out;
}
#endif

}  // namespace
}  // namespace ajar::test
