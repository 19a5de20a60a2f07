#pragma once
// `--step-us` (replay, synth, verify) sets the model's replay step `step_s` in seconds.
// The model names its own field when it refuses a step (more than 1e9 internal steps over
// a recording); the verbs re-raise that error under the option the user typed.
#include <fmt/format.h>

#include <cmath>
#include <string>
#include <utility>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::apps {

inline void check_step_us(double step_us) {
  if (!(step_us >= 0) || !std::isfinite(step_us))
    throw InputError("command line", "--step-us", "a step ≥ 0 (µs; 0 = half the sample period)",
                     fmt::format("{}", step_us));
}

// Runs `work` (which replays with step_s = step_us·10⁻⁶); a refused step is reported as
// "command line: --step-us (recording …): expected …, got <µs> µs (<the model's figures>)".
template <class Work>
decltype(auto) with_step_option(double step_us, Work&& work) {
  try {
    return std::forward<Work>(work)();
  } catch (const InputError& e) {
    if (e.file() != "replay" || e.field().rfind("step_s", 0) != 0) throw;
    throw InputError("command line", "--step-us" + e.field().substr(6), e.expected(),
                     fmt::format("{} µs ({})", step_us, e.got()));
  }
}

}  // namespace burrbench::apps
