// The report of `wmr-mission view`: a run (x-y plot linked to the time plots,
// verdicts, phases, transitions), a campaign (success, the table of runs,
// figures) or a falsification (its verdict, lowest runs, figures, evaluations). Hand-written on <canvas>: no library, nothing fetched.
// Every text from the data goes in as text (textContent, Text nodes,
// attribute values), never as markup.
"use strict";
(() => {
  const meta = JSON.parse(document.getElementById("meta").textContent);
  const root = document.getElementById("report");

  // --- helpers -------------------------------------------------------------

  function el(tag, props, ...children) {
    const node = document.createElement(tag);
    for (const [key, value] of Object.entries(props || {})) {
      if (key === "class") node.className = value;
      else if (key === "text") node.textContent = value;
      else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
      else node.setAttribute(key, value);
    }
    for (const child of children) if (child !== null && child !== undefined) node.append(child);
    return node;
  }

  const finite = (v) => typeof v === "number" && Number.isFinite(v);

  function fmt(v, digits = 4) {
    if (v === Infinity || v === -Infinity) return v > 0 ? "inf" : "-inf";  // a margin without a number
    if (!finite(v)) return "–";
    const a = Math.abs(v);
    if (a !== 0 && (a >= 1e6 || a < 1e-3)) return v.toExponential(digits - 1);
    return String(Number(v.toPrecision(digits)));
  }

  // a number of falsify.json, where a margin without one is the text "-inf" (or "inf")
  const number = (v) => (v === "-inf" ? -Infinity : v === "inf" ? Infinity : Number(v));

  const percent = (v) => (finite(v) ? (100 * v).toFixed(2) + " %" : "–");

  function runs(n) {
    return `${n} run${n === 1 ? "" : "s"}`;
  }

  function ticks(lo, hi, count) {
    const span = hi - lo;
    if (!(span > 0)) return { values: [lo], step: 1 };
    const raw = span / count;
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => span / s <= count) || 10 * mag;
    const values = [];
    for (let k = Math.ceil(lo / step); k * step <= hi + step * 1e-9; k++) values.push(k * step);
    return { values, step };
  }

  function tickLabel(v, step) {
    if (Math.abs(v) < step * 1e-6) return "0";
    const a = Math.abs(v);
    if (a >= 1e5 || a < 1e-4) return v.toExponential(1);
    const decimals = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
    return v.toFixed(Math.min(decimals, 10));
  }

  function makeCanvas(width, height, cls) {
    const c = el("canvas", { class: cls });
    const ratio = window.devicePixelRatio || 1;
    c.width = Math.round(width * ratio);
    c.height = Math.round(height * ratio);
    c.style.width = width + "px";
    c.style.height = height + "px";
    c.getContext("2d").setTransform(ratio, 0, 0, ratio, 0, 0);
    return c;
  }

  function layer(width, height) {
    const base = makeCanvas(width, height, "base");
    const overlay = makeCanvas(width, height, "overlay");
    const box = el("div", { class: "stack" }, base, overlay);
    box.style.width = width + "px";
    box.style.height = height + "px";
    return { box, base, overlay, width, height };
  }

  function clear(canvas) {
    const g = canvas.getContext("2d");
    g.save();
    g.setTransform(1, 0, 0, 1, 0, 0);
    g.clearRect(0, 0, canvas.width, canvas.height);
    g.restore();
    return g;
  }

  function table(headers, rows, numeric) {
    const head = el("tr", null, ...headers.map((h, i) => el("th", { class: numeric[i] ? "num" : "", text: h })));
    const body = el("tbody");
    for (const row of rows) body.append(row);
    return el("div", { class: "scroll" }, el("table", null, el("thead", null, head), body));
  }

  function swatch(color, kind) {
    const s = el("span", { class: "swatch " + (kind || "") });
    s.style.borderColor = color;
    return s;
  }

  function firstAtOrAfter(values, t) {
    let lo = 0, hi = values.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (values[mid] < t) lo = mid + 1; else hi = mid;
    }
    return lo;
  }

  function nearest(values, t) {
    const i = firstAtOrAfter(values, t);
    if (i <= 0) return 0;
    if (i >= values.length) return values.length - 1;
    return t - values[i - 1] <= values[i] - t ? i - 1 : i;
  }

  // --- a run ---------------------------------------------------------------

  const STYLES = {
    true: { color: "#1f4e9c", width: 1.5, dash: [] },
    // neutral, told apart by their dashes: a phase may take any colour
    estimate: { color: "#111111", width: 1.1, dash: [6, 3] },
    reference: { color: "#7b8691", width: 1.2, dash: [2, 3] },
    measurement: { color: "#8a8a8a", width: 0, dash: [], dots: true },
    input: { color: "#1f4e9c", width: 1.3, dash: [], steps: true },
    "error-x": { color: "#1f77b4", width: 1.2, dash: [] },
    "error-y": { color: "#2ca02c", width: 1.2, dash: [] },
    "error-theta": { color: "#d62728", width: 1.2, dash: [] },
    error: { color: "#6a3d9a", width: 1.3, dash: [] },
  };

  function runPage(meta, S) {
    const n = S.t.length;
    for (const key of ["x", "y", "x_est", "y_est", "x_ref", "y_ref", "theta", "theta_est"]) {
      if (!S["pose_" + key]) S["pose_" + key] = S[key];  // every sample shows: the same values
    }
    const phases = meta.phases;
    const phaseName = (i) => (phases[i] ? phases[i].name : "?");
    const view = { t0: n ? S.t[0] : 0, t1: n ? S.t[n - 1] : 1, cursor: null };
    const failed = meta.outcome !== "success";

    root.append(
      el("h1", { text: meta.mission }),
      el("p", { class: "sub" },
        el("span", { class: "badge " + (failed ? "failed" : "success"), text: meta.outcome }),
        meta.message),
      el("p", { class: "sub", text:
        `seed ${meta.seed} · ${meta.samples} samples · dt ${fmt(meta.dt)} s · ` +
        `${n ? fmt(S.t[n - 1] - S.t[0], 6) : 0} s · final position error ` +
        `${fmt(meta.final.position_error)} m, heading error ${fmt(meta.final.heading_error)} rad` }),
    );
    if (meta.margin_check !== null) {
      root.append(el("p", { class: "sub", text:
        `margin ${meta.margin === null ? "-inf" : fmt(meta.margin)}, set by ${meta.margin_check}` }));
    }
    if (meta.bucket_seconds !== null) {
      root.append(el("p", { class: "note", text:
        `The plots show ${meta.shown} of ${meta.samples} samples: per bucket of ` +
        `${fmt(meta.bucket_seconds)} s, each signal's smallest and largest value (a one-sample ` +
        `spike still shows). trajectory.csv has every sample.` }));
    }
    if (!n) {
      root.append(el("p", { text: "This run has no samples." }));
      return;
    }

    // x-y plot and its side panel
    const top = el("div", { class: "top" });
    root.append(top);
    const xy = xyPlot(meta, S, phases);
    top.append(el("div", { class: "xy" }, xy.layer.box));
    const readout = el("tbody");
    const legend = el("div", { class: "legend" });
    top.append(el("div", { class: "side" },
      el("div", { class: "note", text: "Hover a plot to follow a time on every plot; drag across a time plot to zoom all of them to that span, double-click to zoom out." }),
      el("table", { id: "readout" }, readout), legend));
    for (const [i, p] of phases.slice(0, 40).entries()) {
      legend.append(el("div", { class: "key" }, swatch(p.color), `${i + 1}. ${p.name} (${p.kind})`));
    }
    if (phases.length > 40) legend.append(el("div", { class: "key", text: `and ${phases.length - 40} more phases` }));
    legend.append(el("div", { class: "key" }, swatch(STYLES.estimate.color, "dashed"), "estimate"));
    legend.append(el("div", { class: "key" }, swatch(STYLES.reference.color, "dotted"), "reference"));
    for (const r of meta.regions) {
      const s = swatch(regionStyle(r).stroke, "box");
      legend.append(el("div", { class: "key" }, s,
        `region ${r.name} (${r.type}${r.sides.length ? ", stay " + r.sides.join("/") : ""})`));
    }
    const resetButton = el("button", { text: "Zoom out", onclick: () => setRange(S.t[0], S.t[n - 1]) });
    resetButton.hidden = true;
    legend.append(el("div", { class: "controls" }, resetButton));

    // time plots
    root.append(el("h2", { text: "Over time" }));
    const width = Math.min(1200, Math.max(700, root.clientWidth - 4));
    const plots = meta.plots.map((spec) => timePlot(spec, width));

    function setCursor(i) {
      view.cursor = i;
      for (const p of plots) p.drawOverlay();
      xy.drawOverlay(view);
      showReadout(i);
    }

    function setRange(a, b) {
      view.t0 = Math.max(S.t[0], Math.min(a, b));
      view.t1 = Math.min(S.t[n - 1], Math.max(a, b));
      if (!(view.t1 > view.t0)) { view.t0 = S.t[0]; view.t1 = S.t[n - 1]; }
      resetButton.hidden = view.t0 === S.t[0] && view.t1 === S.t[n - 1];
      for (const p of plots) { p.draw(); p.drawOverlay(); }
      xy.drawOverlay(view);
    }

    function showReadout(i) {
      const row = (label, ...values) => el("tr", null, el("td", { text: label }),
        ...values.map((v) => el("td", { class: "num", text: typeof v === "string" ? v : fmt(v, 6) })));
      readout.replaceChildren(
        row("t [s]", S.t[i]),
        row("phase", phaseName(S.phase[i])),
        el("tr", null, el("td"), el("th", { class: "num", text: "true" }), el("th", { class: "num", text: "estimate" })),
        row("x [m]", S.pose_x[i], S.pose_x_est[i]),
        row("y [m]", S.pose_y[i], S.pose_y_est[i]),
        row("θ [rad]", S.pose_theta[i], S.pose_theta_est[i]),
        row("v [m/s]", S.v[i]),
        row("ω [rad/s]", S.omega[i]),
        row("to reference [m]", S.reference_distance[i]),
        row("constraint", S.constraint[i]),
      );
    }

    function timePlot(spec, width) {
      const height = 130;
      const pad = { left: 60, right: 12, top: 10, bottom: 20 };
      const title = el("div", { class: "plot-title" }, el("strong", { text: spec.title }));
      for (const s of spec.series) {
        const st = STYLES[s.style];
        title.append(el("span", { class: "key" },
          swatch(st.color, st.dots ? "dotted" : st.dash.length ? "dashed" : ""), s.label));
      }
      const hidden = (spec.lines || []).filter((l) => !l.shown);
      if (hidden.length) title.append(el("span", { class: "note", text: `${hidden[0].label} (off scale)` }));
      const lay = layer(width, height);
      lay.base.dataset.plot = spec.id;
      root.append(el("div", { class: "time-plot" }, title, lay.box));
      const x0 = pad.left, x1 = width - pad.right, y0 = pad.top, y1 = height - pad.bottom;
      let yLo = 0, yHi = 1;
      const tx = (t) => x0 + ((t - view.t0) / (view.t1 - view.t0)) * (x1 - x0);
      const ty = (v) => y1 - ((v - yLo) / (yHi - yLo)) * (y1 - y0);
      const tAt = (px) => view.t0 + ((px - x0) / (x1 - x0)) * (view.t1 - view.t0);

      function range(a, b) {
        let lo = Infinity, hi = -Infinity;
        for (const s of spec.series) {
          const values = S[s.key];
          for (let i = a; i < b; i++) {
            const v = values[i];
            if (v !== null) { if (v < lo) lo = v; if (v > hi) hi = v; }
          }
        }
        for (const l of spec.lines || []) if (l.shown) { lo = Math.min(lo, l.y); hi = Math.max(hi, l.y); }
        if (spec.zero) { lo = Math.min(lo, 0); hi = Math.max(hi, 0); }
        if (!(hi >= lo)) { lo = -1; hi = 1; }
        if (hi === lo) { const d = Math.abs(hi) * 0.1 || 1; lo -= d; hi += d; }
        const margin = 0.06 * (hi - lo);
        return [lo - margin, hi + margin];
      }

      function draw() {
        const g = clear(lay.base);
        const a = Math.max(0, firstAtOrAfter(S.t, view.t0) - 1);
        const b = Math.min(n, firstAtOrAfter(S.t, view.t1) + 1);
        [yLo, yHi] = range(a, b);
        g.font = "11px system-ui, sans-serif";
        g.strokeStyle = "#e3e7eb";
        g.fillStyle = "#5b6670";
        g.lineWidth = 1;
        const yt = ticks(yLo, yHi, 4);
        g.textAlign = "right";
        g.textBaseline = "middle";
        for (const v of yt.values) {
          const y = Math.round(ty(v)) + 0.5;
          g.beginPath(); g.moveTo(x0, y); g.lineTo(x1, y); g.stroke();
          g.fillText(tickLabel(v, yt.step), x0 - 6, y);
        }
        const xt = ticks(view.t0, view.t1, 10);
        g.textAlign = "center";
        g.textBaseline = "top";
        for (const t of xt.values) {
          const x = Math.round(tx(t)) + 0.5;
          g.beginPath(); g.moveTo(x, y0); g.lineTo(x, y1); g.stroke();
          g.fillText(tickLabel(t, xt.step), x, y1 + 4);
        }
        g.strokeStyle = "#9aa5ae";
        g.strokeRect(x0 + 0.5, y0 + 0.5, x1 - x0, y1 - y0);
        g.save();
        g.beginPath(); g.rect(x0, y0 - 6, x1 - x0, y1 - y0 + 6); g.clip();
        // phases: a band along the top, a dotted line at each change
        for (let i = a; i < b; ) {
          let j = i;
          while (j + 1 < b && S.phase[j + 1] === S.phase[i]) j++;
          const end = j + 1 < n ? S.t[j + 1] : S.t[j];
          g.fillStyle = phases[S.phase[i]] ? phases[S.phase[i]].color : "#999";
          g.fillRect(tx(S.t[i]), y0 - 6, Math.max(1, tx(end) - tx(S.t[i])), 5);
          i = j + 1;
        }
        if (meta.transitions.length <= 1000) {
          g.strokeStyle = "#7b8691";
          g.setLineDash([2, 3]);
          for (const tr of meta.transitions) {
            if (tr.time === null || tr.time < view.t0 || tr.time > view.t1) continue;
            const x = Math.round(tx(tr.time)) + 0.5;
            g.beginPath(); g.moveTo(x, y0); g.lineTo(x, y1); g.stroke();
          }
        }
        for (const l of spec.lines || []) {
          if (!l.shown) continue;
          g.strokeStyle = l.y === 0 ? "#7b8691" : "#b3261e";
          g.setLineDash(l.y === 0 ? [1, 2] : [6, 4]);
          const y = Math.round(ty(l.y)) + 0.5;
          g.beginPath(); g.moveTo(x0, y); g.lineTo(x1, y); g.stroke();
        }
        // measurements under the lines, the true signal under its estimate and reference
        const order = [...spec.series].sort((p, q) => !!STYLES[q.style].dots - !!STYLES[p.style].dots);
        for (const s of order) drawSeries(g, S[s.key], STYLES[s.style], a, b);
        g.restore();
      }

      function drawSeries(g, values, st, a, b) {
        g.strokeStyle = st.color;
        g.fillStyle = st.color;
        g.lineWidth = st.width;
        g.setLineDash(st.dash);
        if (st.dots) {
          g.globalAlpha = 0.6;
          for (let i = a; i < b; i++) if (values[i] !== null) g.fillRect(tx(S.t[i]) - 1, ty(values[i]) - 1, 2, 2);
          g.globalAlpha = 1;
          return;
        }
        g.beginPath();
        let open = false;
        for (let i = a; i < b; i++) {
          const v = values[i];
          if (v === null) { open = false; continue; }
          const x = tx(S.t[i]), y = ty(v);
          if (!open) g.moveTo(x, y);
          else if (st.steps) g.lineTo(x, ty(values[i - 1]));
          g.lineTo(x, y);
          open = true;
        }
        g.stroke();
      }

      let dragFrom = null;
      function drawOverlay(brushTo) {
        const g = clear(lay.overlay);
        if (dragFrom !== null && brushTo !== undefined) {
          g.fillStyle = "rgba(31, 78, 156, 0.15)";
          g.fillRect(Math.min(dragFrom, brushTo), y0, Math.abs(brushTo - dragFrom), y1 - y0);
        }
        const i = view.cursor;
        if (i === null || S.t[i] < view.t0 || S.t[i] > view.t1) return;
        const x = Math.round(tx(S.t[i])) + 0.5;
        g.strokeStyle = "#111";
        g.lineWidth = 1;
        g.beginPath(); g.moveTo(x, y0); g.lineTo(x, y1); g.stroke();
        for (const s of spec.series) {
          const v = S[s.key][i];
          if (v === null) continue;
          g.fillStyle = STYLES[s.style].color;
          g.beginPath(); g.arc(x, ty(v), 3, 0, 2 * Math.PI); g.fill();
        }
      }

      const local = (event) => event.clientX - lay.overlay.getBoundingClientRect().left;
      lay.overlay.addEventListener("mousedown", (e) => { dragFrom = local(e); });
      lay.overlay.addEventListener("mousemove", (e) => {
        const px = Math.max(x0, Math.min(x1, local(e)));
        setCursor(nearest(S.t, tAt(px)));
        if (dragFrom !== null) drawOverlay(px);
      });
      lay.overlay.addEventListener("mouseup", (e) => {
        const from = dragFrom;
        dragFrom = null;
        const px = Math.max(x0, Math.min(x1, local(e)));
        if (from !== null && Math.abs(px - from) > 4) setRange(tAt(from), tAt(px));
        else drawOverlay();
      });
      lay.overlay.addEventListener("mouseleave", () => { dragFrom = null; drawOverlay(); });
      lay.overlay.addEventListener("dblclick", () => setRange(S.t[0], S.t[n - 1]));
      draw();
      return { draw, drawOverlay };
    }

    // xy plot: cursor hover picks the nearest shown sample
    xy.layer.overlay.addEventListener("mousemove", (e) => {
      const r = xy.layer.overlay.getBoundingClientRect();
      const i = xy.pick(e.clientX - r.left, e.clientY - r.top, view);
      if (i !== null) setCursor(i);
    });

    // tables
    const spanOf = (name) => meta.phase_table.find((p) => p.name === name);
    root.append(el("h2", { text: "Verdicts" }));
    if (!meta.expectations.length) root.append(el("p", { class: "note", text: "summary.json holds no expectation." }));
    else root.append(table(["metric", "phase", "threshold", "value", "margin", "verdict", "unit"],
      meta.expectations.map((e) => {
        const threshold = e.max !== null ? `max ${fmt(e.max)}` : e.min !== null ? `min ${fmt(e.min)}` : "–";
        const span = e.phase === null ? undefined : spanOf(e.phase);
        const tr = el("tr", { class: (e.met === false ? "bad " : "") + (span ? "clickable" : "") },
          el("td", { text: e.metric }), el("td", { text: e.phase === null ? "whole mission" : e.phase }),
          el("td", { class: "num", text: threshold }), el("td", { class: "num", text: fmt(e.value) }),
          el("td", { class: "num", text: e.margin === null ? (e.met === false ? "-inf" : "–") : fmt(e.margin) }),
          el("td", { text: e.met === null ? "–" : e.met ? "met" : "NOT MET" }),
          el("td", { text: e.unit }));
        if (span) tr.addEventListener("click", () => setRange(span.start, span.end));
        return tr;
      }), [false, false, true, true, true, false, false]));

    root.append(el("h2", { text: "Phases" }));
    const colorOf = new Map(phases.map((p) => [p.name, p.color]));
    const shownPhases = meta.phase_table.slice(0, 2000);
    if (meta.phase_table.length > shownPhases.length) {
      root.append(el("p", { class: "note", text: `The first ${shownPhases.length} of ${meta.phase_table.length} phases (summary.json has them all).` }));
    }
    // the catalog's metrics under the verdict's names (summary.json's, runs.csv's)
    const metricNames = meta.phase_metrics.map((m) => m.unit ? `${m.name} [${m.unit}]` : m.name);
    root.append(table(
      ["phase", "kind", "start [s]", "end [s]", "duration [s]", "target error [m]",
        "heading error [rad]", "max violation", ...metricNames],
      shownPhases.map((p) => {
        const color = colorOf.get(p.name) || "#999";
        const tr = el("tr", { class: "clickable" },
          el("td", { class: "name" }, swatch(color), " ", p.name), el("td", { text: p.kind }),
          ...[p.start, p.end, p.duration, p.target_position, p.target_heading, p.max_violation,
            ...p.metrics]
            .map((v) => el("td", { class: "num", text: fmt(v) })));
        tr.addEventListener("click", () => { if (finite(p.start) && finite(p.end)) setRange(p.start, p.end); });
        return tr;
      }), [false, false, true, true, true, true, true, true, ...metricNames.map(() => true)]));

    root.append(el("h2", { text: "Transitions" }));
    const shownTransitions = meta.transitions.slice(0, 2000);
    if (meta.transitions.length > shownTransitions.length) {
      root.append(el("p", { class: "note", text: `The first ${shownTransitions.length} of ${meta.transitions.length} transitions (transitions.json has them all).` }));
    }
    root.append(table(["#", "time [s]", "from", "to", "condition", "value", "lap", "reaction"],
      shownTransitions.map((tr, k) => {
        const row = el("tr", { class: "clickable" },
          el("td", { class: "num", text: String(k + 1) }), el("td", { class: "num", text: fmt(tr.time, 6) }),
          el("td", { class: "name", text: tr.from }),
          el("td", { class: "name", text: tr.to === null ? "(end)" : tr.to }),
          el("td", { text: tr.condition }), el("td", { class: "num", text: fmt(tr.value) }),
          el("td", { class: "num", text: tr.lap === null || tr.lap === undefined ? "" : String(tr.lap) }),
          // what fired, its why on hover
          el("td", { text: tr.reaction || "", title: tr.why || "" }));
        row.addEventListener("click", () => { if (tr.time !== null) setCursor(nearest(S.t, tr.time)); });
        return row;
      }), [true, true, false, false, false, true, true, false]));

    setCursor(failed ? n - 1 : 0);
  }

  function regionStyle(r) {
    if (r.sides.includes("outside")) return { fill: "rgba(179, 38, 30, 0.13)", stroke: "#b3261e" };
    if (r.sides.includes("inside")) return { fill: "rgba(59, 111, 182, 0.07)", stroke: "#3b6fb6" };
    return { fill: "rgba(0, 0, 0, 0.06)", stroke: "#8a8a8a" };
  }

  function xyPlot(meta, S, phases) {
    const n = S.t.length;
    const width = 620, height = 500, pad = 44;
    const lay = layer(width, height);
    lay.base.dataset.plot = "xy";
    let [vx0, vx1, vy0, vy1] = meta.view;
    // equal scales on both axes, centred
    const scale = Math.min((width - 2 * pad) / (vx1 - vx0), (height - 2 * pad) / (vy1 - vy0));
    const cx = (vx0 + vx1) / 2, cy = (vy0 + vy1) / 2;
    const px = (x) => width / 2 + (x - cx) * scale;
    const py = (y) => height / 2 - (y - cy) * scale;
    vx0 = cx - (width / 2 - pad) / scale; vx1 = cx + (width / 2 - pad) / scale;
    vy0 = cy - (height / 2 - pad) / scale; vy1 = cy + (height / 2 - pad) / scale;

    const g = lay.base.getContext("2d");
    g.font = "11px system-ui, sans-serif";
    g.lineWidth = 1;
    g.strokeStyle = "#e3e7eb";
    g.fillStyle = "#5b6670";
    const xt = ticks(vx0, vx1, 8), yt = ticks(vy0, vy1, 7);
    g.textAlign = "center"; g.textBaseline = "top";
    for (const v of xt.values) {
      const x = Math.round(px(v)) + 0.5;
      g.beginPath(); g.moveTo(x, pad); g.lineTo(x, height - pad); g.stroke();
      g.fillText(tickLabel(v, xt.step), x, height - pad + 4);
    }
    g.textAlign = "right"; g.textBaseline = "middle";
    for (const v of yt.values) {
      const y = Math.round(py(v)) + 0.5;
      g.beginPath(); g.moveTo(pad, y); g.lineTo(width - pad, y); g.stroke();
      g.fillText(tickLabel(v, yt.step), pad - 4, y);
    }
    g.textAlign = "center";
    g.fillText("x [m]", width / 2, height - 14);
    g.save(); g.translate(10, height / 2); g.rotate(-Math.PI / 2); g.fillText("y [m]", 0, 0); g.restore();
    g.strokeStyle = "#9aa5ae";
    g.strokeRect(pad + 0.5, pad + 0.5, width - 2 * pad, height - 2 * pad);
    g.save();
    g.beginPath(); g.rect(pad, pad, width - 2 * pad, height - 2 * pad); g.clip();

    for (const r of meta.regions) {
      const st = regionStyle(r);
      g.beginPath();
      r.x.forEach((x, k) => (k ? g.lineTo(px(x), py(r.y[k])) : g.moveTo(px(x), py(r.y[k]))));
      if (r.closed) { g.closePath(); g.fillStyle = st.fill; g.fill(); }
      g.strokeStyle = st.stroke; g.lineWidth = 1.2; g.setLineDash(r.closed ? [] : [6, 4]); g.stroke();
      if (r.closed && r.x.length) {
        const mx = r.x.reduce((a, b) => a + b, 0) / r.x.length, my = r.y.reduce((a, b) => a + b, 0) / r.y.length;
        g.fillStyle = st.stroke; g.textAlign = "center"; g.textBaseline = "middle";
        g.fillText(r.name, px(mx), py(my));
      }
    }
    g.setLineDash([]);

    function polyline(xs, ys, color, width, dash, from = 0, to = n) {
      g.strokeStyle = color; g.lineWidth = width; g.setLineDash(dash);
      g.beginPath();
      let open = false;
      for (let i = from; i < to; i++) {
        if (xs[i] === null || ys[i] === null) { open = false; continue; }
        if (open) g.lineTo(px(xs[i]), py(ys[i])); else g.moveTo(px(xs[i]), py(ys[i]));
        open = true;
      }
      g.stroke();
    }
    polyline(S.pose_x_ref, S.pose_y_ref, STYLES.reference.color, 1, STYLES.reference.dash);
    polyline(S.pose_x_est, S.pose_y_est, STYLES.estimate.color, 1, STYLES.estimate.dash);
    for (let i = 0; i < n; ) {  // the true path, coloured by phase
      let j = i;
      while (j + 1 < n && S.phase[j + 1] === S.phase[i]) j++;
      const color = phases[S.phase[i]] ? phases[S.phase[i]].color : "#999";
      polyline(S.pose_x, S.pose_y, color, 2, [], Math.max(0, i - 1), j + 1);
      i = j + 1;
    }
    g.setLineDash([]);
    for (const p of phases) {  // regulate targets
      if (!p.target || p.target[0] === null || p.target[1] === null) continue;
      const x = px(p.target[0]), y = py(p.target[1]);
      g.strokeStyle = "#111"; g.lineWidth = 1.5;
      g.beginPath(); g.moveTo(x - 6, y); g.lineTo(x + 6, y); g.moveTo(x, y - 6); g.lineTo(x, y + 6); g.stroke();
    }
    g.font = "10px system-ui, sans-serif"; g.textAlign = "center"; g.textBaseline = "middle";
    const changes = meta.transitions.filter((t) => t.to !== null && t.x !== null && t.y !== null);
    const every = Math.max(1, Math.ceil(changes.length / 40));
    changes.forEach((tr, k) => {  // each phase change, numbered by the phase it enters
      if (k % every) return;
      const index = phases.findIndex((p) => p.name === tr.to);
      const x = px(tr.x), y = py(tr.y);
      g.fillStyle = "#fff"; g.strokeStyle = "#111"; g.lineWidth = 1;
      g.beginPath(); g.arc(x, y, 7, 0, 2 * Math.PI); g.fill(); g.stroke();
      g.fillStyle = "#111"; g.fillText(String(index + 1), x, y);
    });
    const end = (i, shape) => {
      if (S.pose_x[i] === null || S.pose_y[i] === null) return;
      g.fillStyle = "#111";
      const x = px(S.pose_x[i]), y = py(S.pose_y[i]);
      g.beginPath();
      if (shape === "square") g.rect(x - 4, y - 4, 8, 8); else g.arc(x, y, 4, 0, 2 * Math.PI);
      g.fill();
    };
    end(0, "circle");
    end(n - 1, "square");
    g.restore();

    function drawOverlay(view) {
      const o = clear(lay.overlay);
      o.save();
      o.beginPath(); o.rect(pad, pad, width - 2 * pad, height - 2 * pad); o.clip();
      if (view.t0 > S.t[0] || view.t1 < S.t[n - 1]) {  // the zoomed span, drawn over the path
        const a = firstAtOrAfter(S.t, view.t0), b = firstAtOrAfter(S.t, view.t1 + 1e-12);
        o.strokeStyle = "rgba(255, 196, 0, 0.75)"; o.lineWidth = 6; o.lineJoin = "round";
        o.beginPath();
        let open = false;
        for (let i = a; i < b; i++) {
          if (S.pose_x[i] === null || S.pose_y[i] === null) { open = false; continue; }
          if (open) o.lineTo(px(S.pose_x[i]), py(S.pose_y[i])); else o.moveTo(px(S.pose_x[i]), py(S.pose_y[i]));
          open = true;
        }
        o.stroke();
      }
      const i = view.cursor;
      if (i !== null) {
        const pose = (x, y, theta, color, filled) => {
          if (x === null || y === null) return;
          const X = px(x), Y = py(y);
          o.strokeStyle = color; o.fillStyle = color; o.lineWidth = 2;
          o.beginPath(); o.arc(X, Y, 5, 0, 2 * Math.PI);
          if (filled) o.fill(); else o.stroke();
          if (theta !== null) {
            o.beginPath(); o.moveTo(X, Y); o.lineTo(X + 16 * Math.cos(theta), Y - 16 * Math.sin(theta)); o.stroke();
          }
        };
        if (S.pose_x_ref[i] !== null && S.pose_y_ref[i] !== null) {
          const X = px(S.pose_x_ref[i]), Y = py(S.pose_y_ref[i]);
          o.strokeStyle = "#111"; o.lineWidth = 2;
          o.beginPath(); o.moveTo(X - 5, Y - 5); o.lineTo(X + 5, Y + 5); o.moveTo(X - 5, Y + 5); o.lineTo(X + 5, Y - 5); o.stroke();
        }
        pose(S.pose_x_est[i], S.pose_y_est[i], S.pose_theta_est[i], STYLES.estimate.color, false);
        pose(S.pose_x[i], S.pose_y[i], S.pose_theta[i], "#111", true);
      }
      o.restore();
    }

    function pick(mx, my, view) {
      const a = firstAtOrAfter(S.t, view.t0), b = firstAtOrAfter(S.t, view.t1 + 1e-12);
      let best = null, bestD = 30 * 30;
      for (let i = a; i < b; i++) {
        if (S.pose_x[i] === null || S.pose_y[i] === null) continue;
        const dx = px(S.pose_x[i]) - mx, dy = py(S.pose_y[i]) - my, d = dx * dx + dy * dy;
        if (d < bestD) { bestD = d; best = i; }
      }
      return best;
    }

    return { layer: lay, drawOverlay, pick };
  }

  // --- a campaign ----------------------------------------------------------

  function campaignPage(meta) {
    const rate = finite(meta.success_rate)
      ? `${percent(meta.success_rate)} (95 % interval ${percent(meta.success_interval[0])} .. ${percent(meta.success_interval[1])})`
      : "–";
    const ok = meta.expectations.every((e) => e.met !== false) && !meta.interrupted;
    root.append(
      el("h1", { text: meta.campaign }),
      el("p", { class: "sub" },
        el("span", { class: "badge " + (ok ? "success" : "failed"), text: ok ? "expect met" : meta.interrupted ? "interrupted" : "expect not met" }),
        `${meta.succeeded} of ${meta.runs} runs succeeded: ${rate}`,
        meta.planned_runs !== null && meta.planned_runs !== undefined && meta.planned_runs !== meta.runs
          ? ` · ${meta.planned_runs} planned` : ""),
      el("p", { class: "sub", text: "outcomes: " + Object.entries(meta.outcomes).map(([k, v]) => `${k} ${v}`).join(" · ") +
        (finite(meta.missions_per_second) ? ` · ${fmt(meta.wall_seconds)} s of runs, ${fmt(meta.missions_per_second)} runs per second of simulating` : "") }),
    );
    if (meta.missing_runs > 0) {
      // A campaign stopped early: its figures and its rate cover the runs done only.
      root.append(el("p", { class: "sub bad", text:
        `runs missing: ${meta.missing_runs} of the ${meta.planned_runs} planned (interrupted after ${meta.runs})` }));
      if (meta.cells_without_runs_count) {
        const more = meta.cells_without_runs_count - meta.cells_without_runs.length;
        root.append(el("p", { class: "sub bad", text:
          `grid cells with no runs (${meta.cells_without_runs_count}): ` + meta.cells_without_runs.join("; ") +
          (more > 0 ? `; and ${more} more` : "") }));
      }
    }
    if (meta.margin) {
      const m = meta.margin;
      // The quantiles are over the finite margins: where runs have none (-inf: a
      // timeout, an invalid run), the line says over how many runs they are,
      // never a "least" above the runs that missed without a number.
      const over = m.finite !== null && m.finite !== meta.runs ? ` of the ${runs(m.finite)} with a number` : "";
      const none = m.minus_inf ? `, ${m.minus_inf} of them without a number (-inf: an outcome such as a timeout, or a check without a value)` : "";
      root.append(el("p", { class: "sub", text:
        `margins${over}: least ${fmt(m.min)}, p1 ${fmt(m.p1)}, p5 ${fmt(m.p5)}, ` +
        `median ${fmt(m.p50)}; ${runs(m.below_zero)} below 0${none}` }));
    }
    if (meta.expectations.length) {
      root.append(table(["expectation", "min", "value", "verdict"], meta.expectations.map((e) =>
        el("tr", { class: e.met === false ? "bad" : "" }, el("td", { text: e.metric }),
          el("td", { class: "num", text: fmt(e.min) }), el("td", { class: "num", text: fmt(e.value) }),
          el("td", { text: e.verdict }))), [false, true, true, false]));
    }

    if (meta.figures.length) {
      root.append(el("h2", { text: "Figures" }));
      const box = el("div", { class: "figures" });
      for (const f of meta.figures) {
        const img = el("img", { alt: f.name });
        img.src = "data:image/png;base64," + f.png;
        box.append(el("figure", null, img, el("figcaption", { text: f.name })));
      }
      root.append(box);
    }

    const metricNames = Object.keys(meta.metrics);
    if (metricNames.length) {
      root.append(el("h2", { text: "Metrics over the runs" }));
      root.append(table(["metric", "p50", "p95", "p99", "max"], metricNames.map((name) =>
        el("tr", null, el("td", { text: name }),
          ...["p50", "p95", "p99", "max"].map((q) => el("td", { class: "num", text: fmt(meta.metrics[name][q]) })))),
      [false, true, true, true, true]));
    }

    root.append(el("h2", { text: "Runs" }));
    runsTable(meta);
  }

  // --- a falsification ----------------------------------------------------

  function falsificationPage(meta) {
    const r = meta.record;
    const found = r.falsified;
    root.append(
      el("h1", { text: `${meta.campaign}: falsification (${r.method})` }),
      el("p", { class: "sub" },
        el("span", { class: "badge " + (found ? "failed" : "success"),
          text: found ? "falsified" : r.interrupted ? "interrupted" : "no failure found" }),
        found
          // a run by its evaluation number, as the table and the command name it
          ? `${r.failing_runs} failing run${r.failing_runs === 1 ? "" : "s"} of ${r.evaluations}; ` +
            `the first run ${r.runs_to_first_failure - 1} ` +
            `(${r.runs_to_first_failure} run${r.runs_to_first_failure === 1 ? "" : "s"} in)`
          : `no failing run within ${r.evaluations} runs (budget ${r.settings.budget}); lowest ${r.objective} ${fmt(number(r.lowest))}`),
      el("p", { class: "sub", text: "settings: " + Object.entries(r.settings).map(([k, v]) => `${k} ${JSON.stringify(v)}`).join(" · ") }),
    );
    root.append(el("h2", { text: `Lowest ${r.objective}` }));
    root.append(table(["evaluation", "outcome", r.objective, "margin check", "command"], r.best.map((b) =>
      el("tr", { class: b.outcome === "success" ? "" : "bad" }, el("td", { text: String(b.evaluation) }),
        el("td", { text: b.outcome }), el("td", { class: "num", text: fmt(number(b.objective)) }),
        el("td", { text: b.margin_check || "" }), el("td", null, el("code", { text: b.run || b.replay })))),
    [false, false, true, false, false]));
    if (meta.figures.length) {
      root.append(el("h2", { text: "Figures" }));
      const box = el("div", { class: "figures" });
      for (const f of meta.figures) {
        const img = el("img", { alt: f.name });
        img.src = "data:image/png;base64," + f.png;
        box.append(el("figure", null, img, el("figcaption", { text: f.name })));
      }
      root.append(box);
    }
    root.append(el("h2", { text: "Evaluations" }));
    runsTable(meta);
  }

  function runsTable(meta) {
    const columns = meta.columns;
    const numeric = meta.types.map((t) => t === "int64" || t === "float64");
    const outcomeColumn = columns.indexOf("outcome");
    const rows = meta.rows.map((cells, k) => ({
      cells,
      replay: meta.replays[k],
      keys: cells.map((c, j) => (numeric[j] ? (c === "" ? NaN : Number(c)) : c)),
      text: (cells.join("\u0000") + "\u0000" + meta.replays[k]).toLowerCase(),
    }));
    const state = { query: "", outcome: "", column: 0, descending: false, page: 0 };
    const perPage = 100;
    const worst = new Set(meta.worst);

    const search = el("input", { type: "search", placeholder: "filter: any text in a row (e.g. ekf, timeout)" });
    const outcome = el("select", null, el("option", { value: "", text: "every outcome" }),
      ...Object.keys(meta.outcomes).map((o) => el("option", { value: o, text: o })));
    const previous = el("button", { text: "◀ previous" });
    const next = el("button", { text: "next ▶" });
    const status = el("span", { class: "note" });
    root.append(el("div", { class: "controls" }, search, outcome, previous, next, status));
    if (meta.total_rows > meta.rows.length) {
      root.append(el("p", { class: "note", text:
        `The table holds ${meta.rows.length} of the ${meta.total_rows} runs: every run that did not succeed, ` +
        `then successes in run order. runs.csv has them all.` }));
    }
    const headerCells = columns.map((name, j) => {
      const th = el("th", { class: "sortable " + (numeric[j] ? "num" : ""), text: name });
      th.addEventListener("click", () => {
        state.descending = state.column === j ? !state.descending : false;
        state.column = j;
        state.page = 0;
        render();
      });
      return th;
    });
    const body = el("tbody");
    root.append(el("div", { class: "scroll" },
      el("table", { id: "runs" }, el("thead", null, el("tr", null, ...headerCells)), body)));

    function compare(a, b) {
      const x = a.keys[state.column], y = b.keys[state.column];
      let c;
      if (numeric[state.column]) {
        if (Number.isNaN(x) || Number.isNaN(y)) return Number.isNaN(x) - Number.isNaN(y);  // empty last
        c = x < y ? -1 : x > y ? 1 : 0;  // two -inf margins are equal (their difference is NaN)
      } else c = x < y ? -1 : x > y ? 1 : 0;
      return state.descending ? -c : c;
    }

    function render() {
      const query = state.query.toLowerCase();
      const matching = rows.filter((r) =>
        (!state.outcome || r.cells[outcomeColumn] === state.outcome) && (!query || r.text.includes(query)));
      matching.sort(compare);
      const pages = Math.max(1, Math.ceil(matching.length / perPage));
      state.page = Math.min(state.page, pages - 1);
      const first = state.page * perPage;
      const shown = matching.slice(first, first + perPage);
      body.replaceChildren(...shown.flatMap(rowElements));
      headerCells.forEach((th, j) => {
        th.textContent = columns[j] + (j === state.column ? (state.descending ? " ▼" : " ▲") : "");
      });
      status.textContent = matching.length
        ? `runs ${first + 1}–${first + shown.length} of ${matching.length} matching (${rows.length} in the table)`
        : `no run matches (${rows.length} in the table)`;
      previous.disabled = state.page === 0;
      next.disabled = state.page >= pages - 1;
    }

    // each run: its row, then its replay command
    function rowElements(r) {
      const tr = el("tr", { class: "run " + (r.cells[outcomeColumn] === "success" ? "" : "bad") });
      r.cells.forEach((cell, j) => {
        const td = el("td", { class: (numeric[j] ? "num" : "") + (j === columns.length - 1 ? " reason" : "") });
        if (j === 0 && worst.has(cell)) {
          const link = meta.worst_links[cell];
          td.append(link ? el("a", { href: link, text: cell }) : cell, " ",
            el("span", { class: "worst", text: "worst", title: `one of campaign.json's worst runs, in worst/${cell}` }));
        } else if (meta.types[j] === "float64" && cell !== "") {
          td.textContent = fmt(Number(cell), 5);
          td.title = cell;
        } else {
          td.textContent = cell;
          if (j === columns.length - 1) td.title = cell;  // the reason, in full below
        }
        tr.append(td);
      });
      const code = el("code", { class: "replay", text: r.replay });
      const button = el("button", { text: "Copy" });
      button.addEventListener("click", () => copy(r.replay, code, button));
      const reason = r.cells[columns.length - 1];
      const replay = el("tr", { class: "replay" },
        el("td", { colspan: String(columns.length) },
          reason ? el("div", { class: "why", text: reason }) : null,
          el("span", { class: "note", text: "replay " }), button, " ", code));
      return [tr, replay];
    }

    search.addEventListener("input", () => { state.query = search.value; state.page = 0; render(); });
    outcome.addEventListener("change", () => { state.outcome = outcome.value; state.page = 0; render(); });
    previous.addEventListener("click", () => { state.page--; render(); });
    next.addEventListener("click", () => { state.page++; render(); });
    render();
  }

  function copy(text, code, button) {
    const done = (label) => {
      button.textContent = label;
      setTimeout(() => { button.textContent = "Copy"; }, 2500);
    };
    const select = () => {  // where the page may not use the clipboard: select the command
      const range = document.createRange();
      range.selectNodeContents(code);
      const selection = window.getSelection();
      selection.removeAllRanges();
      selection.addRange(range);
      done("Selected: press Ctrl+C");
    };
    if (navigator.clipboard && navigator.clipboard.writeText) {
      navigator.clipboard.writeText(text).then(() => done("Copied"), select);
    } else select();
  }

  if (meta.kind === "run") runPage(meta, JSON.parse(document.getElementById("series").textContent));
  else if (meta.kind === "falsification") falsificationPage(meta);
  else campaignPage(meta);
  document.body.dataset.rendered = "1";
})();
