// `burrbench sample import | synth | export-nrrd`: make sample volumes from what labs have.
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/density.hpp"
#include "burrbench/data_schema/import/sample_import.hpp"
#include "burrbench/data_schema/import/segment.hpp"
#include "burrbench/data_schema/import/synth.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "burrbench/data_schema/output_files.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "output_paths.hpp"
#include "verb_registry.hpp"

namespace {
namespace fs = std::filesystem;
using namespace burrbench;
using namespace burrbench::data_schema;
using namespace burrbench::data_schema::import;

struct ImportArgs {
  std::string labels, fraction, out, encoding = "float32";
  std::vector<std::string> ct;          // a file, a folder, or (DICOM) a list of files
  std::string dicom_series, density;    // --dicom-series UID, --density PHANTOM.toml
  std::optional<double> threshold_mg_cm3;
  std::vector<double> spacing;
  bool resample = false, overwrite = false;
  double voxel_mm = 0;
  double budget_mb = double(kDefaultBudgetBytes >> 20);
  std::optional<double> threshold, empty_grey, bone_grey;
  SegmentationSettings seg;
};

void check_out_not_input(const std::string& out, const std::vector<std::string>& inputs) {
  burrbench::apps::refuse_output_over_inputs(out, "--out", inputs);
}

// Issue 59, D6b: the files a volume's reader found and opened (a header's detached data
// file, a stack's slices, a DICOM folder's files, a SkyScan log) are inputs as much as the
// paths on the command line, so --out never replaces one, not even with --overwrite.
// Checked as soon as the volume is read, before any resampling, segmentation or write.
void refuse_output_over_files_read(const std::string& out, const ImageVolume& v, const char* option,
                                   const std::string& given) {
  if (out.empty()) return;
  std::vector<fs::path> read = v.files;
  read.insert(read.end(), v.set_aside.begin(), v.set_aside.end());
  for (const auto& f : read)
    if (same_file(out, f))
      throw InputError(out, "--out", "a file that is not one of the inputs (inputs are never replaced, not even with --overwrite)",
                       fmt::format("{}, which {} {} reads", f.string(), option, given));
}

ImageVolume load(const std::vector<std::string>& paths, const ImportArgs& a, Interpolation interp, const ImportLimits& lim,
                 const char* what, const char* option) {
  ReadOptions opt;
  if (!a.spacing.empty()) opt.spacing_mm = glm::dvec3(a.spacing[0], a.spacing[1], a.spacing[2]);
  opt.dicom_series = a.dicom_series;
  ImageVolume v = read_volume(std::vector<fs::path>(paths.begin(), paths.end()), opt, lim);
  const std::string path = paths.size() == 1 ? paths[0] : fmt::format("{} files from {}", paths.size(), paths[0]);
  refuse_output_over_files_read(a.out, v, option, path);
  if (a.resample || a.voxel_mm > 0) {
    const double vox = a.voxel_mm > 0 ? a.voxel_mm : std::min({v.spacing_mm.x, v.spacing_mm.y, v.spacing_mm.z});
    if (!is_cubic(v) || std::abs(vox - v.spacing_mm.x) > 1e-9 * vox) {
      std::cerr << fmt::format("burrbench: resampling {} ({}) from {} x {} x {} mm to {} mm cubic voxels ({})\n", what, path,
                               v.spacing_mm.x, v.spacing_mm.y, v.spacing_mm.z, vox,
                               interp == Interpolation::kNearest ? "nearest" : "trilinear");
      auto files = std::move(v.files);
      v = resample_cubic(v, vox, interp, lim);
      v.files = std::move(files);
    }
  }
  return v;
}

void run_import(const ImportArgs& a) {
  if (a.labels.empty() == a.ct.empty()) throw InputError("<command line>", "--labels / --ct", "exactly one of --labels or --ct");
  if (!a.fraction.empty() && a.labels.empty()) throw InputError("<command line>", "--fraction", "--labels with it (a CT gives its own fraction)");
  if (!a.labels.empty() && (!a.density.empty() || a.threshold_mg_cm3))
    throw InputError("<command line>", a.density.empty() ? "--threshold-mg-cm3" : "--density", "--ct with it (a density calibration maps a CT's greys)");
  if (a.threshold_mg_cm3 && a.density.empty()) throw InputError("<command line>", "--threshold-mg-cm3", "--density PHANTOM.toml with it");
  if (a.threshold_mg_cm3 && a.threshold) throw InputError("<command line>", "--threshold-mg-cm3", "either --threshold or --threshold-mg-cm3, not both");
  if (!a.density.empty() && (a.empty_grey || a.bone_grey))
    throw InputError("<command line>", a.empty_grey ? "--empty-grey" : "--bone-grey", "no grey calibration with --density (the phantom gives χ = 0 and 1)");
  if (!(a.budget_mb > 0 && a.budget_mb <= double(1 << 30))) throw InputError("<command line>", "--budget-mb", "a budget in (0, 2^30] MiB");
  std::vector<std::string> inputs{a.labels, a.fraction, a.density};
  inputs.insert(inputs.end(), a.ct.begin(), a.ct.end());
  check_out_not_input(a.out, inputs);
  burrbench::apps::refuse_existing(a.out, "--out", a.overwrite);
  const ImportLimits lim{static_cast<std::size_t>(a.budget_mb * double(1 << 20))};
  Provenance prov;  // the input files hashed once read, before the long work on them
  SampleVolume s;
  nlohmann::json settings;
  std::optional<TerminalProgress> progress;  // a lab CT takes minutes to segment
  if (!a.labels.empty()) {
    const ImageVolume labels = load({a.labels}, a, Interpolation::kNearest, lim, "labels", "--labels");
    std::optional<ImageVolume> fraction;
    if (!a.fraction.empty()) fraction = load({a.fraction}, a, Interpolation::kTrilinear, lim, "fraction", "--fraction");
    std::vector<fs::path> inputs = labels.files;
    if (fraction) inputs.insert(inputs.end(), fraction->files.begin(), fraction->files.end());
    prov = make_provenance(inputs);
    s = sample_from_labels(labels, fraction, a.labels, a.fraction);
    settings = nlohmann::json::parse(s.segmentation_json);
  } else {
    const ImageVolume ct = load(a.ct, a, Interpolation::kTrilinear, lim, "CT", "--ct");
    std::vector<fs::path> read = ct.files;
    SegmentationSettings seg = a.seg;
    seg.threshold = a.threshold;
    seg.empty_grey = a.empty_grey;
    seg.bone_grey = a.bone_grey;
    std::optional<DensityCalibration> density;
    if (!a.density.empty()) {
      density = calibrate_density(read_density_phantom(a.density), ct, a.ct[0]);
      read.push_back(a.density);
      seg.empty_grey = density->empty_grey();
      seg.bone_grey = density->bone_grey();
      if (a.threshold_mg_cm3) seg.threshold = density->grey(*a.threshold_mg_cm3);
    }
    prov = make_provenance(read);
    // Progress once the CT is read and checked, so that a refused input stays one line.
    progress.emplace("import");
    Segmentation r = segment_ct(ct, seg, a.ct[0], &*progress);
    s = std::move(r.sample);
    settings = r.settings_used;
    if (density) {
      // The segmentation's greys in mg HA/cm³ too, and the calibration that gives them.
      settings["density_calibration"] = density->record;
      settings["empty_grey_source"] = settings["bone_grey_source"] = "density calibration";
      if (a.threshold_mg_cm3) settings["threshold_method"] = "given in mg HA/cm3";
      settings["threshold_mg_HA_cm3"] = density->density(settings["threshold"].get<double>());
      settings["empty_mg_HA_cm3"] = density->density(settings["empty_grey"].get<double>());
      settings["bone_mg_HA_cm3"] = density->density(settings["bone_grey"].get<double>());
    }
    settings["ct_source"] = ct.source_info;
  }
  settings["resampled"] = a.resample || a.voxel_mm > 0;
  if (!a.spacing.empty()) settings["spacing_mm_given"] = a.spacing;
  settings["memory_budget_bytes"] = lim.max_bytes;
  s.segmentation_json = settings.dump();
  // A CT re-exported while it was segmented: the sample would name a scan it was not made of.
  check_unchanged(prov.inputs, "import");
  s.provenance = make_provenance_hashed(prov.inputs);  // created now, of the files as read
  s.sources = s.provenance.inputs;
  if (progress) progress->stage("write", a.out);
  write_sample(a.out, s, a.encoding == "counter8" ? FractionEncoding::kCounter8 : FractionEncoding::kFloat32);
  if (progress) progress->finish(fmt::format("{} voxels", s.labels.size()));
  std::size_t counts[3] = {0, 0, 0};
  for (auto l : s.labels) ++counts[std::min<std::size_t>(l, 2)];
  std::cout << fmt::format("wrote {}: {}x{}x{} voxels of {} mm, origin ({}, {}, {}) mm; empty {}, compact {}, other bone {}\n",
                           a.out, s.dims[0], s.dims[1], s.dims[2], s.voxel_mm, s.origin_mm.x, s.origin_mm.y, s.origin_mm.z,
                           counts[0], counts[1], counts[2]);
}

// `sample import`
void setup_import(CLI::App* sample) {
  auto a = std::make_shared<ImportArgs>();
  auto* imp = sample->add_subcommand("import", "Import a label (+ bone fraction) volume, or segment a grey CT, into a sample file");
  imp->add_option("--labels", a->labels, "label volume (.nrrd/.nhdr/.mha/.mhd or a folder of TIFF/PNG slices)");
  imp->add_option("--fraction", a->fraction, "bone fraction volume (float in [0,1] or uint8 counter n/255)");
  imp->add_option("--ct", a->ct, "grey CT volume to segment (HU or micro-CT grey values): a file, a folder (slices or DICOM), "
                                 "or several DICOM files")->expected(1, -1);
  imp->add_option("--dicom-series", a->dicom_series, "DICOM: the SeriesInstanceUID to import when the files hold several");
  imp->add_option("--density", a->density, "CT: density calibration (burrbench.density TOML: phantom rods or slope/intercept); "
                                           "χ = mg HA/cm³ / tissue density");
  auto thr_mg = std::make_shared<double>();
  auto* o_thr_mg = imp->add_option("--threshold-mg-cm3", *thr_mg, "CT with --density: bone where density ≥ this (mg HA/cm³)");
  imp->add_option("--out", a->out, "output sample file (.h5)")->required();
  imp->add_flag("--overwrite", a->overwrite, "replace an existing --out file (refused otherwise)");
  imp->add_option("--spacing-mm", a->spacing, "voxel spacing sx,sy,sz (required for slice stacks; overrides the file's)")
      ->delimiter(',')->expected(3);
  imp->add_flag("--resample", a->resample, "resample anisotropic voxels to cubic ones (side = smallest spacing unless --voxel-mm)");
  imp->add_option("--voxel-mm", a->voxel_mm, "cubic voxel side for resampling (implies --resample)");
  imp->add_option("--fraction-encoding", a->encoding, "float32 or counter8 (χ = n/255)")->check(CLI::IsMember({"float32", "counter8"}));
  imp->add_option("--budget-mb", a->budget_mb, "memory budget for one decoded volume, MiB")->capture_default_str();
  auto thr = std::make_shared<double>(), eg = std::make_shared<double>(), bg = std::make_shared<double>();
  auto* o_thr = imp->add_option("--threshold", *thr, "CT: bone if grey ≥ this (default: Otsu)");
  auto* o_eg = imp->add_option("--empty-grey", *eg, "CT: grey of empty space, χ = 0 (default: median of interior empty voxels)");
  auto* o_bg = imp->add_option("--bone-grey", *bg, "CT: grey of full bone, χ = 1 (default: median of interior bone voxels)");
  imp->add_option("--bvtv-radius-mm", a->seg.bvtv_radius_mm, "CT: half side of the BV/TV box")->capture_default_str();
  imp->add_option("--compact-bvtv", a->seg.compact_bvtv, "CT: BV/TV at or above which bone is compact")->capture_default_str();
  imp->add_option("--envelope-radius-mm", a->seg.envelope_radius_mm, "CT: closing radius that fills pores for the envelope")->capture_default_str();
  imp->add_option("--bone-open", a->seg.bone_open_vox, "CT: opening radius (voxels) on the bone mask")->capture_default_str();
  imp->add_option("--bone-close", a->seg.bone_close_vox, "CT: closing radius (voxels) on the bone mask")->capture_default_str();
  imp->add_option("--compact-close", a->seg.compact_close_vox, "CT: closing radius (voxels) on the bone mask before the compact opening")->capture_default_str();
  imp->add_option("--compact-open-mm", a->seg.compact_open_mm, "CT: compact bone holds a box of this half side (opening)")->capture_default_str();
  imp->callback([a, thr, eg, bg, o_thr, o_eg, o_bg, thr_mg, o_thr_mg] {
    if (o_thr_mg->count()) a->threshold_mg_cm3 = *thr_mg;
    if (o_thr->count()) a->threshold = *thr;
    if (o_eg->count()) a->empty_grey = *eg;
    if (o_bg->count()) a->bone_grey = *bg;
    run_import(*a);
  });
}

// `sample export-ct`
// The grey volume as imported (DICOM rescaled, folded into the sample's frame; with
// --density in mg HA/cm³), for 3D Slicer or a check against another reader.
void setup_export_ct(CLI::App* sample) {
  auto ea = std::make_shared<ImportArgs>();
  auto* ect = sample->add_subcommand("export-ct", "Write a CT (DICOM series, SkyScan folder, ISQ, NRRD, ...) as imported to a "
                                                  "float NRRD: grey values, or mg HA/cm³ with --density");
  ect->add_option("--ct", ea->ct, "CT volume: a file, a folder (slices or DICOM), or several DICOM files")->required()->expected(1, -1);
  ect->add_option("--dicom-series", ea->dicom_series, "DICOM: the SeriesInstanceUID to export when the files hold several");
  ect->add_option("--spacing-mm", ea->spacing, "voxel spacing sx,sy,sz (required for slice stacks; overrides the file's)")
      ->delimiter(',')->expected(3);
  ect->add_option("--density", ea->density, "density calibration (burrbench.density TOML): write mg HA/cm³");
  ect->add_option("--out", ea->out, "output NRRD (.nrrd)")->required();
  ect->add_flag("--overwrite", ea->overwrite, "replace an existing --out file (refused otherwise)");
  ect->add_option("--budget-mb", ea->budget_mb, "memory budget for the decoded volume, MiB")->capture_default_str();
  ect->callback([ea] {
    const ImportArgs& a = *ea;
    if (!(a.budget_mb > 0 && a.budget_mb <= double(1 << 30))) throw InputError("<command line>", "--budget-mb", "a budget in (0, 2^30] MiB");
    std::vector<std::string> inputs{a.density};
    inputs.insert(inputs.end(), a.ct.begin(), a.ct.end());
    check_out_not_input(a.out, inputs);
    burrbench::apps::refuse_existing(a.out, "--out", a.overwrite);
    const ImportLimits lim{static_cast<std::size_t>(a.budget_mb * double(1 << 20))};
    ImageVolume v = load(a.ct, a, Interpolation::kTrilinear, lim, "CT", "--ct");
    std::vector<fs::path> read = v.files;
    nlohmann::json info = v.source_info;
    if (!a.density.empty()) {
      const DensityCalibration d = calibrate_density(read_density_phantom(a.density), v, a.ct[0]);
      for (float& x : v.values) x = static_cast<float>(d.density(x));
      info["density_calibration"] = d.record;
      info["values"] = "mg HA/cm3";
      read.push_back(a.density);
    } else {
      info["values"] = "grey values as imported";
    }
    const Provenance prov = make_provenance(read);
    nlohmann::json inputs_json = nlohmann::json::array();
    for (const auto& f : prov.inputs) inputs_json.push_back({{"path", f.path}, {"sha256", f.sha256}});
    check_unchanged(prov.inputs, "export-ct");
    write_nrrd(a.out, v, VoxelType::kFloat32,
               {{"burrbench_software_version", prov.software_version},
                {"burrbench_command_line", prov.command_line},
                {"burrbench_created_utc", prov.created_utc},
                {"burrbench_inputs", inputs_json.dump()},
                {"burrbench_source", info.dump()}});
    std::cout << fmt::format("wrote {}: {}x{}x{} voxels of {} x {} x {} mm, origin ({}, {}, {}) mm; {}\n", a.out, v.dims[0],
                             v.dims[1], v.dims[2], v.spacing_mm.x, v.spacing_mm.y, v.spacing_mm.z, v.origin_mm.x,
                             v.origin_mm.y, v.origin_mm.z, info.dump());
  });
}

// `sample synth`
void setup_synth(CLI::App* sample) {
  auto ss = std::make_shared<SynthSettings>();
  auto extent = std::make_shared<std::vector<double>>(std::vector<double>{10, 10, 6});
  auto out = std::make_shared<std::string>();
  auto syn_overwrite = std::make_shared<bool>(false);
  auto* syn = sample->add_subcommand("synth", "Write a seeded synthetic sample: a compact layer over a trabecular core");
  syn->add_option("--voxel-mm", ss->voxel_mm, "cubic voxel side")->capture_default_str();
  syn->add_option("--extent-mm", *extent, "extent x,y,z")->delimiter(',')->expected(3);
  syn->add_option("--compact-mm", ss->compact_mm, "thickness of the compact layer on top (high z)")->capture_default_str();
  syn->add_option("--porosity", ss->porosity, "pore volume fraction of the trabecular core")->capture_default_str();
  syn->add_option("--strut-mm", ss->strut_mm, "length scale of the trabecular plates")->capture_default_str();
  syn->add_option("--seed", ss->seed, "random seed")->capture_default_str();
  syn->add_option("--out", *out, "output sample file (.h5)")->required();
  syn->add_flag("--overwrite", *syn_overwrite, "replace an existing --out file (refused otherwise)");
  syn->callback([ss, extent, out, syn_overwrite] {
    burrbench::apps::refuse_existing(*out, "--out", *syn_overwrite);
    ss->extent_mm = glm::dvec3((*extent)[0], (*extent)[1], (*extent)[2]);
    SampleVolume s = synth_sample(*ss);
    s.provenance = make_provenance({});
    write_sample(*out, s);
    std::cout << fmt::format("wrote {}: {}x{}x{} voxels of {} mm; {}\n", *out, s.dims[0], s.dims[1], s.dims[2], s.voxel_mm,
                             s.segmentation_json);
  });
}

// `sample resample`
void setup_resample(CLI::App* sample) {
  struct ResampleArgs {
    std::string in, out;
    int split = 0, merge = 0;
    bool overwrite = false;
  };
  auto ra = std::make_shared<ResampleArgs>();
  auto* res = sample->add_subcommand("resample", "The same sample at voxels split or merged by an integer factor "
                                                 "(solution verification, coarse-to-fine fits)");
  res->add_option("SAMPLE", ra->in, "sample file (.h5)")->required();
  res->add_option("--split", ra->split, "split every voxel into N³ (voxel side / N): the same bone");
  res->add_option("--merge", ra->merge, "merge blocks of N³ voxels (voxel side × N): bone volume kept, majority class");
  res->add_option("--out", ra->out, "output sample file (.h5)")->required();
  res->add_flag("--overwrite", ra->overwrite, "replace an existing --out file (refused otherwise)");
  res->callback([ra] {
    if ((ra->split != 0) == (ra->merge != 0))
      throw InputError("command line", "--split/--merge", "exactly one of --split N or --merge N");
    check_out_not_input(ra->out, {ra->in});
    burrbench::apps::refuse_existing(ra->out, "--out", ra->overwrite);
    const bool split = ra->split != 0;
    const int n = split ? ra->split : ra->merge;
    if (n < 2 || n > 16)
      throw InputError("command line", split ? "--split" : "--merge", "an integer factor 2..16", std::to_string(n));
    std::vector<InputFile> read;
    const SampleVolume s = read_hashed(ra->in, read, read_sample);
    TerminalProgress progress("resample");  // after the input is read and checked: a refusal stays one line
    progress.stage(split ? "split" : "merge", split ? fmt::format("every voxel into {}", n * n * n)
                                                    : fmt::format("every block of {} voxels into one", n * n * n));
    SampleVolume r = split ? split_voxels(s, n) : merge_voxels(s, n);
    check_unchanged(read, "resample");
    r.sources.push_back({std::filesystem::absolute(ra->in).string(), read.front().sha256});
    r.provenance = make_provenance_hashed(read);
    progress.stage("write", ra->out);
    write_sample(ra->out, r);
    progress.finish(fmt::format("{} voxels", r.labels.size()));
    std::cout << fmt::format("wrote {}: {}x{}x{} voxels of {} mm (from {} mm, {} by {})\n", ra->out, r.dims[0],
                             r.dims[1], r.dims[2], r.voxel_mm, s.voxel_mm, split ? "split" : "merged", n);
  });
}

// `sample export-nrrd`
void setup_export_nrrd(CLI::App* sample) {
  auto in = std::make_shared<std::string>();
  auto prefix = std::make_shared<std::string>();
  auto* exp = sample->add_subcommand("export-nrrd", "Write PREFIX_labels.nrrd and PREFIX_fraction.nrrd for 3D Slicer");
  exp->add_option("SAMPLE", *in, "sample file (.h5)")->required();
  exp->add_option("--out-prefix", *prefix, "output prefix")->required();
  auto exp_overwrite = std::make_shared<bool>(false);
  exp->add_flag("--overwrite", *exp_overwrite, "replace existing PREFIX_*.nrrd files (refused otherwise)");
  exp->callback([in, prefix, exp_overwrite] {
    const std::string lp = *prefix + "_labels.nrrd", fp = *prefix + "_fraction.nrrd";
    check_out_not_input(lp, {*in});
    check_out_not_input(fp, {*in});
    burrbench::apps::refuse_existing(lp, "--out-prefix", *exp_overwrite);
    burrbench::apps::refuse_existing(fp, "--out-prefix", *exp_overwrite);
    const SampleVolume s = read_sample(*in);
    OutputFiles outputs;  // the pair appears together or not at all
    outputs.write(lp, [&](const fs::path& p) { write_nrrd(p, labels_image(s), VoxelType::kUint8); });
    outputs.write(fp, [&](const fs::path& p) { write_nrrd(p, fraction_image(s), VoxelType::kFloat32); });
    outputs.commit(*exp_overwrite);
    std::cout << fmt::format("wrote {} and {}\n", lp, fp);
  });
}

void setup(CLI::App& root) {
  auto* sample = root.add_subcommand("sample", "Make sample volumes: import labels or a CT, synthesise, export to NRRD");
  sample->require_subcommand(1);
  setup_import(sample);
  setup_export_ct(sample);
  setup_synth(sample);
  setup_resample(sample);
  setup_export_nrrd(sample);
}

BURRBENCH_VERB("sample", setup);
}  // namespace
