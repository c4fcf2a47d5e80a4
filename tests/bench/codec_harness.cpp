// Codec: the streaming decoder over ~1 MiB of mixed frames (every sample message, fed in 4 KiB
// reads like socket reads) vs CRC-32C alone over the same frames (exactly the two calls the
// decoder makes per frame: header bytes 0..17 and the payload), in alternating blocks (harness.hpp:
// A B A B ..., CPU time of this thread, pinned), for each CRC-32C path this CPU has. Target: decode
// >= 0.5x CRC-only with the hardware CRC. protocol_bench.cpp has the same figures as Google
// Benchmarks (and encode, per-frame decode); this is the same-run comparison scripts/bench prints.
#include <time.h>

#include "../protocol/samples.hpp"
#include "ajar/protocol/crc32c.hpp"
#include "harness.hpp"

namespace ajar::bench {
namespace {

using namespace protocol;

std::vector<std::uint8_t> mixed_stream() {
  std::vector<std::uint8_t> b;
  const auto all = samples::all();
  while (b.size() < (1u << 20))
    for (const auto& s : all)
      if (!encode_append(s.envelope, b)) fail("encode");
  return b;
}

std::int64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// MB/s of `passes` runs of `f` over `bytes`.
template <class F>
double throughput(std::size_t bytes, int passes, F&& f) {
  const std::int64_t t0 = thread_cpu_ns();
  for (int i = 0; i < passes; ++i)
    f();
  const double s = static_cast<double>(thread_cpu_ns() - t0) * 1e-9;
  return static_cast<double>(bytes) * passes / s / 1e6;
}

}  // namespace
}  // namespace ajar::bench

int main(int argc, char** argv) {
  using namespace ajar::bench;
  using namespace ajar::protocol;
  bool smoke = false;
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--smoke") smoke = true;
  const Placement where = placement();
  pin_this_thread(where.client);
  const int blocks = smoke ? 3 : 2 * kMinBlocks;
  const int passes = smoke ? 2 : 40;
  const auto stream = mixed_stream();
  std::vector<std::pair<std::size_t, std::size_t>> frames;  // (offset, size), computed once
  for (std::size_t pos = 0; pos < stream.size();) {
    const auto h = decode_header(std::span(stream).subspan(pos).first<kHeaderSize>());
    frames.emplace_back(pos, kHeaderSize + h.payload_length);
    pos += kHeaderSize + h.payload_length;
  }
  info("codec: " + std::to_string(stream.size()) + " bytes, " + std::to_string(frames.size()) +
       " frames; " + std::to_string(blocks) + " blocks of " + std::to_string(passes) +
       " passes per side, CPU time, " + where.describe() + "; load average " + load_average());
  std::size_t messages = 0;
  const auto decode = [&] {
    StreamDecoder decoder;
    StreamDecoder::Outcome o;
    for (std::size_t pos = 0; pos < stream.size(); pos += 4096) {
      std::span<const std::uint8_t> in(stream.data() + pos,
                                       std::min<std::size_t>(4096, stream.size() - pos));
      while (!in.empty()) {
        in = in.subspan(decoder.feed(in, o));
        if (o.kind == StreamDecoder::Kind::kMessage) ++messages;
        if (o.kind == StreamDecoder::Kind::kError) fail("decode error in the sample stream");
      }
    }
  };
  volatile std::uint32_t sink = 0;
  const auto crc_only = [&] {
    std::uint32_t acc = 0;
    for (const auto& [pos, size] : frames) {
      acc ^= crc32c(std::span(stream).subspan(pos, 18));
      acc ^= crc32c(std::span(stream).subspan(pos + kHeaderSize, size - kHeaderSize));
    }
    sink = sink ^ acc;
  };
  const Crc32cPath saved = crc32c_path();
  std::string hardware;
  for (const auto path : {Crc32cPath::kSse42, Crc32cPath::kArmv8, Crc32cPath::kTable}) {
    if (!crc32c_available(path) || !force_crc32c_path(path)) continue;
    const bool hw = path != Crc32cPath::kTable;
    if (hw) hardware = std::string(to_string(path));
    decode();  // warm-up
    crc_only();
    Paired p;
    for (int b = 0; b < blocks; ++b) {
      const double base = throughput(stream.size(), passes, crc_only);
      const double subject = throughput(stream.size(), passes, decode);
      p.add(base, subject);
    }
    compare_row("stream decode (4 KiB reads), crc " + std::string(to_string(path)), p, "MB/s",
                hw ? ">= 0.5x" : "", "vs CRC-only, same path, same frames");
  }
  force_crc32c_path(saved);
  if (hardware.empty()) info("no hardware CRC-32C on this CPU: table path only");
  return messages > 0 ? 0 : 1;
}
