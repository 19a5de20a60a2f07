// The live view: reads the watcher's Server-Sent Events (hello, batch, event, alarm,
// status) and draws them with uPlot. Read-only: the page only ever GETs.
"use strict";
(function () {
  const token = new URLSearchParams(location.search).get("token") || "";
  const MAX_POINTS = 60000;  // the plots keep the newest points of a long session
  const idx = [], t = [], meas = [[], [], []], pred = [[], [], []], res = [[], [], []], bandHi = [], bandLo = [];
  const path = [];
  // Moments and spindle load, where the recording logs them (null where it does not).
  const tmeas = [[], [], []], tpred = [[], [], []], smeas = [], spred = [];
  let wrenchShown = false;
  let top = null, k = 5, sigma = 0, dirty = false, fresh = false, lastWall = 0;
  // What a test (or a curious operator, in the console) can read.
  const stats = window.watchStats = { batches: 0, points: 0, latency_ms: [], median_latency_ms: null,
                                      alarms: [], events: 0, ended: false, connected: false,
                                      predicted_in_contact: 0, measured_in_contact: 0 };
  const colors = ["#1f77b4", "#2ca02c", "#d62728"];
  const axes = ["x", "y", "z"];
  const width = Math.min(900, window.innerWidth - 420);
  function series(label, color, dash) { return { label, stroke: color, width: 1.5, dash: dash ? [6, 4] : undefined, points: { show: false } }; }
  const forcePlot = new uPlot({ width, height: 260, scales: { x: { time: false } },
    axes: [{ label: "t (s)" }, { label: "N" }],
    series: [{ label: "t (s)" }].concat(axes.map((a, i) => series("F" + a + " measured", colors[i], false)),
                                        axes.map((a, i) => series("F" + a + " predicted", colors[i], true))) },
    [t, ...meas, ...pred], document.getElementById("force"));
  const resPlot = new uPlot({ width, height: 220, scales: { x: { time: false } },
    axes: [{ label: "t (s)" }, { label: "N" }],
    series: [{ label: "t (s)" }].concat(axes.map((a, i) => series("r" + a, colors[i], false)),
                                        [series("+kσ", "#888", true), series("−kσ", "#888", true)]) },
    [t, ...res, bandHi, bandLo], document.getElementById("residual"));

  const momentPlot = new uPlot({ width: Math.min(700, width), height: 220, scales: { x: { time: false } },
    axes: [{ label: "t (s)" }, { label: "N·mm" }],
    series: [{ label: "t (s)" }].concat(axes.map((a, i) => series("M" + a + " measured", colors[i], false)),
                                        axes.map((a, i) => series("M" + a + " predicted", colors[i], true))) },
    [t, ...tmeas, ...tpred], document.getElementById("moment"));
  const spindlePlot = new uPlot({ width: 480, height: 220, scales: { x: { time: false } },
    axes: [{ label: "t (s)" }, { label: "N·mm" }],
    series: [{ label: "t (s)" }, series("measured", "#9467bd", false), series("predicted", "#9467bd", true)] },
    [t, smeas, spred], document.getElementById("spindle"));
  const statusEl = document.getElementById("status"), alarmEl = document.getElementById("alarm");
  const eventsEl = document.getElementById("events");
  function line(text, cls) {
    const d = document.createElement("div");
    d.textContent = text;
    if (cls) d.className = cls;
    eventsEl.appendChild(d);
    eventsEl.scrollTop = eventsEl.scrollHeight;
  }
  function drawTop() {
    const c = document.getElementById("top"), g = c.getContext("2d");
    g.fillStyle = "#fff"; g.fillRect(0, 0, c.width, c.height);
    if (!top) return;
    const s = Math.min(c.width / top.nx, c.height / top.ny);
    const img = g.createImageData(top.nx, top.ny);
    for (let y = 0; y < top.ny; ++y)
      for (let x = 0; x < top.nx; ++x) {
        const v = 255 - Math.round(0.4 * top.values[x + top.nx * y]), o = 4 * (x + top.nx * (top.ny - 1 - y));
        img.data[o] = img.data[o + 1] = img.data[o + 2] = v; img.data[o + 3] = 255;
      }
    const off = document.createElement("canvas"); off.width = top.nx; off.height = top.ny;
    off.getContext("2d").putImageData(img, 0, 0);
    g.imageSmoothingEnabled = false;
    g.drawImage(off, 0, 0, top.nx * s, top.ny * s);
    // Voxel centres: cell i covers origin + (i − ½)·cell … (i + ½)·cell.
    const px = (xmm) => ((xmm - top.origin_mm[0]) / top.cell_mm + 0.5) * s;
    const py = (ymm) => (top.ny - ((ymm - top.origin_mm[1]) / top.cell_mm + 0.5)) * s;
    g.strokeStyle = "#d62728"; g.lineWidth = 1.5; g.beginPath();
    path.forEach((p, i) => { if (i) g.lineTo(px(p[0]), py(p[1])); else g.moveTo(px(p[0]), py(p[1])); });
    g.stroke();
    if (path.length) {
      const p = path[path.length - 1];
      g.fillStyle = "#d62728"; g.beginPath(); g.arc(px(p[0]), py(p[1]), 4, 0, 2 * Math.PI); g.fill();
    }
  }
  function redraw() {
    if (!dirty) return;
    dirty = false;
    forcePlot.setData([t, ...meas, ...pred]);
    resPlot.setData([t, ...res, bandHi, bandLo]);
    if (wrenchShown) {
      momentPlot.setData([t, ...tmeas, ...tpred]);
      spindlePlot.setData([t, smeas, spred]);
    }
    drawTop();
    // From the newest sample's acquisition to its point drawn (same host clock); only
    // after a batch: a redraw for the end of the session has no new sample.
    const lat = Date.now() - lastWall;
    if (fresh) stats.latency_ms.push(lat);
    fresh = false;
    const sorted = stats.latency_ms.slice().sort((a, b) => a - b);
    stats.median_latency_ms = sorted[Math.floor(sorted.length / 2)];
    statusEl.textContent = `${stats.points} samples, t = ${t.length ? t[t.length - 1].toFixed(2) : 0} s, σ = ${sigma.toPrecision(3)} N, ` +
      `latency ${Math.round(stats.latency_ms[stats.latency_ms.length - 1] || 0)} ms (median ${Math.round(stats.median_latency_ms)} ms)` + (stats.behind > 0.5 ? `, ${stats.behind.toFixed(1)} s behind (display thinned)` : "") +
      (stats.ended ? " — session ended" : "");
  }
  function onBatch(m) {
    sigma = m.sigma_N || 0; stats.behind = m.behind_s;
    for (const p of m.points) {
      // A revised sample (the previous batch's last, by its index) replaces it.
      if (idx.length && p[0] <= idx[idx.length - 1]) {
        if (p[0] < idx[idx.length - 1]) continue;
        idx.pop(); t.pop(); bandHi.pop(); bandLo.pop(); path.pop(); smeas.pop(); spred.pop();
        for (let i = 0; i < 3; ++i) { tmeas[i].pop(); tpred[i].pop(); }
        for (let i = 0; i < 3; ++i) { meas[i].pop(); pred[i].pop(); res[i].pop(); }
      } else {
        stats.points++;
        if (Math.hypot(p[6], p[7], p[8]) > 0) stats.predicted_in_contact++;
        if (sigma > 0 && Math.hypot(p[3], p[4], p[5]) > k * sigma) stats.measured_in_contact++;
      }
      idx.push(p[0]); t.push(p[1]);
      for (let i = 0; i < 3; ++i) { meas[i].push(p[3 + i]); pred[i].push(p[6 + i]); res[i].push(p[3 + i] - p[6 + i]); }
      bandHi.push(sigma > 0 ? k * sigma : null); bandLo.push(sigma > 0 ? -k * sigma : null);
      path.push([p[10], p[11]]);
      for (let i = 0; i < 3; ++i) { tmeas[i].push(p[13 + i]); tpred[i].push(p[16 + i]); }
      smeas.push(p[19]); spred.push(p[20]);
      if (!wrenchShown && (p[13] !== null || p[19] !== null)) {
        wrenchShown = true;
        document.getElementById("wrench").style.display = "";
      }
      lastWall = p[2];
    }
    if (t.length > MAX_POINTS) {
      const n = t.length - MAX_POINTS;
      for (const a of [idx, t, bandHi, bandLo, path, smeas, spred, ...meas, ...pred, ...res, ...tmeas, ...tpred]) a.splice(0, n);
    }
    stats.batches++;
    dirty = true;
    fresh = m.points.length > 0;
    requestAnimationFrame(redraw);
  }
  const es = new EventSource("events?token=" + encodeURIComponent(token));
  es.onopen = () => { stats.connected = true; };
  es.onerror = () => { if (!stats.ended) statusEl.textContent = "connection lost; retrying…"; };
  es.onmessage = (ev) => {
    const m = JSON.parse(ev.data);
    if (m.type === "hello") {
      document.getElementById("rec").textContent = m.recording;
      top = m.top; k = m.alarms.residual_k; drawTop();
    } else if (m.type === "batch") onBatch(m);
    else if (m.type === "event") { stats.events++; line(`${m.stream}: ${m.kind}: ${m.detail}`); }
    else if (m.type === "alarm") {
      stats.alarms.push(m);
      alarmEl.textContent = `ALARM at t = ${m.t_s.toFixed(3)} s: ${m.message}`;
      alarmEl.className = "on";
      line(`ALARM t = ${m.t_s.toFixed(3)} s: ${m.message}`, "alarmline");
    } else if (m.type === "status" && m.ended) { stats.ended = true; es.close(); dirty = true; requestAnimationFrame(redraw); }
  };
})();
