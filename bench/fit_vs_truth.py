"""Scores a calibration's fit.json against the truth.toml its data were made with, for
bench/calibration.sh. Prints one line of counts over the free physics constants.

  coverage FIT TRUTH: "held covariance_held total identifiable missed" — profile intervals
      (an open side holds the truth on that side) and covariance intervals of identifiable
      ones; missed: the constants whose profile interval missed, comma-separated, or "-";
  mismatch FIT TRUTH: "held limited wrong total open" — a constant limited by discretization
      error counts with its widened interval (open where the coarse refit ran into a bound
      and gave none: "open" counts those, whose interval holds anything); "wrong": outside,
      identifiable, not limited;
  tolerance FIT TRUTH: "within wrong off held total not_identifiable limited open misses" —
      issue 10's test of a held-out fit, the rule of tests/calibration/test_heldout.cpp: an
      identifiable constant must recover the truth within C1 2 %, μ 5 %, α 10 % and have a
      profile interval holding it ("within"; "wrong" otherwise, a confident miss; "off":
      those of them outside the tolerance, the rest missed only with the interval); "held":
      profile intervals holding the truth, which a 95 % interval does at 95 % of seeds, not
      at every one; "limited": constants limited by discretization error, "open" those of
      them with no widened interval (boundless); misses: the confident misses as
      class.name(error %, tolerance|interval|both), comma-separated, or "-".
"""
import json
import sys
import tomllib

KEY = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}


def free_constants(fit_path, truth_path):
    """(parameter, true value, profile interval low, high) of every free physics constant."""
    fit = json.load(open(fit_path))
    truth = tomllib.load(open(truth_path, "rb"))["classes"]
    for p in fit["parameters"]:
        if p["fixed"]:
            continue
        lo = p["profile_ci95_low"] if p["profile_ci95_low"] is not None else 0.0
        hi = p["profile_ci95_high"] if p["profile_ci95_high"] is not None else float("inf")
        yield p, truth[p["class_name"]][KEY[p["name"]]], lo, hi


def coverage(fit_path, truth_path):
    held = chheld = total = ident = 0
    missed = []
    for p, tv, lo, hi in free_constants(fit_path, truth_path):
        total += 1
        held += lo <= tv <= hi
        if not lo <= tv <= hi:
            missed.append(f"{p['class_name']}.{p['name']}")
        ident += bool(p["identifiable"])
        chheld += bool(p["identifiable"]) and p["ci95_low"] <= tv <= p["ci95_high"]
    return held, chheld, total, ident, ",".join(missed) or "-"


def widened(p):
    """(limited, open, low, high): a constant limited by discretization error and its
    widened interval, open (0 or ∞) on a side the coarse refit gave none for."""
    d = p.get("discretization") or {}
    lo, hi = d.get("ci95_low"), d.get("ci95_high")
    return (bool(d.get("limited")), lo is None or hi is None,
            0.0 if lo is None else lo, float("inf") if hi is None else hi)


def mismatch(fit_path, truth_path):
    held = limited = wrong = total = boundless = 0
    for p, tv, lo, hi in free_constants(fit_path, truth_path):
        total += 1
        lim, wide_open, wlo, whi = widened(p)
        if lim:
            limited += 1
            boundless += wide_open
            lo, hi = wlo, whi
        inside = lo <= tv <= hi
        held += inside
        wrong += (not inside) and bool(p["identifiable"]) and not lim
    return held, limited, wrong, total, boundless


TOLERANCE = {"alpha": 0.10, "c1": 0.02, "mu": 0.05}


def tolerance(fit_path, truth_path):
    within = wrong = off = held = total = unident = limited = boundless = 0
    misses = []
    for p, tv, lo, hi in free_constants(fit_path, truth_path):
        total += 1
        inside = lo <= tv <= hi
        held += inside
        lim, wide_open, _, _ = widened(p)
        limited += lim
        boundless += lim and wide_open
        if not p["identifiable"]:
            unident += 1
            continue
        close = abs(p["estimate"] / tv - 1) <= TOLERANCE[p["name"]]
        if close and inside:
            within += 1
        else:
            wrong += 1
            off += not close
            why = "interval" if close else "tolerance" if inside else "both"
            misses.append(f"{p['class_name']}.{p['name']}({100 * (p['estimate'] / tv - 1):+.2f}%,{why})")
    return within, wrong, off, held, total, unident, limited, boundless, ",".join(misses) or "-"


if __name__ == "__main__":
    scores = {"coverage": coverage, "mismatch": mismatch, "tolerance": tolerance}
    if len(sys.argv) != 4 or sys.argv[1] not in scores:
        sys.exit("usage: fit_vs_truth.py coverage|mismatch|tolerance FIT.json TRUTH.toml")
    score = scores[sys.argv[1]]
    print(*score(sys.argv[2], sys.argv[3]))
