// ajar-consumer HOST:PORT: connects to ajard as an observer, pings it and prints its procedure
// state. Exit 0 only if the Hello, the Ping and the GetStatus were all answered.
#include <cstdio>
#include <string>

#include "ajar/client/client.hpp"
#include "ajar/version.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: ajar-consumer HOST:PORT\n");
    return 2;
  }
  const auto endpoint = ajar::client::parse_endpoint(argv[1]);
  if (!endpoint) {
    std::fprintf(stderr, "ajar-consumer: bad address %s\n", argv[1]);
    return 2;
  }
  ajar::client::ClientOptions options;
  options.client_name = "ajar-consumer";
  ajar::client::Client client(options);
  if (const auto connected = client.connect(*endpoint); !connected) {
    std::fprintf(stderr, "ajar-consumer: connect: %s\n", connected.error().message.c_str());
    return 3;
  }
  if (!client.hello(ajar::protocol::Role::kObserver).ok()) {
    std::fprintf(stderr, "ajar-consumer: Hello not answered with Welcome\n");
    return 1;
  }
  const auto pong = client.request(ajar::protocol::Ping{});
  if (!pong.ok() || pong.get<ajar::protocol::Pong>() == nullptr) {
    std::fprintf(stderr, "ajar-consumer: Ping not answered with Pong\n");
    return 1;
  }
  const auto status = client.request(ajar::protocol::GetStatus{});
  const auto* s = status.get<ajar::protocol::Status>();
  if (!status.ok() || s == nullptr) {
    std::fprintf(stderr, "ajar-consumer: GetStatus not answered with Status\n");
    return 1;
  }
  std::printf("ajar-consumer (ajar %s): pong in %lld ms, state %s, %u session(s)\n", ajar::kVersion,
              static_cast<long long>(pong.round_trip.count()),
              std::string(ajar::protocol::to_string(s->state)).c_str(),
              static_cast<unsigned>(s->session_count));
  return 0;
}
