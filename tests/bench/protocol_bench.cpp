// Protocol throughput: encode/decode of typical frames, the streaming decoder over a long stream of
// mixed frames, and CRC-32C alone over the same bytes (the limit). The stream and CRC benchmarks
// run once per CRC-32C implementation this CPU has (second argument: 0 table, 1 SSE4.2, 2 ARMv8),
// so the hardware path is compared with the table in the same run. Figures and the command:
// docs/performance.md.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdlib>
#include <string>
#include <vector>

#include "../protocol/samples.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/crc32c.hpp"

namespace {

using namespace ajar::protocol;

const Envelope& sample(const char* name) {
  static const auto all = samples::all();
  for (const auto& s : all) {
    if (s.name == name) return s.envelope;
  }
  std::abort();
}

// ~1 MiB of every sample frame, repeated.
const std::vector<std::uint8_t>& mixed_stream() {
  static const std::vector<std::uint8_t> stream = [] {
    std::vector<std::uint8_t> b;
    const auto all = samples::all();
    while (b.size() < (1u << 20)) {
      for (const auto& s : all) {
        if (!encode_append(s.envelope, b)) std::abort();
      }
    }
    return b;
  }();
  return stream;
}

void BM_Encode(benchmark::State& state, const char* name) {
  const Envelope& e = sample(name);
  std::array<std::uint8_t, kMaxFrameSize> out{};
  std::size_t n = 0;
  for (auto _ : state) {
    n = encode(e, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(n));
}

void BM_DecodeFrame(benchmark::State& state, const char* name) {
  std::vector<std::uint8_t> frame;
  if (!encode_append(sample(name), frame)) std::abort();
  StreamDecoder::Outcome o;
  for (auto _ : state) {
    o = decode_frame(frame);
    benchmark::DoNotOptimize(o);
  }
  if (o.kind != StreamDecoder::Kind::kMessage) state.SkipWithError("decode failed");
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(frame.size()));
}

// Forces the CRC path named by the benchmark's argument `index` for the benchmark's duration.
class ForcedPath {
 public:
  ForcedPath(benchmark::State& state, std::size_t index) {
    const auto path = static_cast<Crc32cPath>(state.range(index));
    state.SetLabel(std::string("crc ") + std::string(to_string(path)));
    ok_ = force_crc32c_path(path);
    if (!ok_) state.SkipWithError("this CPU lacks this CRC-32C path");
  }
  ~ForcedPath() { force_crc32c_path(saved_); }
  bool ok() const { return ok_; }

 private:
  Crc32cPath saved_ = crc32c_path();
  bool ok_ = false;
};

// The streaming decoder over the mixed stream, fed in `chunk` byte reads (like socket reads).
void BM_StreamDecode(benchmark::State& state) {
  ForcedPath forced(state, 1);
  if (!forced.ok()) return;
  const auto& stream = mixed_stream();
  const auto chunk = static_cast<std::size_t>(state.range(0));
  std::size_t messages = 0;
  for (auto _ : state) {
    StreamDecoder decoder;
    StreamDecoder::Outcome o;
    for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
      std::span<const std::uint8_t> in(stream.data() + pos, std::min(chunk, stream.size() - pos));
      while (!in.empty()) {
        in = in.subspan(decoder.feed(in, o));
        if (o.kind == StreamDecoder::Kind::kMessage) ++messages;
      }
    }
    benchmark::DoNotOptimize(messages);
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(stream.size()));
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(messages), benchmark::Counter::kIsRate);
}

// CRC-32C alone over the same stream, frame by frame (the same calls the decoder makes).
void BM_Crc32cOnly(benchmark::State& state) {
  ForcedPath forced(state, 0);
  if (!forced.ok()) return;
  const auto& stream = mixed_stream();
  // Frame boundaries, computed once.
  std::vector<std::pair<std::size_t, std::size_t>> frames;
  for (std::size_t pos = 0; pos < stream.size();) {
    const auto h = decode_header(std::span(stream).subspan(pos).first<kHeaderSize>());
    frames.emplace_back(pos, kHeaderSize + h.payload_length);
    pos += kHeaderSize + h.payload_length;
  }
  for (auto _ : state) {
    std::uint32_t acc = 0;
    for (const auto& [pos, size] : frames) {
      acc ^= crc32c(std::span(stream).subspan(pos, 18));
      acc ^= crc32c(std::span(stream).subspan(pos + kHeaderSize, size - kHeaderSize));
    }
    benchmark::DoNotOptimize(acc);
  }
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(stream.size()));
}

// CRC-32C over the whole stream in one call (no per-frame overhead at all).
void BM_Crc32cContiguous(benchmark::State& state) {
  ForcedPath forced(state, 0);
  if (!forced.ok()) return;
  const auto& stream = mixed_stream();
  for (auto _ : state)
    benchmark::DoNotOptimize(crc32c(stream));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(stream.size()));
}

BENCHMARK_CAPTURE(BM_Encode, telemetry, "telemetry");
BENCHMARK_CAPTURE(BM_Encode, status, "status");
BENCHMARK_CAPTURE(BM_Encode, measure_door_plane_16, "measure_door_plane_16");
BENCHMARK_CAPTURE(BM_Encode, ping, "ping");
BENCHMARK_CAPTURE(BM_DecodeFrame, telemetry, "telemetry");
BENCHMARK_CAPTURE(BM_DecodeFrame, status, "status");
BENCHMARK_CAPTURE(BM_DecodeFrame, measure_door_plane_16, "measure_door_plane_16");
BENCHMARK_CAPTURE(BM_DecodeFrame, ping, "ping");
// The CRC paths this CPU has (the table always).
std::vector<std::int64_t> paths() {
  std::vector<std::int64_t> out;
  for (auto p : {Crc32cPath::kTable, Crc32cPath::kSse42, Crc32cPath::kArmv8})
    if (crc32c_available(p)) out.push_back(static_cast<std::int64_t>(p));
  return out;
}

BENCHMARK(BM_StreamDecode)->ArgsProduct({{1, 64, 4096, 65536}, paths()});
BENCHMARK(BM_Crc32cOnly)->ArgsProduct({paths()});
BENCHMARK(BM_Crc32cContiguous)->ArgsProduct({paths()});

}  // namespace
