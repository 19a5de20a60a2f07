// `burrbench study run|summarize`: many specimens on a workflow engine (docs/study.md).
// `run` hands the study to Snakemake (study/Snakefile: calibrate → validate per specimen
// as separate jobs, then summarize), locally with --cores or on Slurm with --profile;
// burrbench writes no scheduler of its own. `summarize` pools the specimens' fits into
// population constants (study/population.hpp) with a report.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "burrbench/data_schema/output_folder.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/study/population.hpp"
#include "burrbench/study/study_manifest.hpp"
#include "burrbench/study/study_report.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;
using namespace burrbench;
using nlohmann::json;

struct RunArgs {
  std::string study, out, profile;
  int cores = 2;
  bool dry_run = false;
};
struct SummarizeArgs {
  std::string study, results, out;
  bool overwrite = false;
};

fs::path self_exe() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path("burrbench") : exe;
}

// The workflow: $BURRBENCH_SNAKEFILE, the installed copy, or the source tree's.
fs::path snakefile() {
  if (const char* env = std::getenv("BURRBENCH_SNAKEFILE")) {
    if (!fs::is_regular_file(env))
      throw InputError("environment", "BURRBENCH_SNAKEFILE", "an existing Snakefile", env);
    return env;
  }
  const fs::path installed = self_exe().parent_path().parent_path() / "share/burrbench/study/Snakefile";
  if (fs::is_regular_file(installed)) return installed;
  return fs::path(BURRBENCH_SOURCE_DIR) / "study/Snakefile";
}

fs::path find_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string p = path ? path : "";
  for (std::size_t b = 0; b <= p.size();) {
    const std::size_t e = std::min(p.find(':', b), p.size());
    const fs::path c = fs::path(p.substr(b, e - b)) / name;
    if (b < e && ::access(c.c_str(), X_OK) == 0) return c;
    b = e + 1;
  }
  return {};
}

fs::path default_results(const study::StudyManifest& s) { return s.file.parent_path() / "results"; }

// Writes `text` to `file` only when it differs, so the file's time stamp moves only when
// its content does.
void write_if_changed(const fs::path& file, const std::string& text) {
  std::ifstream old(file, std::ios::binary);
  const std::string before((std::istreambuf_iterator<char>(old)), std::istreambuf_iterator<char>());
  if (before != text) data_schema::write_file_atomic(file, text);
}

// The SHA-256 of every file a job reads, one line each: a folder (a slice stack, a DICOM
// series, a SkyScan reconstruction) by each regular file in it, as the importers read it.
std::string hashes(const std::vector<fs::path>& inputs) {
  std::string text;
  for (const auto& i : inputs) {
    std::vector<fs::path> files{i};
    if (fs::is_directory(i)) {
      files.clear();
      for (const auto& e : fs::directory_iterator(i))
        if (e.is_regular_file()) files.push_back(e.path());
      std::sort(files.begin(), files.end());
    }
    for (const auto& f : files) text += sha256_file(f) + "  " + f.string() + "\n";
  }
  return text;
}

// The resolved study as Snakemake's config: absolute paths, the calibrate options and per
// specimen a fingerprint file — the SHA-256 of its manifest, sample and recordings —
// that its calibration depends on instead of the files themselves. The fingerprint is
// rewritten only when a hash changes, so jobs are content-addressed: touching or copying
// a recording unchanged redoes nothing, changing one byte redoes that specimen.
// A specimen with imports: each import (one sample or recording from raw files) gets a
// fingerprint of its own (its command and the SHA-256 of the raw files it reads), its
// output goes to specimens/ID/import/, and the specimen is calibrated from its manifest
// with the imported paths put in (.burrbench/experiments/ID.toml).
fs::path write_plan(const study::StudyManifest& s, const fs::path& out) {
  const fs::path dir = out / ".burrbench";
  fs::create_directories(dir / "inputs");
  json plan;
  plan["burrbench"] = self_exe().string();
  plan["study"] = s.file.string();
  plan["criteria"] = s.criteria ? json(s.criteria->string()) : json(nullptr);
  plan["calibrate_args"] = s.fit.calibrate_args();
  plan["specimens"] = json::object();
  for (const auto& sp : s.specimens) {
    std::string fingerprint = hashes(sp.inputs);
    fs::path experiment = sp.experiment;
    json imports = {{"sample", json::object()}, {"recording", json::object()}}, imported = json::array();
    if (!sp.imports.empty()) {
      const fs::path import_dir = out / "specimens" / sp.id / "import";
      const std::string text = study::resolved_experiment(sp, import_dir);
      experiment = dir / "experiments" / (sp.id + ".toml");
      fs::create_directories(experiment.parent_path());
      write_if_changed(experiment, text);
      fingerprint += sha256_bytes(text.data(), text.size()) + "  " + experiment.string() + "\n";
      fs::create_directories(dir / "inputs" / sp.id);
      for (const auto& imp : sp.imports) {
        std::string command = fmt::format("burrbench {} import", imp.verb());
        for (const auto& a : imp.args) command += " " + a;
        const fs::path fp = dir / "inputs" / sp.id / fmt::format("{}.{}.sha256", imp.verb(), imp.id);
        write_if_changed(fp, command + "\n" + hashes(imp.inputs));
        imports[imp.verb()][imp.id] = {{"args", imp.args}, {"fingerprint", fp.string()}};
        imported.push_back(fs::relative(study::imported_file(import_dir, imp), out).string());
      }
    }
    const fs::path fp = dir / "inputs" / (sp.id + ".sha256");
    write_if_changed(fp, fingerprint);
    plan["specimens"][sp.id] = {{"experiment", experiment.string()}, {"fingerprint", fp.string()},
                                {"imports", imports}, {"imported", imported}};
  }
  write_if_changed(dir / "plan.json", plan.dump(1) + "\n");
  return dir / "plan.json";
}

// Snakemake runs in a process group of its own (its local jobs with it), and a SIGINT or
// SIGTERM to burrbench is forwarded to that whole group; burrbench then waits for
// Snakemake to stop (it ends its jobs and removes their incomplete outputs) and only then
// dies of the signal. Before, the signal stopped burrbench alone and the jobs went on
// writing after it had exited (issue 59, N6).
// The group gets SIGINT whichever signal came: Snakemake's SIGTERM handler (7.21,
// Scheduler.exit_gracefully) takes the scheduler's non-reentrant lock, so a SIGTERM that
// lands while the main thread holds that lock deadlocks Snakemake (a `study run` that never
// ended after SIGTERM on a loaded host); its SIGINT path (KeyboardInterrupt: cancel the
// jobs, clean up) takes no lock.
std::atomic<pid_t> g_child_group{0};
std::atomic<int> g_forwarded{0};
void forward_signal(int sig) {
  g_forwarded = sig;
  if (const pid_t g = g_child_group.load(); g > 0) ::kill(-g, SIGINT);
}

// Waits for the child; once a signal was forwarded, sends SIGINT again to its group every
// kResendS seconds until it ends: a job Snakemake had started as the first one arrived
// would otherwise run to its end before Snakemake can exit.
int wait_child(pid_t pid) {
  constexpr int kPollMs = 100, kResendS = 10;
  int status = 0, polls_since_signal = 0;
  for (;;) {
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return status;
    if (r < 0 && errno != EINTR) throw std::runtime_error(std::string("waitpid: ") + std::strerror(errno));
    if (g_forwarded.load() && ++polls_since_signal % (kResendS * 1000 / kPollMs) == 0) ::kill(-pid, SIGINT);
    std::this_thread::sleep_for(std::chrono::milliseconds(kPollMs));
  }
}

int run_process(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::cout.flush();
  struct sigaction sa {}, old_int {}, old_term {};
  sa.sa_handler = forward_signal;
  sigemptyset(&sa.sa_mask);
  // Blocked until the child's group exists, so a signal in between is forwarded, not lost.
  sigset_t block, prev;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  ::sigprocmask(SIG_BLOCK, &block, &prev);
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::sigprocmask(SIG_SETMASK, &prev, nullptr);
    throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  }
  if (pid == 0) {
    ::setpgid(0, 0);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::sigprocmask(SIG_SETMASK, &prev, nullptr);
    ::execv(args[0], args.data());
    std::fprintf(stderr, "burrbench: cannot run %s: %s\n", args[0], std::strerror(errno));
    std::_Exit(127);
  }
  ::setpgid(pid, pid);  // as the child does: whichever runs first
  g_child_group = pid;
  ::sigprocmask(SIG_SETMASK, &prev, nullptr);
  const int status = wait_child(pid);
  g_child_group = 0;
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  if (const int sig = g_forwarded.load()) {
    std::cerr << fmt::format("burrbench: study: {} forwarded to Snakemake, which has stopped; running the same "
                             "command again resumes\n", sig == SIGINT ? "SIGINT" : "SIGTERM");
    ::signal(sig, SIG_DFL);
    ::raise(sig);
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

void run(const RunArgs& a) {
  if (a.cores < 1 || a.cores > 4096) throw InputError("command line", "--cores", "1..4096", std::to_string(a.cores));
  const auto s = study::read_study(a.study);
  const fs::path out = fs::absolute(a.out.empty() ? default_results(s) : fs::path(a.out));
  if (!a.profile.empty() && !fs::is_regular_file(fs::path(a.profile) / "config.yaml"))
    throw InputError("command line", "--profile", "a Snakemake profile folder with config.yaml", a.profile);
  const fs::path snakemake = find_on_path("snakemake");
  if (snakemake.empty())
    throw InputError("PATH", "snakemake", "the snakemake command (Debian package snakemake; scripts/install-deps installs it)",
                     "not found");
  fs::create_directories(out / "logs");  // job logs, and sbatch's --output (refused when absent)
  const fs::path plan = write_plan(s, out);
  std::vector<std::string> argv{snakemake.string(), "--snakefile", snakefile().string(), "--directory", out.string(),
                                "--configfile", plan.string(), "--cores", std::to_string(a.cores), "--keep-going",
                                "--rerun-incomplete"};
  if (!a.profile.empty()) argv.insert(argv.end(), {"--profile", fs::absolute(a.profile).string()});
  if (a.dry_run) argv.push_back("--dry-run");
  std::cout << fmt::format("study {}: {} specimens → {} (Snakemake, {} cores{})\n", s.name, s.specimens.size(),
                           out.string(), a.cores, a.profile.empty() ? "" : ", profile " + a.profile);
  const int rc = run_process(argv);
  if (rc != 0) {
    std::cerr << fmt::format("burrbench: study: Snakemake stopped with exit code {} (its log is above and in {}); "
                             "finished specimens are kept, running the same command again resumes\n",
                             rc, (out / ".snakemake/log").string());
    apps::set_exit_code(1);
    return;
  }
  if (!a.dry_run) std::cout << "study summary: " << (out / "summary/report.html").string() << "\n";
}

void summarize(const SummarizeArgs& a) {
  const auto s = study::read_study(a.study);
  const fs::path results = fs::absolute(a.results.empty() ? default_results(s) : fs::path(a.results)).lexically_normal();
  const fs::path out = fs::absolute(a.out.empty() ? results / "summary" : fs::path(a.out)).lexically_normal();
  std::vector<std::pair<std::string, data_schema::FitResult>> fits;
  std::vector<study::SpecimenRow> rows;
  std::vector<fs::path> inputs{s.file};
  for (const auto& sp : s.specimens) {
    const fs::path dir = results / "specimens" / sp.id, fit = dir / "cal" / "fit.json";
    if (!fs::is_regular_file(fit))
      throw InputError(fit.string(), "file", "the specimen's fit (run `burrbench study run` first)", "missing");
    fits.emplace_back(sp.id, data_schema::read_fit(fit));
    inputs.push_back(fit);
    study::SpecimenRow r;
    r.id = sp.id;
    r.experiment = sp.experiment.string();
    r.fit_link = fs::relative(fit, out).string();
    const fs::path metrics = dir / "gate" / "metrics.json";
    if (fs::is_regular_file(metrics)) {
      std::ifstream in(metrics);
      const json m = json::parse(in, nullptr, false);
      if (m.is_discarded() || !m.contains("pass") || !m["pass"].is_boolean())
        throw InputError(metrics.string(), "pass", "a boolean (burrbench validate's metrics.json)");
      r.gate = m["pass"].get<bool>() ? "PASS" : "FAIL";
      r.report_link = fs::relative(dir / "gate" / "report.html", out).string();
    }
    rows.push_back(std::move(r));
  }
  const auto pop = study::summarize(fits);
  data_schema::OutputFolder folder(out, "--out", a.overwrite);
  folder.refuse_inputs({"population.json", "params.toml", "report.html"}, inputs);
  data_schema::ParameterSet ps = study::population_params(pop, fits.front().second);
  ps.provenance = make_provenance(inputs);
  json pj = study::population_json(s, pop, rows);
  pj["provenance"] = data_schema::provenance_json(ps.provenance);
  folder.write([&](const fs::path& dir) {
    data_schema::write_params(dir / "params.toml", ps);
    data_schema::write_file_atomic(dir / "population.json", pj.dump(1) + "\n");
    data_schema::write_file_atomic(dir / "report.html", study::study_report_html(s, pop, rows));
  });
  folder.commit();
  std::cout << fmt::format("population of {} specimens (random effects on ln θ, 95 % HKSJ interval):\n", fits.size());
  for (const auto& p : pop)
    if (p.estimable())
      std::cout << fmt::format("  {:<12} {:<6} {:>10.4g} [{:.4g}, {:.4g}]{}  k={} tau_ln={:.3g} I2={:.0f}%{}\n",
                               p.class_name, p.parameter, p.mean, p.ci95_low, p.ci95_high,
                               data_schema::unit_suffix(p.unit), p.k, p.tau_ln,
                               100 * p.i2, p.excluded.empty() ? "" : fmt::format(", {} excluded", p.excluded.size()));
    else
      std::cout << fmt::format("  {:<12} {:<6} not pooled: {} usable specimen(s), {} excluded{}\n", p.class_name,
                               p.parameter, p.k, p.excluded.size(),
                               p.excluded.empty() ? "" : " (" + p.excluded.front().second + ")");
  std::cout << "wrote " << (folder.target() / "population.json").string() << ", params.toml and report.html\n";
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("study", "Studies across many specimens: run them on Snakemake, pool their fits");
  cmd->require_subcommand(1);
  auto r = std::make_shared<RunArgs>();
  auto* run_cmd = cmd->add_subcommand("run", "Calibrate and validate every specimen of a study (Snakemake), then summarize");
  run_cmd->add_option("STUDY", r->study, "study manifest (burrbench.study TOML)")->required();
  run_cmd->add_option("--out", r->out, "results folder (default: STUDY's folder/results); re-running resumes there");
  run_cmd->add_option("--cores", r->cores, "cores Snakemake may use locally (default 2)");
  run_cmd->add_option("--profile", r->profile, "a Snakemake profile folder, e.g. study/profiles/slurm to submit with sbatch");
  run_cmd->add_flag("--dry-run", r->dry_run, "list the jobs that would run (snakemake --dry-run)");
  run_cmd->callback([r] { run(*r); });
  auto m = std::make_shared<SummarizeArgs>();
  auto* sum_cmd = cmd->add_subcommand("summarize", "Pool the specimens' fits into population constants with a report");
  sum_cmd->add_option("STUDY", m->study, "study manifest (burrbench.study TOML)")->required();
  sum_cmd->add_option("--results", m->results, "the study's results folder (default: STUDY's folder/results)");
  sum_cmd->add_option("--out", m->out, "output folder (default: RESULTS/summary)");
  sum_cmd->add_flag("--overwrite", m->overwrite, "write into an existing --out folder, replacing its files");
  sum_cmd->callback([m] { summarize(*m); });
}

BURRBENCH_VERB("study", setup);

}  // namespace
