// Host-side cost of acquisition: decoding a 42-register FT block and appending a sample
// to the journal (with and without fdatasync). Targets: far below the 1 ms poll period.
#include <unistd.h>

#include <filesystem>

#include <benchmark/benchmark.h>

#include "burrbench/rig/decode.hpp"
#include "burrbench/rig/journal.hpp"

using namespace burrbench::rig;

static void BM_DecodeFtBlock(benchmark::State& state) {
  ChannelSpec f;
  f.type = ValueType::Float32;
  f.registers = {200, 202, 204, 206, 208, 210};
  std::vector<std::uint16_t> regs(42, 0x4120);
  double out[6];
  for (auto _ : state) {
    benchmark::DoNotOptimize(decode_channel(f, regs, 180, out));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_DecodeFtBlock);

static void BM_JournalAppend(benchmark::State& state) {
  const auto path = std::filesystem::temp_directory_path() / ("bench_journal_" + std::to_string(::getpid()));
  std::filesystem::remove(path);
  {
    JournalWriter w(path, "{}");
    JournalSample s;
    s.regs.assign(42, 7);
    std::int64_t i = 0;
    for (auto _ : state) {
      s.t_send_ns = i;
      s.counter = i++;
      w.append(s);
      if (state.range(0) && i % state.range(0) == 0) w.sync();
    }
    w.sync();
    state.SetItemsProcessed(state.iterations());
  }
  std::filesystem::remove(path);
}
// 10000: nearly buffered only (bounded memory); 100: one fsync per 100 samples (50 ms of
// two 1 kHz devices ≈ 100), what acquisition does.
BENCHMARK(BM_JournalAppend)->Arg(10000)->Arg(100);

BENCHMARK_MAIN();
