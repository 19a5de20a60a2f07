// burrbench report: draws the interactive plots from the JSON embedded in the page.
// All text from data files goes through textContent, never innerHTML.
(function () {
  "use strict";
  var data = JSON.parse(document.getElementById("burrbench-data").textContent);
  var AX = ["x", "y", "z"];
  var MEAS = ["#1f77b4", "#2ca02c", "#9467bd"];
  var PRED = ["#ff7f0e", "#d62728", "#8c564b"];

  function width(el) { return Math.max(320, el.clientWidth || 600); }

  function plot(el, title, xlabel, ylabel, series, cols, extra) {
    var opts = {
      title: title, width: width(el), height: 260,
      cursor: { drag: { x: true, y: true, uni: 40 } },  // drag to zoom, double-click resets
      scales: { x: { time: false } },
      axes: [{ label: xlabel }, { label: ylabel }],
      series: [{ label: xlabel }].concat(series)
    };
    if (extra) extra(opts);
    var u = new uPlot(opts, cols, el);
    el.setAttribute("data-rendered", "1");
    return u;
  }

  function forcePlots(rec, i) {
    var el = document.getElementById("plot-force-" + i);
    if (!el) return;
    var s = [], cols = [rec.t];
    for (var a = 0; a < 3; a++) {
      s.push({ label: "measured " + AX[a], stroke: MEAS[a], width: 1 });
      cols.push(rec.m[a]);
    }
    for (a = 0; a < 3; a++) {
      s.push({ label: "predicted " + AX[a], stroke: PRED[a], width: 1, dash: [6, 3] });
      cols.push(rec.p[a]);
    }
    var bands = [];
    if (rec.band) {
      // The 95 % band of each predicted axis: two thin series and the fill between them.
      for (a = 0; a < 3; a++) {
        var hi = [], lo = [];
        for (var k = 0; k < rec.t.length; k++) {
          hi.push(rec.p[a][k] + rec.band[a][k]);
          lo.push(rec.p[a][k] - rec.band[a][k]);
        }
        s.push({ label: "95 % band " + AX[a] + " +", stroke: PRED[a] + "66", width: 0.5 });
        s.push({ label: "95 % band " + AX[a] + " −", stroke: PRED[a] + "66", width: 0.5 });
        cols.push(hi, lo);
        bands.push({ series: [cols.length - 2, cols.length - 1], fill: PRED[a] + "33" });
      }
    }
    plot(el, "Force, sensor frame — " + rec.id, "t (s)", "F (N)", s, cols,
         bands.length ? function (o) { o.bands = bands; } : null);
  }

  function residualPlots(rec, i) {
    var el = document.getElementById("plot-resid-t-" + i);
    if (el) {
      var s = [], cols = [rec.t];
      for (var a = 0; a < 3; a++) {
        s.push({ label: "e " + AX[a], stroke: MEAS[a], width: 1 });
        var e = new Array(rec.t.length);
        for (var k = 0; k < rec.t.length; k++) e[k] = rec.m[a][k] - rec.p[a][k];
        cols.push(e);
      }
      plot(el, "Residual vs time — " + rec.id, "t (s)", "measured − predicted (N)", s, cols);
    }
    el = document.getElementById("plot-resid-p-" + i);
    if (el) {
      // Scatter on one x scale: the three axes' (prediction, residual) pairs merged
      // and sorted by prediction; a series is null where another axis owns the x.
      var pts = [];
      for (var a2 = 0; a2 < 3; a2++)
        for (var k2 = 0; k2 < rec.t.length; k2++)
          pts.push([rec.p[a2][k2], a2, rec.m[a2][k2] - rec.p[a2][k2]]);
      pts.sort(function (u, v) { return u[0] - v[0]; });
      var xs = [], ys = [[], [], []];
      pts.forEach(function (q) {
        xs.push(q[0]);
        for (var b = 0; b < 3; b++) ys[b].push(b === q[1] ? q[2] : null);
      });
      var ss = [];
      for (var b = 0; b < 3; b++)
        ss.push({ label: "e " + AX[b], stroke: MEAS[b], paths: function () { return null; },
                  points: { show: true, size: 3, space: 0, fill: MEAS[b] } });
      plot(el, "Residual vs prediction — " + rec.id, "predicted F (N)", "residual (N)", ss,
           [xs].concat(ys));
    }
  }

  // The sensor's moment and the spindle's load (report section 8), when logged.
  function wrenchPlots(rec, i) {
    var el = document.getElementById("plot-torque-" + i);
    if (el && rec.tm) {
      var s = [], cols = [rec.t];
      for (var a = 0; a < 3; a++) {
        s.push({ label: "measured M" + AX[a], stroke: MEAS[a], width: 1 });
        cols.push(rec.tm[a]);
      }
      for (a = 0; a < 3; a++) {
        s.push({ label: "predicted M" + AX[a], stroke: PRED[a], width: 1, dash: [6, 3] });
        cols.push(rec.tp[a]);
      }
      plot(el, "Moment, sensor frame — " + rec.id, "t (s)", "M (N·mm)", s, cols);
    }
    el = document.getElementById("plot-spindle-" + i);
    if (el && rec.sm)
      plot(el, "Spindle load — " + rec.id, "t (s)", "τ (N·mm)",
           [{ label: "measured", stroke: MEAS[0], width: 1 },
            { label: "predicted", stroke: PRED[0], width: 2 }], [rec.t, rec.sm, rec.sp]);
    el = document.getElementById("plot-energy-" + i);
    if (el && rec.em)
      plot(el, "Cumulative cutting energy — " + rec.id, "t (s)", "∫(τ − idle)|ω| dt (mJ)",
           [{ label: "measured", stroke: MEAS[0], width: 1.5 },
            { label: "predicted", stroke: PRED[0], width: 1.5, dash: [6, 3] }], [rec.t, rec.em, rec.ep]);
  }

  function histograms() {
    (data.histograms || []).forEach(function (h, i) {
      var el = document.getElementById("plot-hist-" + i);
      if (!el) return;
      var s = [];
      for (var a = 0; a < 3; a++)
        s.push({ label: "e " + AX[a], stroke: MEAS[a], fill: MEAS[a] + "55",
                 paths: uPlot.paths.bars({ size: [0.9, 60], align: 0 }) });
      plot(el, "Residual histogram — " + h.role + " data", "residual (N)", "count", s,
           [h.centres].concat(h.counts));
    });
  }

  // QQ plot and autocorrelation per role (report section 9).
  function diagnosticPlots() {
    (data.diagnostics || []).forEach(function (d, i) {
      var el = document.getElementById("plot-qq-" + i);
      if (el) {
        var lo = Math.min(d.qq.theory[0], d.qq.sample[0]);
        var hi = Math.max(d.qq.theory[d.qq.theory.length - 1], d.qq.sample[d.qq.sample.length - 1]);
        var diag = d.qq.theory.slice();
        plot(el, "Normal QQ — " + d.role + " data", "normal quantile", "standardised residual", [
          { label: "residuals", stroke: MEAS[0], paths: function () { return null; },
            points: { show: true, size: 3, space: 0, fill: MEAS[0] } },
          { label: "normal", stroke: "#777", dash: [6, 4] }], [d.qq.theory, d.qq.sample, diag],
          function (o) { o.scales.y = { range: [lo, hi] }; });
      }
      el = document.getElementById("plot-acf-" + i);
      if (el) {
        var band = 1.96 / Math.sqrt(Math.max(1, d.n));
        var s = [], cols = [d.acf.lag];
        for (var a = 0; a < 3; a++) {
          s.push({ label: "r " + AX[a], stroke: MEAS[a], width: 1.5, points: { show: true, size: 4 } });
          cols.push(d.acf.r[a]);
        }
        s.push({ label: "+1.96/√n", stroke: "#777", dash: [6, 4] });
        s.push({ label: "−1.96/√n", stroke: "#777", dash: [6, 4] });
        cols.push(d.acf.lag.map(function () { return band; }));
        cols.push(d.acf.lag.map(function () { return -band; }));
        plot(el, "Residual autocorrelation — " + d.role + " data", "lag (samples)", "r(k)", s, cols);
      }
    });
  }

  function overview() {
    var el = document.getElementById("plot-overview");
    var rec = data.recordings[data.overview];
    if (!el || !rec) return;
    var mag = function (v) {
      var out = new Array(rec.t.length);
      for (var k = 0; k < rec.t.length; k++)
        out[k] = Math.sqrt(v[0][k] * v[0][k] + v[1][k] * v[1][k] + v[2][k] * v[2][k]);
      return out;
    };
    plot(el, "|F| measured vs predicted — " + rec.id + " (" + rec.role + ")", "t (s)", "|F| (N)",
         [{ label: "measured", stroke: MEAS[0], width: 1.5 },
          { label: "predicted", stroke: PRED[0], width: 1.5, dash: [6, 3] }],
         [rec.t, mag(rec.m), mag(rec.p)]);
  }

  function searchPlots() {
    var el = document.getElementById("plot-waterfall");
    if (el && data.waterfall && data.waterfall.length) {
      var w = data.waterfall.slice().sort(function (a, b) { return a.cost - b.cost; });
      var rank = w.map(function (_, i) { return i + 1; });
      // One series per ending, so that a minimum of the cost stands apart from a start that
      // stopped short of one ("": a fit.json from before endings were stored).
      var kinds = [["converged", "converged (a minimum)", PRED[1]], ["stopped", "stopped before converging", MEAS[0]],
                   ["screened", "screened at its pre-fit", "#777"], ["", "cost", MEAS[0]]];
      var s = [], cols = [rank];
      kinds.forEach(function (k) {
        var ys = w.map(function (e) { return (e.ending || "") === k[0] ? e.cost : null; });
        if (!ys.some(function (y) { return y !== null; })) return;
        s.push({ label: k[1], stroke: k[2], width: 0, points: { show: true, size: 7 } });
        cols.push(ys);
      });
      plot(el, "Waterfall: final cost of every start", "start (sorted)", "cost", s, cols,
        function (o) {
          o.scales.y = { distr: 3 };
          o.axes[0].incrs = [1, 2, 5, 10, 20, 50, 100, 200, 500];  // starts are counted: whole ticks
        });
    }
    (data.profiles || []).forEach(function (p, i) {
      var e = document.getElementById("plot-profile-" + i);
      if (!e) return;
      var c = profileCurve(p);
      var thr = c.x.map(function () { return p.threshold; });
      plot(e, "Profile: " + p.name, p.name + " (" + p.unit + ")", "cost rise", [
        { label: "profile", stroke: PRED[0], width: 1.5, points: { show: false } },
        { label: "computed points", stroke: PRED[0], width: 0, points: { show: true, size: 7 } },
        { label: "95 % threshold", stroke: "#777", dash: [6, 4], points: { show: false } }], [c.x, c.curve, c.points, thr]);
    });
  }

  // The profile between its computed points as the walk models it (docs/calibration.md,
  // "Profiles and verdicts"): √Δ linear in ln θ, i.e. a quadratic rise, the model its
  // crossings are interpolated with. Straight lines would draw a V where the cost is a
  // parabola (a side often closes with one point). The computed points are marked.
  function profileCurve(p) {
    var pts = p.value.map(function (v, k) { return [v, p.delta[k]]; })
      .sort(function (a, b) { return a[0] - b[0]; });
    var x = [], curve = [], points = [], steps = 24;
    pts.forEach(function (q, k) {
      var prev = pts[k - 1];
      if (prev && prev[0] > 0 && q[0] > 0 && prev[1] !== null && q[1] !== null) {
        var sa = Math.sqrt(Math.max(0, prev[1])), sb = Math.sqrt(Math.max(0, q[1]));
        for (var j = 1; j < steps; j++) {
          var t = j / steps, s = (1 - t) * sa + t * sb;
          x.push(Math.exp((1 - t) * Math.log(prev[0]) + t * Math.log(q[0])));
          curve.push(s * s);
          points.push(null);
        }
      }
      x.push(q[0]);
      curve.push(q[1]);
      points.push(q[1]);
    });
    return { x: x, curve: curve, points: points };
  }

  overview();
  searchPlots();
  data.recordings.forEach(function (rec, i) { forcePlots(rec, i); wrenchPlots(rec, i); residualPlots(rec, i); });
  histograms();
  diagnosticPlots();
  document.body.setAttribute("data-plots-done", "1");
})();
