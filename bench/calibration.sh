#!/usr/bin/env bash
# Calibration figures (issue 10) on the synthetic reference experiment (R/l = 10, two
# classes, plunge + sweep + polish, bias and lag free; ≈ 15 s at 1 kHz at time scale 3):
#  1. one single-start fit (--starts 1 --no-profiles --no-discretization-check --no-depth-check) with --derivatives fd against the
#     forward sensitivities: wall time, replays and plain-replay equivalents, and the ceiling
#     of the ratio were every sensitivity replay free (docs/calibration.md "Why fd /
#     sensitivities stays far from 8×");
#  2. the default calibration (16 starts, profiles, no cross-validation): wall time;
#  3. the same experiment calibrated on the sample resampled to 0.05 mm voxels (R/l = 20):
#     wall time, the estimates against the truth (data made at 0.1 mm), whether each profile
#     interval holds it, and the residuals' lag-1 autocorrelation and interval widening;
#     and the single-start pair of 1. on it;
#  4. coverage of the profile (and covariance) 95 % intervals of the six constants over
#     REPS seeds (time scale COVERAGE_TIME_SCALE, default 0.5, default calibration), and
#     again over FULL_REPS seeds at the timing experiment's full length (time scale 3, the
#     experiment of 1.–3.; issue 56); every coverage line names its time scale;
#  5. the same coverages when the registration comes from four fiducials with 5 µm of
#     noise (a rig frame rotated 37°; seeds of fiducial and sensor noise, issue 17).
#  6. the discretization mismatch of issue 18 over MISMATCH_REPS seeds (default 10): data
#     made at 0.1 mm, calibrated on the sample at 0.05 mm; coverage of the intervals where
#     a constant limited by discretization error counts with its widened interval (open when it has none), the
#     limited constants whose widened interval is open (it holds anything), the
#     constants reported confidently wrong (outside, not limited), and the wall time at
#     0.05 mm with and without --coarse-to-fine (ratio of the sums).
#  7. the moments and the spindle's load (issue 13): one reference experiment (seed 1,
#     time scale CHANNELS_TIME_SCALE, default 1) whose recordings carry them, calibrated
#     with the force alone and with [fit] channels = force, torque, spindle: each
#     constant's profile interval width (hi/lo) and error before and after, and the
#     trabecular C1–α correlation; and the coverage of the 95 % intervals of such fits over
#     REPS seeds at COVERAGE_TIME_SCALE and FULL_REPS seeds at time scale 3 (as in 4.).
#  8. issue 10's own case, the held-out polish (tests/calibration/layered_fixture.hpp: one
#     recording, plunge + sweep calibrate, polish validates) over HELDOUT_REPS seeds
#     (default 10), with its [fit] section and with none: constants within the issue's
#     tolerances with a profile interval holding the truth (the rule of
#     tests/calibration/test_heldout.cpp), confident misses (identifiable, and outside them
#     or its interval missing the truth; goal 0), not identifiable, the profile intervals'
#     coverage, and the constants limited by discretization error with an open widened
#     interval.
#  9. the realistic session of issue 55 (tests/calibration/session_fixture.hpp: fiducials
#     with 5 µm noise in a rig frame turned 37°, a six-axis sensor 34 mm below, force,
#     moments and spindle load with their own lags, varying speed, both classes) over
#     SESSION_REPS seeds (default 10), calibrated with the defaults by the make-test case
#     RealisticSession.*: profile coverage of the six constants, the global optimum reached
#     (cost within 0.1 % of the fit with the true constants held), confident misses, wall
#     per seed (goal ≤ 3 min); and the plunge-only variant: seeds whose three trabecular
#     intervals hold the truth.
# The test manifests ask for 4 starts; every run here passes --starts 16, the default.
# Environment: COVERAGE_TIME_SCALE (default 0.5); FULL_REPS: seeds of the full-length
# (time scale 3) coverages of 4., 5. and 7. (default REPS, at most 10; 0: none, for a short
# run: a seed at time scale 3 costs about six at 0.5); SKIP_TIMING=1 runs only the coverages;
# COVERAGE=reference|registration|mismatch|channels|heldout|session runs one of the six
# (default all; none: the timings alone); SESSION_REPS; MISMATCH_REPS; HELDOUT_REPS; NO_BUILD (below).
# Usage: calibration.sh BUILD_DIR [REPS]
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
reps=${2:-20}
B="$build/apps/burrbench"
G="$build/bench/bench_calibration_reference"
PY=/usr/bin/python3
here=$(cd "$(dirname "$0")" && pwd)
# NO_BUILD=1: BUILD_DIR holds apps/burrbench, bench/bench_calibration_reference and (for COVERAGE=session) tests/test_calibration only
# (a copy, so that the build tree can change while a long run goes on).
[[ -n ${NO_BUILD:-} ]] || cmake --build "$build" --target burrbench bench_calibration_reference test_calibration -j 2 > /dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The timing experiment's time scale (≈ 17 s of data): the full length the coverages are
# also measured at; the short coverages run at COVERAGE_TIME_SCALE.
full_scale=3
short_scale=${COVERAGE_TIME_SCALE:-0.5}
full_reps=${FULL_REPS:-$(( reps < 10 ? reps : 10 ))}

# Runs `burrbench calibrate` and prints "wall_s cpu_s replays iterations equivalents
# sensitivity_replays" (the CPU time tells a busy machine from a slow fit; equivalents: the
# replays in plain-replay equivalents, a sensitivity replay weighed at its measured CPU,
# fit.json settings.derivatives.replay_work).
calib() {  # OUT MANIFEST ARGS...
  local out=$1 m=$2; shift 2
  local TIMEFORMAT='%R %U %S' times
  times=$( { time "$B" calibrate --experiment "$m" --out "$out" --no-cross-validation "$@" > "$out.log" 2>&1 ; } 2>&1 )
  $PY - "$out/fit.json" $times <<'PY'
import json, sys
f = json.load(open(sys.argv[1]))
w = f["settings"]["derivatives"]["replay_work"]
eq = w["replay_equivalents"]
print(f"{float(sys.argv[2]):.1f} {float(sys.argv[3]) + float(sys.argv[4]):.1f} {f['solver']['replays']} "
      f"{f['solver']['iterations']} {'-' if eq is None else f'{eq:.0f}'} {w['sensitivity']['replays']}")
PY
}

fd_wall=- fd_cpu=- fd_rep=- fd_it=- fd_eq=- se_wall=- se_cpu=- se_rep=- se_it=- se_eq=- se_sens=- def_wall=- def_cpu=- def_rep=-
fine_wall=- fine_cpu=- fine_rep=- fine_err=- def_stages=- ffd_wall=- ffd_rep=- fse_wall=- fse_rep=- fine_iters="- -"
if [[ -z ${SKIP_TIMING:-} ]]; then
  m=$("$G" "$work/ref" "$B" 1 "$full_scale" fine)
  mc="$work/ref/experiment.toml"
  read -r fd_wall fd_cpu fd_rep fd_it fd_eq _ <<<"$(calib "$work/ref/fd" "$mc" --starts 1 --no-profiles --no-discretization-check --no-depth-check --derivatives fd)"
  echo "  fd single start: $fd_wall s wall, $fd_cpu s CPU, $fd_rep replays" >&2
  read -r se_wall se_cpu se_rep se_it se_eq se_sens <<<"$(calib "$work/ref/se" "$mc" --starts 1 --no-profiles --no-discretization-check --no-depth-check)"
  echo "  sensitivities single start: $se_wall s wall, $se_cpu s CPU, $se_rep replays" >&2
  read -r def_wall def_cpu def_rep _ <<<"$(calib "$work/ref/def" "$mc" --starts 16)"
  echo "  default calibration: $def_wall s wall, $def_cpu s CPU, $def_rep replays" >&2
  read -r fine_wall fine_cpu fine_rep _ <<<"$(calib "$work/ref/fine" "$m" --starts 16)"
  echo "  0.05 mm: $fine_wall s wall, $fine_cpu s CPU, $fine_rep replays" >&2
  # The single-start pair again at R/l = 20, where a lab's micro-CT is.
  single=(--starts 1 --no-profiles --no-discretization-check --no-depth-check)
  read -r ffd_wall _ ffd_rep _ <<<"$(calib "$work/ref/ffd" "$m" "${single[@]}" --derivatives fd)"
  read -r fse_wall _ fse_rep _ <<<"$(calib "$work/ref/fse" "$m" "${single[@]}")"
  fine_iters=$($PY - "$work/ref/ffd/fit.json" "$work/ref/fse/fit.json" <<'PY'
import json, sys
print(" ".join(str(json.load(open(p))["multistart"][0]["iterations"]) for p in sys.argv[1:]))
PY
)
  echo "  0.05 mm single start: fd $ffd_wall s ($ffd_rep replays), sensitivities $fse_wall s ($fse_rep)" >&2
  fine_err=$($PY - "$work/ref/fine/fit.json" "$work/ref/truth.toml" <<'PY'
import json, sys, tomllib
f = json.load(open(sys.argv[1])); t = tomllib.load(open(sys.argv[2], "rb"))["classes"]
key = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}
def holds(p, tv):
    lo, hi = p.get("profile_ci95_low"), p.get("profile_ci95_high")
    return (lo is None or lo <= tv) and (hi is None or tv <= hi)
nm = f["settings"].get("noise_model", {})
print(" ".join(f"{p['class_name'][0]}.{p['name']}{100*(p['held']/t[p['class_name']][key[p['name']]]-1):+.1f}%"
               f"({'in' if holds(p, t[p['class_name']][key[p['name']]]) else 'OUT'})"
               for p in f["parameters"] if not p["fixed"]),
      f"rho {nm.get('residual_lag1', float('nan')):.2f} widening x{nm.get('interval_widening', 1):.2f}")
PY
)
  def_stages=$($PY - "$work/ref/def/fit.json" <<'PY'
import json, sys
f = json.load(open(sys.argv[1]))
print(", ".join(f"{s['stage']} {s['wall_s']:.0f} s ({s['replays']})" for s in f["solver"]["stages"] if s["wall_s"] >= 0.5))
PY
)
fi

# Coverage over seeds: prints "hits covariance_hits total identifiable depth_said"; each
# seed's line (stderr) names the time scale and the constants whose profile interval
# missed. depth_said counts the seeds whose depth check spoke (the data hold no depth
# error: false alarms).
coverage() {  # MODE ("" force alone, registration: fiducials, wrench: moments, spindle load) TIME_SCALE SEEDS
  local hits=0 chits=0 total=0 idf=0 dsaid=0 seed ms h ch t i miss d
  for seed in $(seq 1 "$3"); do
    ms=$("$G" "$work/cov$seed" "$B" "$seed" "$2" $1)
    if ! "$B" calibrate --experiment "$ms" --out "$work/cov$seed/out" --no-cross-validation --starts 16 > /dev/null 2>&1; then
      total=$((total+6)); rm -rf "$work/cov$seed"; continue  # a failed fit covers nothing
    fi
    read -r h ch t i miss <<<"$($PY "$here/fit_vs_truth.py" coverage "$work/cov$seed/out/fit.json" "$work/cov$seed/truth.toml")"
    d=$($PY -c "import json,sys; print(int(json.load(open(sys.argv[1]))['settings']['depth_check'].get('said', False)))" \
      "$work/cov$seed/out/fit.json")
    hits=$((hits+h)); chits=$((chits+ch)); total=$((total+t)); idf=$((idf+i)); dsaid=$((dsaid+d))
    echo "  coverage ${1:-reference} (time scale $2) seed $seed: $h/$t held ($i identifiable; missed: $miss; depth check said: $d)" >&2
    rm -rf "$work/cov$seed"
  done
  echo "$hits $chits $total $idf $dsaid"
}
# The mismatch: prints "hits limited wrong total wall_default wall_c2f open".
mismatch() {
  local hits=0 lim=0 wrong=0 total=0 wd=0 wc=0 open=0 seed ms h l w t a b o
  for seed in $(seq 1 "${MISMATCH_REPS:-10}"); do
    ms=$("$G" "$work/mm$seed" "$B" "$seed" "$short_scale" fine)
    read -r a _ <<<"$(calib "$work/mm$seed/def" "$ms" --starts 16)"
    read -r b _ <<<"$(calib "$work/mm$seed/c2f" "$ms" --starts 16 --coarse-to-fine)"
    read -r h l w t o <<<"$($PY "$here/fit_vs_truth.py" mismatch "$work/mm$seed/def/fit.json" "$work/mm$seed/truth.toml")"
    hits=$((hits+h)); lim=$((lim+l)); wrong=$((wrong+w)); total=$((total+t)); open=$((open+o))
    wd=$($PY -c "print(round($wd + $a, 1))"); wc=$($PY -c "print(round($wc + $b, 1))")
    echo "  mismatch (time scale $short_scale) seed $seed: $h/$t held ($l limited by discretization, $o of them with an open widened interval; $w confidently wrong); $a s, coarse-to-fine $b s" >&2
    rm -rf "$work/mm$seed"
  done
  echo "$hits $lim $wrong $total $wd $wc $open"
}

# The held-out case: prints "within wrong off held total not_identifiable limited open" over
# both variants; "within" as tests/calibration/test_heldout.cpp: within tolerance and the
# profile interval holding the truth; "wrong" the other identifiable ones, "off" those of
# them outside the tolerance.
heldout() {
  local within=0 wrong=0 off=0 held=0 total=0 unid=0 lim=0 open=0 seed ms v a b f c d e l o miss
  for seed in $(seq 1 "${HELDOUT_REPS:-10}"); do
    ms=$("$G" "$work/ho$seed" "$B" "$seed" 1 layered)
    sed '/^\[fit\]/,$d' "$ms" > "$work/ho$seed/defaults.toml"  # the [fit] section is last
    for v in "$ms" "$work/ho$seed/defaults.toml"; do
      if ! "$B" calibrate --experiment "$v" --out "$work/ho$seed/out" --no-cross-validation > /dev/null 2>&1; then
        # A failed fit recovers nothing: six misses, counted as outside the tolerance.
        total=$((total+6)); wrong=$((wrong+6)); off=$((off+6)); rm -rf "$work/ho$seed/out"
        echo "  held-out seed $seed $(basename "$v"): calibrate FAILED, 6 confidently wrong" >&2; continue
      fi
      read -r a b f c d e l o miss <<<"$($PY "$here/fit_vs_truth.py" tolerance "$work/ho$seed/out/fit.json" "$work/ho$seed/truth.toml")"
      within=$((within+a)); wrong=$((wrong+b)); off=$((off+f)); held=$((held+c)); total=$((total+d)); unid=$((unid+e))
      lim=$((lim+l)); open=$((open+o))
      echo "  held-out seed $seed $(basename "$v"): $a/$d within tolerance with the interval holding the truth, $b confidently wrong ($miss), $e not identifiable, $c/$d intervals hold the truth, $l limited by discretization ($o with an open widened interval)" >&2
      rm -rf "$work/ho$seed/out"
    done
    rm -rf "$work/ho$seed"
  done
  echo "$within $wrong $off $held $total $unid $lim $open"
}

# The channels: prints one line per constant and the correlation line.
channels() {
  local mw
  mw=$("$G" "$work/ch" "$B" 1 "${CHANNELS_TIME_SCALE:-1}" wrench)
  calib "$work/ch/force" "$work/ch/experiment.toml" --starts 16 > /dev/null
  calib "$work/ch/all" "$mw" --starts 16 > /dev/null
  $PY - "$work/ch/force/fit.json" "$work/ch/all/fit.json" "$work/ch/truth.toml" <<'PY'
import json, sys, tomllib
a, b = (json.load(open(p)) for p in sys.argv[1:3]); t = tomllib.load(open(sys.argv[3], "rb"))["classes"]
key = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}
def width(p):
    lo, hi = p.get("profile_ci95_low"), p.get("profile_ci95_high")
    return f"x{hi / lo:.4f}" if lo and hi else "open"
def err(p, tv):
    return f"{100 * (p['held'] / tv - 1):+.2f}%"
for pa, pb in zip(a["parameters"], b["parameters"]):
    if pa["fixed"]:
        continue
    tv = t[pa["class_name"]][key[pa["name"]]]
    print(f"  {pa['class_name']}.{pa['name']}: width {width(pa)} -> {width(pb)}, error {err(pa, tv)} -> {err(pb, tv)}, "
          f"verdict {pa['verdict']} -> {pb['verdict']}")
def corr(f):
    c = f.get("correlation", {}); n = c.get("names", []); m = c.get("matrix", [])
    try:
        i, j = n.index("trabecular.c1"), n.index("trabecular.alpha")
    except ValueError:
        return "n/a"
    return f"{m[i * len(n) + j]:.5f}"
print(f"  trabecular C1-alpha correlation: {corr(a)} -> {corr(b)}")
PY
}

# The realistic session (9.): runs the make-test case per seed and variant and prints
# "held total global seeds misses wall_max wall_sum trab_seeds plunge_seeds".
session() {
  local T="$build/tests/test_calibration" n=${SESSION_REPS:-10} seed log
  local held=0 total=0 global=0 misses=0 wmax=0 wsum=0 trab=0 h t g m w
  for seed in $(seq 1 "$n"); do
    log="$work/session$seed.log"
    BURRBENCH="$B" BURRBENCH_SOURCE_DIR="$here/.." BURRBENCH_BUILD_DIR="$build" BURRBENCH_SESSION_SEED=$seed "$T" --gtest_filter='RealisticSession.DefaultCalibration*' > "$log" 2>&1 || true
    read -r h t g m w <<<"$($PY - "$log" <<'PY'
import re, sys
s = open(sys.argv[1]).read()
rows = re.findall(r"^  (compact|trabecular) +(\w+) +\S+ +held .*? (holds|MISSES)", s, re.M)
c = re.search(r"optimum's cost (\S+), at the truth with the nuisances fitted (\S+)", s)
w = re.search(r"default calibration: ([0-9.]+) s wall", s)
g = int(bool(c) and float(c.group(1)) < 1.001 * float(c.group(2)))
print(sum(r[2] == "holds" for r in rows), len(rows), g, s.count("CONFIDENT MISS"), w.group(1) if w else "nan")
PY
)"
    echo "  session seed $seed: $h/$t intervals hold, global optimum $g, confident misses $m, $w s wall" >&2
    held=$((held + h)); total=$((total + t)); global=$((global + g)); misses=$((misses + m))
    wmax=$($PY -c "print(max($wmax, $w))"); wsum=$($PY -c "print($wsum + $w)")
    log="$work/session_plunge$seed.log"
    BURRBENCH="$B" BURRBENCH_SOURCE_DIR="$here/.." BURRBENCH_BUILD_DIR="$build" BURRBENCH_SESSION_SEED=$seed BURRBENCH_SESSION_PLUNGE_ONLY=1 "$T" \
      --gtest_filter='RealisticSession.DefaultCalibration*' > "$log" 2>&1 || true
    t=$(grep -cE "^  trabecular +\w+ .* holds" "$log" || true)
    echo "  session seed $seed, plunges only: $t/3 trabecular intervals hold" >&2
    (( t == 3 )) && trab=$((trab + 1))
  done
  echo "$held $total $global $n $misses $wmax $wsum $trab"
}

mhits=0 mlim=0 mwrong=0 mtotal=0 mwd=0 mwc=0 mopen=0 chan=- hwithin=0 hwrong=0 hoff=0 hheld=0 htotal=0 hunid=0 hlim=0 hopen=0
# The coverages of 4., 5. and 7., each at the short and the full time scale: cov[KIND_short]
# and cov[KIND_full] hold "hits covariance_hits total identifiable depth_said" ("0 0 0 0 -" when not run).
declare -A cov
for kind in reference registration wrench; do for sc in short full; do cov[${kind}_$sc]="0 0 0 0 -"; done; done
run_part() { [[ ${COVERAGE:-all} == all || ${COVERAGE:-all} == "$1" ]]; }
coverages() {  # KIND MODE: both time scales
  cov[$1_short]=$(coverage "$2" "$short_scale" "$reps")
  (( full_reps == 0 )) || cov[$1_full]=$(coverage "$2" "$full_scale" "$full_reps")
}
run_part reference && coverages reference ""
run_part registration && coverages registration registration
run_part mismatch && read -r mhits mlim mwrong mtotal mwd mwc mopen <<<"$(mismatch)"
run_part channels && chan=$(channels) && coverages wrench wrench
run_part heldout && read -r hwithin hwrong hoff hheld htotal hunid hlim hopen <<<"$(heldout)"
sheld=0 stotal=0 sglobal=0 sseeds=0 smiss=0 swmax=- swsum=0 strab=0
run_part session && read -r sheld stotal sglobal sseeds smiss swmax swsum strab <<<"$(session)"

# "p % (hits/total)", or "-" for a coverage that was not run.
cover() { if (( $2 == 0 )); then echo -; else $PY -c "print(f'{100*$1/$2:.1f} % ($1/$2)')"; fi; }
ok() { $PY -c "print('ok' if $1 else 'MISSED')" 2>/dev/null || echo -; }
# A coverage that was not run (COVERAGE=...) says "-", not a vacuous ok.
covered() { if (( $2 == 0 )); then echo -; else ok "$1 >= 0.9*$2"; fi; }
ratio=$($PY -c "print(f'{$fd_wall/$se_wall:.2f}')" 2>/dev/null || echo -)
printf '%-70s %-22s %-10s %s\n' figure value goal ok?
printf '%-70s %-22s %-10s %s\n' "single start, --derivatives fd: wall / replays / iterations" "${fd_wall} s (${fd_cpu} CPU) / $fd_rep / $fd_it" - -
printf '%-70s %-22s %-10s %s\n' "single start, sensitivities: wall / replays / iterations" "${se_wall} s (${se_cpu} CPU) / $se_rep / $se_it" - -
printf '%-70s %-22s %-10s %s\n' "  wall time fd / sensitivities" "${ratio}x" ">= 8x" "$(ok "$ratio >= 8")"
printf '%-70s %-22s %-10s %s\n' "  plain-replay equivalents fd / sensitivities" "$fd_eq / $se_eq ($($PY -c "print(f'{$fd_eq/$se_eq:.2f}x')" 2>/dev/null || echo -))" - -
# The most the sensitivities could give: every one of their replays free, the plain ones
# (pre-fit, trial points, checks) left, and nothing but replays taking time.
printf '%-70s %-22s %-10s %s\n' "  ceiling with free Jacobians: fd / the plain replays left" "$fd_eq / $($PY -c "print($se_rep - $se_sens)" 2>/dev/null || echo -) ($($PY -c "print(f'{$fd_eq/($se_rep - $se_sens):.2f}x')" 2>/dev/null || echo -))" - -
printf '%-70s %-22s %-10s %s\n' "default calibration (16 starts, profiles), R/l = 10: wall" "${def_wall} s (${def_cpu} CPU, $def_rep replays)" "<= 60 s" "$(ok "$def_wall <= 60")"
printf '%-70s %s\n' "  where the time went (stage wall, replays)" "$def_stages"
printf '%-70s %-22s %-10s %s\n' "same on the sample resampled to 0.05 mm (R/l = 20): wall" "${fine_wall} s (${fine_cpu} CPU, $fine_rep replays)" "report" -
printf '%-70s %s\n' "  0.05 mm: held values against the truth (profile interval)" "$fine_err"
read -r ffd_its fse_its <<<"$fine_iters"
printf '%-70s %-22s %-10s %s\n' "  0.05 mm single start: fd / sensitivities wall (replays)" "$ffd_wall s ($ffd_rep) / $fse_wall s ($fse_rep)" report -
printf '%-70s %-22s %-10s %s\n' "    ratio; a start's iterations (pre-fit + local) fd / sens." "$($PY -c "print(f'{$ffd_wall/$fse_wall:.2f}x')" 2>/dev/null || echo -); $ffd_its / $fse_its" report -
# The rows of one coverage at one time scale: KIND short|full TITLE.
coverage_rows() {
  local sc=$short_scale n=$reps hits chits total idf dsaid
  [[ $2 == full ]] && sc=$full_scale n=$full_reps
  read -r hits chits total idf dsaid <<<"${cov[$1_$2]}"
  printf '%-70s %-22s %-10s %s\n' "$3, time scale $sc, $n seeds" "$(cover $hits $total)" ">= 90 %" "$(covered $hits $total)"
  printf '%-70s %-22s %-10s %s\n' "  time scale $sc: covariance coverage (identifiable only count)" "$(cover $chits $total)" - -
  printf '%-70s %-22s %-10s %s\n' "  time scale $sc: constants reported identifiable" "$idf/$total" - -
  if [[ $1 == reference ]]; then
    printf '%-70s %-22s %-10s %s\n' "  time scale $sc: depth check said (no depth error in the data)" "$dsaid/$n seeds" "0" \
      "$( [[ $dsaid == - ]] && echo - || ok "$dsaid == 0")"
  fi
}
for sc in short full; do coverage_rows reference $sc "profile 95 % coverage, 6 constants"; done
for sc in short full; do coverage_rows registration $sc "fiducial registration (5 um): profile cov."; done
printf '%-70s %-22s %-10s %s\n' "data at 0.1 mm fitted at 0.05 mm, time scale $short_scale: coverage, ${MISMATCH_REPS:-10} seeds" "$(cover $mhits $mtotal)" ">= 90 %" "$(covered $mhits $mtotal)"
printf '%-70s %-22s %-10s %s\n' "  limited by discretization / confidently wrong" "$mlim / $mwrong of $mtotal" "- / 0" "$( (( mtotal == 0 )) && echo - || ok "$mwrong == 0")"
printf '%-70s %-22s %-10s %s\n' "  limited with an open widened interval (it holds anything)" "$mopen of $mlim" - -
printf '%-70s %-22s %-10s %s\n' "  wall at 0.05 mm: default / --coarse-to-fine (sum)" "$mwd s / $mwc s ($($PY -c "print(f'{$mwd/max($mwc,1e-9):.2f}')")x)" report -
for sc in short full; do coverage_rows wrench $sc "force, moments, spindle load: profile cov."; done
printf '%-70s %-22s %-10s %s\n' "held-out polish, [fit] / defaults, ${HELDOUT_REPS:-10} seeds: within (tol. + interval)" "$hwithin/$htotal" - -
printf '%-70s %-22s %-10s %s\n' "  confidently wrong (tolerance or interval) / not identifiable" "$hwrong / $hunid" "0 / -" "$( (( htotal == 0 )) && echo - || ok "$hwrong == 0")"
printf '%-70s %-22s %-10s %s\n' "  of the confidently wrong: outside tolerance / interval only" "$hoff / $((hwrong - hoff))" - -
printf '%-70s %-22s %-10s %s\n' "  profile intervals holding the truth" "$(cover $hheld $htotal)" ">= 90 %" "$(covered $hheld $htotal)"
printf '%-70s %-22s %-10s %s\n' "  limited by discretization / with an open widened interval" "$hlim / $hopen of $htotal" - -
printf '%-70s %-22s %-10s %s\n' "realistic session (issue 55): profile coverage, $sseeds seeds" "$(cover $sheld $stotal)" ">= 90 %" "$(covered $sheld $stotal)"
printf '%-70s %-22s %-10s %s\n' "  global optimum reached (cost within 0.1 % of truth held)" "$sglobal/$sseeds" ">= 9/10" "$( (( sseeds == 0 )) && echo - || ok "$sglobal >= 0.9*$sseeds")"
printf '%-70s %-22s %-10s %s\n' "  confident misses (identifiable, interval or tolerance off)" "$smiss of $stotal" - -
printf '%-70s %-22s %-10s %s\n' "  default calibration wall per seed: max / mean" "$swmax s / $($PY -c "print(f'{$swsum/max($sseeds,1):.1f}')") s" "<= 180 s" "$( (( sseeds == 0 )) && echo - || ok "$swmax <= 180")"
printf '%-70s %-22s %-10s %s\n' "  plunges only: seeds whose trabecular intervals all hold" "$strab/$sseeds" ">= 9/10" "$( (( sseeds == 0 )) && echo - || ok "$strab >= 0.9*$sseeds")"
printf '%s\n' "force alone -> force, moments and spindle load (profile interval width hi/lo, error against the truth):"
printf '%s\n' "$chan"
