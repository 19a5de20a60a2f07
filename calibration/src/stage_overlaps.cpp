// Stage "overlaps", after the results: at the optimum, every recording of the experiment
// replayed as the analysis replays it (model::predict_experiment with the fitted lag, depth
// offset and pose), to name any two of one sample that removed the same bone. The fit took
// each as a drilling into bone as scanned, so the one drilled second biased the constants:
// fit.json, the summary and CalibrationOutput::overlaps say so, whichever front end ran it.
#include "burrbench/model/model_params.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {

void name_overlaps(const Run& run, CalibrationOutput& res) {
  run.stage("overlaps", "the bone each recording removed at the optimum, compared pair by pair");
  model::PredictOptions po;
  po.fit = &res.fit;
  po.threads = run.opt.threads;
  po.replay.cancel = run.opt.cancel;
  po.replay.quadrature = run.opt.quadrature;
  res.overlaps = model::predict_experiment(run.exp, model::ModelParams::from(res.params), po).overlaps;
  for (const model::RemovedOverlap& o : res.overlaps) {
    res.fit.settings["warnings"].push_back(o.text());
    res.summary += "warning: " + o.text() + "\n";
  }
  res.fit.solver.replays += run.exp.recordings.size();
  auto& equivalents = res.fit.settings["derivatives"]["replay_work"]["replay_equivalents"];
  if (equivalents.is_number())  // these are plain replays
    equivalents = equivalents.get<double>() + double(run.exp.recordings.size());
}

}  // namespace burrbench::calibration::detail
