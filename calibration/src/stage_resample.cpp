// Stages "bootstrap", "cross-validation" and "validation segments": refits on resampled
// or held-out data, warm-started from the optimum.
#include <algorithm>
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "pipeline.hpp"

namespace burrbench::calibration::detail {
namespace {

// Contiguous runs of used samples per recording, cut into blocks of at most block_s.
struct Block { std::size_t rec, begin, end; };
std::vector<Block> blocks_of(const std::vector<const RecordingModel*>& models,
                             const SampleWeights& w, double block_s) {
  std::vector<Block> out;
  for (std::size_t r = 0; r < models.size(); ++r) {
    const auto& t = models[r]->t_s();
    std::size_t j = 0;
    while (j < t.size()) {
      if (!(w[r][j] > 0)) { ++j; continue; }
      const std::size_t b = j;
      while (j < t.size() && w[r][j] > 0 && t[j] - t[b] < block_s) ++j;
      out.push_back({r, b, j});
    }
  }
  return out;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const std::size_t i = std::size_t(pos);
  const double f = pos - double(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

// Hold everything but one recording's own nuisances (bias, lag, depth).
std::vector<bool> only_nuisances_of(const Layout& L, std::size_t rec) {
  std::vector<bool> hold(L.size(), true);
  const auto& nz = L.recordings()[rec];
  if (nz.bias >= 0)
    for (int i : {nz.bias, nz.bias + 1, nz.bias + 2}) hold[std::size_t(i)] = false;
  if (nz.lag >= 0) hold[std::size_t(nz.lag)] = false;
  if (nz.depth >= 0) hold[std::size_t(nz.depth)] = false;
  return hold;
}

}  // namespace

void bootstrap(Run& run) {
  const Layout& L = *run.layout;
  const auto blocks = blocks_of(run.models, run.w_all, run.opt.bootstrap_block_s);
  int usable = 0;
  if (run.opt.bootstrap > 0 && blocks.size() >= 2) {
    std::map<std::string, std::vector<double>> boot;  // physics name → replicate estimates
    std::mt19937_64 rng(run.exp.manifest.fit.seed);
    std::uniform_int_distribution<std::size_t> pick(0, blocks.size() - 1);
    run.stage("bootstrap", fmt::format("{} refits on resampled blocks (≤ {:.3g} s)", run.opt.bootstrap,
                                       run.opt.bootstrap_block_s));
    for (int b = 0; b < run.opt.bootstrap; ++b) {
      run.say(fmt::format("bootstrap {}/{}", b + 1, run.opt.bootstrap));
      SampleWeights wb;
      for (const auto& wr : run.w_all) wb.emplace_back(wr.size(), 0.0);
      for (std::size_t k = 0; k < blocks.size(); ++k) {
        const auto& bl = blocks[pick(rng)];
        for (std::size_t j = bl.begin; j < bl.end; ++j) wb[bl.rec][j] += 1.0;
      }
      SolveOptions sb;
      sb.max_iterations = 8;
      sb.hold = run.unc.held;
      const auto r = run.obj->solve(run.x, wb, sb);
      if (!r.usable) continue;
      ++usable;
      for (const auto& p : L.physics())
        if (p.index >= 0 && !run.unc.held[std::size_t(p.index)])
          boot[L.name(std::size_t(p.index))].push_back(std::exp(r.x[std::size_t(p.index)]));
    }
    for (auto& p : run.out.parameters) {
      auto it = boot.find(p.class_name + "." + p.name);
      if (it == boot.end() || it->second.size() < 10) continue;
      p.bootstrap_ci95_low = percentile(it->second, 0.025);
      p.bootstrap_ci95_high = percentile(it->second, 0.975);
    }
  }
  run.out.settings["bootstrap"] = {{"replicates", run.opt.bootstrap}, {"usable", usable},
                                   {"blocks", blocks.size()}, {"block_s", run.opt.bootstrap_block_s},
                                   {"seed", run.exp.manifest.fit.seed}};
}

void cross_validate(Run& run) {
  const Layout& L = *run.layout;
  const auto& models = run.models;
  run.out.settings["cross_validation"] = !run.opt.cross_validate ? "off"
                                         : models.size() >= 2   ? "leave one recording out"
                                                                : "leave one used span out";
  if (!run.opt.cross_validate) return;
  struct Fold { std::string name; SampleWeights train, test; int rec = -1; };
  std::vector<Fold> folds;
  const auto& w_all = run.w_all;
  if (models.size() >= 2) {
    for (std::size_t r = 0; r < models.size(); ++r) {
      Fold f{models[r]->id(), w_all, {}, int(r)};
      for (auto& wr : f.train) std::fill(wr.begin(), wr.end(), 0.0);
      f.test = f.train;
      for (std::size_t q = 0; q < models.size(); ++q) (q == r ? f.test : f.train)[q] = w_all[q];
      folds.push_back(std::move(f));
    }
  } else {
    // One recording: leave out each contiguous used span (a segment) in turn.
    const auto spans = blocks_of(models, w_all, INFINITY);
    if (spans.size() >= 2)
      for (std::size_t s = 0; s < spans.size(); ++s) {
        Fold f{fmt::format("{}@{:.3f}-{:.3f}s", models[0]->id(), models[0]->t_s()[spans[s].begin],
                           models[0]->t_s()[spans[s].end - 1]),
               w_all, w_all, -1};
        std::fill(f.test[0].begin(), f.test[0].end(), 0.0);
        for (std::size_t j = spans[s].begin; j < spans[s].end; ++j) {
          f.train[0][j] = 0;
          f.test[0][j] = 1;
        }
        folds.push_back(std::move(f));
      }
  }
  for (const auto& f : folds) {
    run.stage("cross-validation", fmt::format("without {}", f.name));
    SolveOptions sf;
    sf.max_iterations = 6;
    sf.hold = run.unc.held;
    auto r = run.obj->solve(run.x, f.train, sf);  // warm start from the optimum
    std::vector<double> xf = r.x;
    if (f.rec >= 0) {
      // The held-out recording's own nuisances are re-fitted on it with the physics held
      // at the fold's estimates: they belong to that recording.
      SolveOptions sn;
      sn.max_iterations = 6;
      sn.hold = only_nuisances_of(L, std::size_t(f.rec));
      xf = run.obj->solve(xf, f.test, sn).x;
    }
    const Metrics held = metrics(*run.obj, run.obj->evaluate(xf, f.test, f.rec), xf, f.test);
    const Metrics train = metrics(*run.obj, run.obj->evaluate(xf, f.train), xf, f.train);
    ds::CrossValidationFold cv;
    cv.held_out = f.name;
    cv.metrics["held_out"] = held.json();
    cv.metrics["calibration"] = train.json();
    nlohmann::json params = nlohmann::json::object();
    for (const auto& p : L.physics())
      if (p.index >= 0 && !run.unc.held[std::size_t(p.index)])
        params[L.name(std::size_t(p.index))] = std::exp(xf[std::size_t(p.index)]);
    cv.metrics["parameters"] = params;
    cv.metrics["termination"] = r.termination;
    run.out.cross_validation.push_back(std::move(cv));
  }
}

void score_validation(Run& run) {
  bool any = false;
  for (const auto& wr : run.w_validate)
    for (double v : wr) any |= v > 0;
  if (!any) return;
  // The validating spans use the optimum's physics and their recording's fitted lag, bias
  // and depth offset (fitted on that recording's calibrating spans).
  run.validation_metrics = metrics(*run.obj, run.obj->evaluate(run.x, run.w_validate), run.x, run.w_validate);
}

}  // namespace burrbench::calibration::detail
