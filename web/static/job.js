// The job page: status and actions, the Table II headline, convergence (live while the job
// runs, from the event stream), body angles and CoM against time, gait diagram, the kind's
// summary, and viser's client playing the bundle's replay.viser.
"use strict";

(() => {
  const { api, el, num, badge, progressText, damageText, plot, empty, FINAL, COLORS, PALETTE } = GM;
  const $ = (id) => document.getElementById(id);
  const jobId = decodeURIComponent(location.pathname.split("/").filter(Boolean).pop());
  let job = null;
  let resultShown = false;
  let live = null;

  const tint = (hex, f) => { // mix with white: the legend shows the same light colour as the bars
    const n = parseInt(hex.slice(1), 16);
    const ch = [16, 8, 0].map((sh) => Math.round(((n >> sh) & 255) * (1 - f) + 255 * f));
    return `rgb(${ch.join(",")})`;
  };
  const colorOf = (name, i) => COLORS[name] || PALETTE[(i + 2) % PALETTE.length];
  const label = (name) => ({ best: "recovered (best)", baseline: "baseline (tripod)" }[name] || name.replace(/_/g, " "));

  // ---------- header ----------
  function header(j) {
    document.title = `gaitmend · ${j.kind} ${j.id.slice(0, 8)}`;
    $("job-title").replaceChildren(`${j.kind} job `, el("span", { class: "id", text: j.id }));
    const bar = FINAL.has(j.status) ? null
      : el("progress", { max: 1, value: j.progress.fraction, "aria-label": "progress" });
    const info = j.progress.info || {};
    const extra = [];
    if (j.status === "running" && typeof info.best === "number") extra.push(`best F ${num(info.best, 4)}`);
    if (typeof info.sim_steps_per_s === "number") extra.push(`${Math.round(info.sim_steps_per_s)} sim steps/s`);
    if (j.cancel_requested && !FINAL.has(j.status)) extra.push("cancel requested");
    $("status-line").replaceChildren(...[badge(j.status), bar].filter(Boolean), el("span", { class: "small", text: progressText(j) }),
                                     el("span", { class: "small muted", text: extra.join(" · ") }));
    $("job-error").hidden = !j.error;
    $("job-error").textContent = j.error || "";
    $("cancel").hidden = FINAL.has(j.status) || j.cancel_requested;
    $("retry").hidden = !(j.status === "failed" || j.status === "cancelled");
    const dl = $("download");
    dl.hidden = j.status !== "succeeded";
    dl.href = `/api/jobs/${j.id}/bundle`;
    $("compare-link").href = `/compare?ids=${j.id}`;
    const spec = j.spec || {};
    const s = spec.search || {};
    const facts = [["Robot", j.robot || "–"], ["Damage", damageText(spec)]];
    if (s.optimizer && s.population !== undefined) {
      facts.push(["Search", `${s.optimizer.toUpperCase()}, population ${s.population}, ${s.generations} generations, seed ${s.seed}`]);
    } else if (Object.keys(s).length) {
      facts.push(["Search", Object.entries(s).map(([k, v]) => `${k} ${typeof v === "string" ? v.toUpperCase() : v}`).join(", ")]);
    }
    if (spec.sim && spec.sim.duration_s) facts.push(["Walk", `${spec.sim.duration_s} s`]);
    facts.push(["Created", new Date(j.created_at).toLocaleString()]);
    if (j.wall_s !== null && j.wall_s !== undefined) facts.push(["Wall time", `${num(j.wall_s, 1)} s`]);
    facts.push(["Attempts", `${j.attempt} of ${j.max_attempts}`], ["Owner", j.owner]);
    $("facts").replaceChildren(...facts.flatMap(([k, v]) => [el("dt", { text: k }), el("dd", { text: v })]));
    $("spec").textContent = JSON.stringify(spec, null, 2);
  }

  // ---------- convergence ----------
  let firstPlot = true;
  function convergence(rows) {
    const div = $("plot-convergence");
    const keys = ["best", "mean", "worst"].filter((k) => rows.some((r) => typeof r[k] === "number"));
    const xKey = rows.length && "generation" in rows[0] ? "generation" : rows.length && "run" in rows[0] ? "run" : null;
    historyTable(rows);
    if (!rows.length) {
      empty(div, FINAL.has(job.status) ? "No per-generation history." : "Waiting for the first generation…");
      return;
    }
    if (!keys.length) {
      empty(div, "This job kind reports no fitness per generation; its rows are in the table below.");
      const d = $("history-table").querySelector("details");
      if (d) d.open = true;
      return;
    }
    const x = rows.map((r, i) => (xKey ? r[xKey] : i));
    const traces = keys.map((k) => ({
      x, y: rows.map((r) => r[k]), name: k === "best" ? "best so far" : `${k} of population`, mode: "lines+markers",
      line: { color: COLORS[k], width: k === "best" ? 3 : 2, dash: k === "worst" ? "dot" : "solid" }, marker: { size: 5 },
    }));
    plot(div, traces, { xaxis: { title: { text: xKey || "row" }, gridcolor: "#e3e8ee", dtick: x.length <= 12 ? 1 : undefined },
                        yaxis: { title: { text: "fitness F (higher is better)" }, gridcolor: "#e3e8ee" } });
    if (firstPlot) { firstPlot = false; window.gmFirstPlotAt = performance.now(); div.dataset.rendered = "1"; }
  }

  function historyTable(rows) {
    const box = $("history-table");
    if (!rows.length) { box.replaceChildren(); return; }
    const cols = [...new Set(rows.flatMap((r) => Object.keys(r)))].filter((k) => rows.some((r) => typeof r[k] !== "object"));
    const shown = rows.slice(-200);
    box.replaceChildren(el("details", {}, el("summary", { text: `History table (${rows.length} rows${rows.length > 200 ? ", last 200 shown" : ""})` }),
      el("table", {}, el("thead", {}, el("tr", {}, cols.map((c) => el("th", { class: "num", scope: "col", text: c })))),
         el("tbody", {}, shown.map((r) => el("tr", {}, cols.map((c) => el("td", { class: "num", text: num(r[c], 4) }))))))));
  }

  let histTimer = null, histLast = 0;
  function refreshHistory() { // at most one request a second while events arrive
    if (histTimer) return;
    histTimer = setTimeout(async () => {
      histLast = Date.now();
      try { convergence(await api(`/api/jobs/${jobId}/history`)); } catch (e) { /* the next event retries */ }
      histTimer = null;
    }, Math.max(0, histLast + 1000 - Date.now()));
  }

  // ---------- results ----------
  function headline(summary) {
    const card = $("headline-card");
    if (summary.kind !== "recovery" || !summary.best || !summary.baseline) { card.hidden = true; return; }
    card.hidden = false;
    const cols = [["x (cm)", (m) => m.x_f_m * 100, "absmin"], ["y (cm)", (m) => m.y_f_m * 100, "max"],
                  ["yaw (°)", (m) => m.yaw_f_deg, "absmin"], ["roll amp. (°)", (m) => m.roll_amp_deg, "min"],
                  ["pitch amp. (°)", (m) => m.pitch_amp_deg, "min"], ["fell", (m) => (m.fell ? "yes" : "no"), null]];
    const rows = [["Baseline (tripod)", summary.baseline], ["Recovered (best)", summary.best]];
    const better = (kind, a, b) => kind === "max" ? b > a : kind === "min" ? b < a : kind === "absmin" ? Math.abs(b) < Math.abs(a) : false;
    const table = el("table", { class: "headline" },
      el("caption", { class: "small muted", style: "text-align:left;caption-side:bottom;padding-top:.4rem",
                      text: "Final position x (sideways drift) and y (forward, the walking direction), final yaw, roll and pitch amplitude, as in the paper's Table II; F is the fitness (Eq. 5), higher is better. Bold green: better than the baseline." }),
      el("thead", {}, el("tr", {}, el("th", { scope: "col", text: "Gait" }), cols.map(([h]) => el("th", { scope: "col", text: h })),
                         el("th", { scope: "col", text: "F" }))),
      el("tbody", {}, rows.map(([name, r], i) => el("tr", {}, el("th", { scope: "row", text: name }),
        cols.map(([, f, kind]) => {
          const v = f(r.metrics);
          const good = i === 1 && kind && better(kind, f(summary.baseline.metrics), v);
          return el("td", { class: good ? "better" : null, text: typeof v === "number" ? v.toFixed(2) : v });
        }),
        el("td", { class: i === 1 && r.fitness > summary.baseline.fitness ? "better" : null, text: num(r.fitness, 4) })))));
    $("headline").replaceChildren(table);
  }

  function flatten(obj, prefix = "", out = [], depth = 0) {
    for (const [k, v] of Object.entries(obj || {})) {
      const key = prefix ? `${prefix}.${k}` : k;
      if (["history", "tree", "bounds", "best_params", "params", "terms"].includes(k)) continue;
      if (v && typeof v === "object" && !Array.isArray(v)) {
        if (depth < 3) flatten(v, key, out, depth + 1);
      } else if (Array.isArray(v)) {
        if (v.length <= 8 && v.every((x) => x === null || typeof x !== "object")) out.push([key, v.map((x) => num(x, 3)).join(", ")]);
        else if (v.length <= 8) {
          const text = JSON.stringify(v);
          out.push([key, text.length > 240 ? `${text.slice(0, 240)}… (${v.length} items; all in the bundle's result.json)` : text]);
        }
      } else if (typeof v === "string" && v.length > 240) {
        out.push([key, `${v.slice(0, 240)}…`]);
      } else out.push([key, typeof v === "number" ? num(v, 4) : v === null ? "–" : String(v)]);
    }
    return out;
  }

  function summaryTable(summary) {
    const rows = flatten(summary);
    $("summary-card").hidden = !rows.length;
    $("summary-details").open = summary.kind !== "recovery"; // recovery's numbers are in the headline
    $("summary").replaceChildren(el("table", {}, el("tbody", {}, rows.map(([k, v]) =>
      el("tr", {}, el("th", { scope: "row", class: "small", text: k }), el("td", { class: "small", text: v }))))));
  }

  function gaitText(summary) {
    const describe = (g) => g ? `${g.name} (σ = ${g.sigma}): ${(g.groups || []).map((grp) => `[${grp.join(" ")}]`).join(" → ")}` : "";
    const parts = [];
    if (summary.gait) parts.push(`Recovered: ${describe(summary.gait)}`);
    if (summary.baseline && summary.baseline.gait) parts.push(`Baseline: ${describe(summary.baseline.gait)}`);
    return parts.join(". ") + (parts.length ? ". Dark bars are swing (foot in the air), light bars support; double-click the plot for the whole walk." : "");
  }

  function tracePlots(tr, summary) {
    const names = Object.keys(tr);
    if (!names.length) return;
    const has = (k) => names.some((n) => k in tr[n].series);
    // body angles and CoM: three stacked panels each, one legend entry per trajectory
    const panels = (specs, div, unit) => {
      const present = specs.filter(([k]) => has(k));
      div.closest("section").hidden = !present.length;
      if (!present.length) return false;
      const n = present.length, gap = 0.06, h = (1 - gap * (n - 1)) / n;
      const traces = [], layout = { hovermode: "x unified", height: 150 * n + 90, showlegend: true };
      present.forEach(([k, title, scale], p) => {
        const ax = p === 0 ? "" : String(p + 1);
        names.forEach((name, i) => {
          if (!(k in tr[name].series)) return;
          traces.push({ x: tr[name].time_s, y: tr[name].series[k].map((v) => (v === null ? null : v * scale)), name: label(name),
                        legendgroup: name, showlegend: p === 0, xaxis: `x${ax}`, yaxis: `y${ax}`, mode: "lines",
                        line: { color: colorOf(name, i), width: 2 } });
        });
        layout[`yaxis${ax}`] = { title: { text: `${title} (${unit})` }, domain: [1 - (p + 1) * h - p * gap, 1 - p * (h + gap)],
                                 gridcolor: "#e3e8ee", anchor: `x${ax}` };
        layout[`xaxis${ax}`] = { matches: p ? "x" : undefined, anchor: `y${ax}`, showticklabels: p === n - 1,
                                 title: p === n - 1 ? { text: "time (s)" } : undefined, gridcolor: "#e3e8ee" };
      });
      plot(div, traces, layout);
      return true;
    };
    const ORIENT = [["roll_deg", "roll", 1], ["pitch_deg", "pitch", 1], ["yaw_deg", "yaw", 1]];
    const COM = [["com_m_0", "CoM x", 100], ["com_m_1", "CoM y", 100], ["com_m_2", "CoM z", 100]];
    const both = ORIENT.some(([k]) => has(k)) && COM.some(([k]) => has(k));
    // Plotly sizes a graph by its container: lay the cards out before drawing
    $("trace-plots").hidden = false;
    $("trace-plots").style.gridTemplateColumns = both ? "" : "minmax(0, 1fr)";
    const a = panels(ORIENT, $("plot-orientation"), "°");
    const b = panels(COM, $("plot-com"), "cm");
    $("trace-plots").hidden = !(a || b);

    // gait diagram: swing (dark) and support (light) bars per leg and trajectory
    const withLegs = names.filter((n) => Object.keys(tr[n].swing).length);
    $("gait-card").hidden = !withLegs.length;
    if (withLegs.length) {
      const traces = [];
      const cats = [];
      withLegs.forEach((name, i) => {
        const T = tr[name].duration_s;
        const sw = { x: [], base: [], y: [], text: [] }, su = { x: [], base: [], y: [], text: [] };
        for (const leg of tr[name].legs) {
          const y = `${{ best: "recovered", baseline: "baseline" }[name] || name.replace(/_/g, " ")} · leg ${leg}`;
          cats.push(y);
          let t0 = 0;
          for (const [s, e] of tr[name].swing[String(leg)] || []) {
            if (s > t0) { su.base.push(t0); su.x.push(s - t0); su.y.push(y); su.text.push(`support ${t0.toFixed(2)}–${s.toFixed(2)} s`); }
            sw.base.push(s); sw.x.push(e - s); sw.y.push(y); sw.text.push(`swing ${s.toFixed(2)}–${e.toFixed(2)} s`);
            t0 = e;
          }
          if (t0 < T) { su.base.push(t0); su.x.push(T - t0); su.y.push(y); su.text.push(`support ${t0.toFixed(2)}–${T.toFixed(2)} s`); }
        }
        const c = colorOf(name, i);
        traces.push(Object.assign({ type: "bar", orientation: "h", name: `${label(name)}: swing`, marker: { color: c }, textposition: "none",
                                    hovertemplate: "%{y}: %{text}<extra></extra>", legendgroup: name }, sw));
        traces.push(Object.assign({ type: "bar", orientation: "h", name: `${label(name)}: support`,
                                    marker: { color: tint(c, 0.75) }, textposition: "none", hovertemplate: "%{y}: %{text}<extra></extra>",
                                    legendgroup: name }, su));
      });
      const period = (summary.gait && summary.gait.period_s) || null;
      const T = Math.max(...withLegs.map((n) => tr[n].duration_s));
      plot($("plot-gait"), traces, {
        barmode: "overlay", hovermode: "closest", height: 60 + 26 * cats.length, bargap: 0.25,
        yaxis: { categoryorder: "array", categoryarray: [...cats].reverse(), automargin: true },
        xaxis: { title: { text: "time (s)" }, range: period && T > 4 * period ? [0, 4 * period] : undefined, gridcolor: "#e3e8ee" },
      });
      $("gait-text").textContent = gaitText(summary);
    }

    // anything else recorded per step (other job kinds): one at a time
    const used = new Set(["roll_deg", "pitch_deg", "yaw_deg", "com_m_0", "com_m_1", "com_m_2"]);
    const others = [...new Set(names.flatMap((n) => Object.keys(tr[n].series)))].filter((k) => !used.has(k));
    $("other-card").hidden = !others.length;
    if (others.length) {
      const sel = $("other-select");
      sel.replaceChildren(...others.map((k) => el("option", { text: k })));
      const draw = () => plot($("plot-other"), names.filter((n) => sel.value in tr[n].series).map((n, i) => ({
        x: tr[n].time_s, y: tr[n].series[sel.value], name: label(n), mode: "lines", line: { color: colorOf(n, i), width: 2 } })),
        { xaxis: { title: { text: "time (s)" } }, yaxis: { title: { text: sel.value } } });
      sel.onchange = draw;
      draw();
    }
  }

  async function replay() {
    try {
      const files = await api(`/api/jobs/${jobId}/files`);
      if (!("replay.viser" in files)) return;
      const link = await api(`/api/jobs/${jobId}/file-link?path=replay.viser`);
      const src = `/viser/?playbackPath=${encodeURIComponent(link.url)}`;
      $("replay-card").hidden = false;
      if (job.kind !== "recovery") $("replay-what").textContent = "the job's recorded runs side by side";
      $("replay").src = src;
      $("replay-open").href = src;
    } catch (e) {
      $("replay-card").hidden = false;
      $("replay-card").append(el("p", { class: "alert", text: `The 3D replay could not be loaded: ${e.message}` }));
    }
  }

  async function results(j) {
    if (resultShown) return;
    resultShown = true;
    const summary = j.summary || {};
    headline(summary);
    summaryTable(summary);
    if (j.status !== "succeeded") return;
    replay();
    try {
      tracePlots(await api(`/api/jobs/${jobId}/traces`), summary);
    } catch (e) {
      $("trace-plots").hidden = false;
      empty($("plot-orientation"), `Trajectories could not be loaded: ${e.message}`);
    }
  }

  // ---------- live updates ----------
  async function follow() {
    if (live) return;
    live = new AbortController();
    const onJob = (j) => { // events carry the short form (no spec, no summary): keep what we have
      const keep = Object.fromEntries(Object.entries(j).filter(([k, v]) => !(v === null && (k === "spec" || k === "summary"))));
      job = Object.assign({}, job, keep);
      header(job);
    };
    try {
      await GM.events(`/api/jobs/${jobId}/events`, (name, data) => {
        if (name === "progress") { onJob(data); refreshHistory(); }
      }, live.signal);
    } catch (e) {
      // no stream (proxy, network): poll instead
      while (job && !FINAL.has(job.status)) {
        await new Promise((r) => setTimeout(r, 2000));
        try { onJob(await api(`/api/jobs/${jobId}`)); refreshHistory(); } catch (err) { break; }
      }
    }
    live = null;
    await load();
  }

  async function load() {
    try {
      job = await api(`/api/jobs/${jobId}`);
    } catch (e) {
      $("job-title").textContent = e.status === 404 ? "Job not found" : "Could not load the job";
      $("job-error").textContent = e.message;
      $("job-error").hidden = false;
      empty($("plot-convergence"), "–");
      return;
    }
    header(job);
    try { convergence(await api(`/api/jobs/${jobId}/history`)); } catch (e) { /* shown as waiting */ }
    if (FINAL.has(job.status)) results(job);
    else follow();
  }

  async function action(path, button) {
    button.disabled = true;
    try {
      const j = await api(`/api/jobs/${jobId}/${path}`, { method: "POST" });
      job = j;
      header(j);
      if (path === "retry") { resultShown = false; follow(); }
    } catch (e) {
      $("job-error").textContent = e.message;
      $("job-error").hidden = false;
    } finally {
      button.disabled = false;
    }
  }

  document.addEventListener("DOMContentLoaded", () => {
    $("cancel").addEventListener("click", () => action("cancel", $("cancel")));
    $("retry").addEventListener("click", () => action("retry", $("retry")));
    $("download").addEventListener("click", (e) => {
      if (!GM.token()) return; // a plain link does it
      e.preventDefault();
      GM.download(`/api/jobs/${jobId}/bundle`, `gaitmend-${jobId}.zip`).catch((err) => {
        $("job-error").textContent = err.message;
        $("job-error").hidden = false;
      });
    });
    load();
  });
})();
