// The job page: status and actions, convergence (live while the job runs, from the event
// stream, labelled with what the kind says its history means), then what the kind supplies
// once it succeeded (headline rows, tables, figures; see views.js), the controls and
// robustness tables, the bundle's own figures and files, and viser's client playing the
// bundle's replay.viser. No kind is named here.
"use strict";

(() => {
  const { api, el, num, badge, progressText, plot, empty, FINAL, COLORS } = GM;
  const $ = (id) => document.getElementById(id);
  const jobId = decodeURIComponent(location.pathname.split("/").filter(Boolean).pop());
  let job = null;
  let resultShown = false;
  let live = null;

  let meta = null; // GET /views: what the history means, and the kind's result views
  const yLabel = () => (meta && meta.convergence ? meta.convergence.y : "objective");

  // ---------- header ----------
  function header(j) {
    document.title = `gaitmend · ${j.kind} ${j.id.slice(0, 8)}`;
    $("job-title").replaceChildren(`${j.kind} job `, el("span", { class: "id", text: j.id }));
    const bar = FINAL.has(j.status) ? null
      : el("progress", { max: 1, value: j.progress.fraction, "aria-label": "progress" });
    const info = j.progress.info || {};
    const extra = [];
    if (j.status === "running" && typeof info.best === "number") extra.push(`best ${yLabel()} ${num(info.best, 4)}`);
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
    $("video").hidden = j.status !== "succeeded";
    $("video").href = `/api/jobs/${j.id}/video`;
    $("compare-link").href = `/compare?ids=${j.id}`;
    const spec = j.spec || {};
    const s = spec.search || {};
    const facts = [["Robot", robotText(j.robot)], [(meta && meta.damage_label) || "Damage", j.damage || "–"]];
    if (s.optimizer && s.population !== undefined) {
      facts.push(["Search", `${s.optimizer.toUpperCase()}, population ${s.population}, ${s.generations} generations, seed ${s.seed}`]);
    } else if (Object.keys(s).length) {
      facts.push(["Search", Object.entries(s).filter(([, v]) => v !== null && typeof v !== "object")
        .map(([k, v]) => `${k.replace(/_/g, " ")} ${k === "optimizer" ? String(v).toUpperCase() : v}`).join(", ")]);
    }
    if (spec.sim && spec.sim.duration_s) facts.push(["Simulated time", `${spec.sim.duration_s} s`]);
    facts.push(["Created", new Date(j.created_at).toLocaleString()]);
    // wall time only once the job has ended: while running it is a moving number, not a result
    if (FINAL.has(j.status) && j.wall_s !== null && j.wall_s !== undefined) facts.push(["Wall time", `${num(j.wall_s, 1)} s`]);
    facts.push(["Attempts", `${j.attempt} of ${j.max_attempts}`], ["Owner", j.owner]);
    $("facts").replaceChildren(...facts.flatMap(([k, v]) => [el("dt", { text: k }), el("dd", { text: v })]));
    $("spec").textContent = JSON.stringify(spec, null, 2);
  }

  // An uploaded robot (a job names it by its 32-hex id) is shown by its name too, once read.
  const robotNames = {};
  function robotText(id) {
    if (!id || !/^[0-9a-f]{32}$/.test(id)) return id || "–";
    if (robotNames[id] === undefined) {
      robotNames[id] = null;
      api(`/api/robots/${id}`).then((r) => {
        robotNames[id] = `${r.name} (your robot, ${r.legs.legs.length} legs; id ${id})`;
        for (const dd of document.querySelectorAll("#facts dd")) if (dd.textContent === id) dd.textContent = robotNames[id];
      }).catch(() => {});
    }
    return robotNames[id] || id;
  }

  // ---------- convergence ----------
  let firstPlot = true;
  function convergence(rows) {
    const div = $("plot-convergence");
    const conv = meta && meta.convergence;
    const names = (conv && conv.series) || { best: "best so far", mean: "mean", worst: "worst" };
    const keys = Object.keys(names).filter((k) => rows.some((r) => typeof r[k] === "number"));
    const xKey = (conv && conv.x) || (rows.length && "generation" in rows[0] ? "generation" : null);
    historyTable(rows);
    if (!rows.length) {
      empty(div, FINAL.has(job.status) ? "No history." : `Waiting for the first ${conv ? conv.x || "generation" : "history row"}…`);
      return;
    }
    if (!conv || !keys.length) {
      // a history of runs (no objective per generation): the table is the whole story
      $("conv-h").textContent = "History";
      div.hidden = true;
      $("conv-note").textContent = "This job's history holds runs, not an objective per generation; its rows are below.";
      const d = $("history-table").querySelector("details");
      if (d) d.open = true;
      return;
    }
    const x = rows.map((r, i) => (xKey in r ? r[xKey] : i));
    const style = GM.HISTORY_LINES; // the colour table's: the bundle's convergence figure draws the same lines
    const traces = keys.map((k, i) => ({
      x, y: rows.map((r) => r[k]), name: names[k], mode: "lines+markers",
      line: { color: COLORS[k] || GM.PALETTE[(i + 2) % GM.PALETTE.length], width: (style[k] || ["solid", 2])[1],
              dash: (style[k] || ["solid"])[0] }, marker: { size: 5 },
    }));
    const better = conv.better ? `, ${conv.better} better` : "";
    $("conv-note").textContent = [conv.x_note && `${xKey[0].toUpperCase()}${xKey.slice(1)} ${conv.x_note.replace(/^generation /, "")}.`,
                                  conv.better && `${conv.y}: ${conv.better} is better.`].filter(Boolean).join(" ");
    div.setAttribute("aria-label", `${conv.y} per ${xKey}${conv.better ? `; ${conv.better} is better` : ""}`);
    return plot(div, traces, { xaxis: { title: { text: xKey }, gridcolor: "#e3e8ee",
                                        dtick: x.length <= 12 ? 1 : undefined },
                               yaxis: { title: { text: `${conv.y}${better}` }, gridcolor: "#e3e8ee" } })
      .then(() => { if (firstPlot) { firstPlot = false; window.gmFirstPlotAt = performance.now(); } });
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
    $("summary").replaceChildren(el("table", {}, el("tbody", {}, rows.map(([k, v]) =>
      el("tr", {}, el("th", { scope: "row", class: "small", text: k }), el("td", { class: "small", text: v }))))));
  }

  function headline(rows) {
    $("headline-card").hidden = !rows.length;
    if (rows.length) $("headline").replaceChildren(GMViews.headline(rows));
  }

  function sizeText(n) {
    return n >= 1048576 ? `${(n / 1048576).toFixed(1)} MB` : n >= 1024 ? `${Math.round(n / 1024)} kB` : `${n} B`;
  }

  function files(list) {
    $("files-card").hidden = !list.length;
    const zip = el("tr", {}, el("th", { scope: "row" }, el("a", { href: $("download").href, class: "dl-zip", text: "the whole bundle (.zip)",
                                                     onclick: (e) => { e.preventDefault(); $("download").click(); } })),
                   el("td", { text: "" }), el("td", { class: "small", text: "every file below in one zip" }));
    $("files").replaceChildren(el("table", { class: "data files" },
      el("thead", {}, el("tr", {}, el("th", { scope: "col", text: "File" }), el("th", { scope: "col", class: "num", text: "Size" }),
                         el("th", { scope: "col", text: "What it is" }))),
      el("tbody", {}, zip, list.map((f) => el("tr", {},
        el("th", { scope: "row" }, el("a", { href: f.url, download: f.path.split("/").pop(), class: "id", text: f.path })),
        el("td", { class: "num small", text: sizeText(f.size) }), el("td", { class: "small", text: f.what || "" }))))));
  }

  // a kind writes each figure as SVG, PNG or both (plots/<stem>.svg|png): the PNG is drawn
  // where there is one, else the SVG; each format present downloads on its own
  function figures(list) {
    $("figures-card").hidden = !list.length;
    $("figures").replaceChildren(...list.map((f) => el("figure", { class: "bundle-figure" },
      el("a", { href: f.svg || f.png, target: "_blank", rel: "noopener" },
         el("img", { loading: "lazy", decoding: "async", src: f.png || f.svg, alt: `bundle figure ${f.name.replace(/_/g, " ")}` })),
      el("figcaption", { class: "small" }, `${f.name.replace(/_/g, " ")}`,
         ...["png", "svg"].filter((x) => f[x]).flatMap((x) => [" · ", el("a", { href: f[x], download: `${f.name}.${x}`, text: x.toUpperCase() })])))));
  }

  // One scene per run (the bundle's replay.viser is the method's answer alone, each other
  // run replay/<name>.viser: one robot is what a software renderer plays smoothly): the
  // answer first, a button per run switches the frame to another. An older bundle has one
  // replay.viser with every run side by side, and no buttons.
  function replay(list, tracks = []) {
    const url = Object.fromEntries(list.map((x) => [x.path, x.url]));
    const own = tracks.filter((t) => t.path && url[t.path]);
    const apart = own.length > 0 && own.length === tracks.length;
    if (!url[apart ? own[0].path : "replay.viser"]) return;
    const frame = $("replay");
    const named = (t) => [el("span", { class: "swatch", style: `background:${t.color}` }), el("strong", { text: t.label })];
    const chooser = $("replay-tracks");
    const show = (t) => {
      const src = `/viser/?playbackPath=${encodeURIComponent(url[t ? t.path : "replay.viser"])}`;
      $("replay-open").href = src;
      frame.dataset.src = src;
      if (frame.getAttribute("src")) frame.src = src; // already on screen: the other scene now
      if (!t) return;
      frame.dataset.track = t.name;
      frame.title = `3D replay of ${t.label}`;
      $("replay-file").textContent = t.path;
      $("replay-what").replaceChildren(...named(t), own.length > 1 ? " alone (the buttons below show another run)" : "");
      for (const b of chooser.children) b.setAttribute("aria-pressed", String(b.dataset.track === t.name));
    };
    if (apart) {
      chooser.replaceChildren(...own.map((t) => el("button", { type: "button", class: "secondary", "data-track": t.name,
        "aria-pressed": "false", onclick: () => show(t) }, ...named(t))));
      chooser.hidden = own.length < 2;
      show(own[0]);
    } else {
      if (tracks.length) { // named and coloured as the plots name and colour them
        $("replay-what").replaceChildren(...tracks.flatMap((t, i) => [i ? (i === tracks.length - 1 ? " and " : ", ") : "",
          ...named(t)]), " side by side");
      }
      show(null);
    }
    $("replay-card").hidden = false;
    // viser's client starts playing (and rendering, in software on many machines) as soon
    // as it loads: it gets its address only once the replay is on screen
    if (!("IntersectionObserver" in window)) { frame.src = frame.dataset.src; return; }
    const seen = new IntersectionObserver((entries) => {
      if (!entries.some((e) => e.isIntersecting)) return;
      seen.disconnect();
      frame.src = frame.dataset.src;
    }, { threshold: 0.05 });
    seen.observe(frame);
  }

  // the views and the history are asked for beside the job itself (one round trip, not three)
  let early = null;
  const take = (key, path) => {
    const p = early && early[key];
    if (early) early[key] = null;
    return p || api(path);
  };

  async function results(j) {
    if (resultShown) return;
    resultShown = true;
    summaryTable(j.summary || {});
    try { meta = await take("views", `/api/jobs/${jobId}/views`); } catch (e) {
      $("panels").replaceChildren(el("p", { class: "alert", text: `The result views could not be loaded: ${e.message}` }));
      return;
    }
    header(j);
    verdict(meta.verdict, meta.headline || []);
    headline(meta.headline || []);
    const types = [...(meta.panels || []), ...(meta.evidence || [])].flatMap((p) => ((p.figure || {}).data || []).map((t) => t.type));
    if (j.status === "succeeded") GM.loadPlotly(types).catch(() => null); // its start-up runs while the page is laid out
    const history = take("history", `/api/jobs/${jobId}/history`).then(convergence).catch(() => null);
    if (j.status !== "succeeded") { await history; return; }
    const secs = [...GMViews.panels($("panels"), meta.panels || []), ...GMViews.panels($("evidence"), meta.evidence || [])];
    figures(meta.figures || []);
    files(meta.files || []);
    replay(meta.files || [], meta.replay || []);
    // the first screen: the verdict and headline (drawn above) and every plot that shows in
    // the window as the page opens; the browser's timing API gets a mark for it and for all
    const onScreen = (node) => node.getBoundingClientRect().top < window.innerHeight;
    const first = [onScreen($("plot-convergence")) ? history : null, ...secs.filter(onScreen).map((sec) => sec._drawn)];
    await Promise.all(first.filter(Boolean));
    performance.mark("gm-first-screen");
    await Promise.all([history, ...secs.map((sec) => sec._drawn)].filter(Boolean));
    performance.mark("gm-drawn"); // every plot of the page drawn (tests read it with the timing API)
    document.body.dataset.drawn = "1";
  }

  // ---------- the verdict at a glance (the kind's verdict: app/jobs/verdict.py) ----------
  const fill = (node, ...kids) => node.replaceChildren(...kids.filter((k) => k !== null && k !== undefined));
  const OUTCOME = { beat: ["▲", "beat", "better"], tied: ["=", "tied", "tied"], lost: ["▼", "lost", "worse"] };

  function verdict(v, rows = []) {
    const box = $("verdict");
    if (!v) { box.hidden = true; return; }
    box.hidden = false;
    const held = (v.robustness || {}).held_out;
    // a fragile gait: the sentence opens with why, marked so it is the first thing read
    const warn = held && held.fragile && (v.sentence || "").startsWith(held.headline) ? held.headline : null;
    box.dataset.fragile = held ? String(!!held.fragile) : "";
    fill($("verdict-sentence"), warn ? el("strong", { class: "fragile", text: warn }) : null,
      warn ? v.sentence.slice(warn.length) : v.sentence || "");
    let t = v.target || {};
    // a target the kind states but did not judge this run by (e.g. a walk too short for it):
    // the headline row that carries the target says why, in words
    const unjudged = t.met === true || t.met === false ? null
      : rows.find((r) => r.target && (r.met === null || r.met === undefined) && typeof r.value === "string");
    if (unjudged) t = { text: unjudged.target, met: null };
    const mark = t.met === true ? el("span", { class: "mark met", text: "✓ target met" })
      : t.met === false ? el("span", { class: "mark unmet", text: "✗ target not met" })
      : unjudged ? el("span", { class: "mark none", text: "– target not judged" }) : el("span", { class: "mark none", text: "no target of its own" });
    const p = v.primary;
    fill($("verdict-target"), el("h3", { text: "Target" }), mark,
      el("p", { class: "small", text: t.text || "The kind states no target." }),
      p ? el("p", { class: "verdict-primary" }, el("span", { class: "small muted", text: `${p.label}: ` }),
             el("strong", { text: `${GMViews.show(p.value, 3)}${p.unit ? ` ${p.unit}` : ""}` }),
             p.better ? el("span", { class: "small muted", text: ` (${p.better} is better)` }) : null) : null);
    const compared = (v.controls || []).filter((c) => c.compared);
    const others = (v.controls || []).filter((c) => !c.compared);
    const item = (c) => {
      const [sym, word, cls] = OUTCOME[c.outcome] || ["–", "–", "tied"];
      return el("li", { "data-control": c.name, "data-outcome": c.outcome },
        el("span", { class: `mark ${cls}`, text: `${sym} ${word}` }), " ", el("strong", { text: c.label }),
        el("div", { class: "small", text: c.text }));
    };
    fill($("verdict-controls"), el("h3", { text: "Against the controls (same budget)" }),
      compared.length ? el("ul", { class: "verdict-list" }, compared.map(item))
        : el("p", { class: "small", text: (v.controls || []).length ? "No control shares a number with the method." : "No controls were run." }),
      others.length ? el("p", { class: "small muted", text: `Judged on their own terms (see Controls below): ${others.map((c) => c.label).join("; ")}.` }) : null,
      v.criteria && v.criteria.length ? el("p", { class: "small muted", text: `Compared on: ${v.criteria.join(", then ")}.` }) : null);
    const r = v.robustness;
    const notJudged = r ? r.total - r.met - r.failed.length : 0; // neither met nor missed: not judged
    // the held-out random models lead (models the search never saw), then the named cases
    // and the timestep checks, each its own count
    const heldLine = held ? el("p", { class: "held-out", "data-fragile": String(!!held.fragile) },
      el("span", { class: `mark ${held.fragile ? "unmet" : "met"}`, text: held.fragile ? "✗ fragile" : "✓ robust" }), " ",
      el("strong", { text: held.text })) : null;
    const reruns = r && r.total ? el("p", {}, el("span", { class: `mark ${r.met === r.total ? "met" : notJudged === r.total ? "none" : "unmet"}`,
                                                  text: `${r.met} of ${r.total}` }),
      " named-case and timestep re-runs meet the target", notJudged ? `; ${notJudged} not judged` : "") : null;
    fill($("verdict-robustness"), el("h3", { text: "Robustness" }), heldLine, reruns,
      !r ? el("p", { class: "small", text: "No robustness re-runs were recorded." }) : null,
      r ? el("ul", { class: "verdict-list small" }, r.groups.map((g) => el("li", { "data-group": g.name },
        `${g.label}: ${g.met} of ${g.total}`, g.fell === null || g.fell === undefined ? "" : `, ${g.fell} fall`))) : null,
      r && r.failed.length ? el("p", { class: "small muted", text: `Missed under: ${r.failed.join("; ")}.` }) : null,
      held ? el("p", { class: "small muted rule", text: `The gait is called ${held.rule}.` }) : null);
    performance.mark("gm-verdict");
  }

  // ---------- queue position and ETA while queued or running ----------
  function queueLine(q, status) {
    const line = $("queue-line");
    if (!q || FINAL.has(status)) { line.hidden = true; return; }
    const eta = q.eta_s === null || q.eta_s === undefined ? "no estimate yet (no job of this kind has finished here)"
      : `about ${GM.duration(q.eta_s)} from now`;
    line.hidden = false;
    line.textContent = status === "queued"
      ? `Queue position ${q.position}${q.held ? " (a study point waiting to be admitted)" : ""}: ${q.ahead} job${q.ahead === 1 ? "" : "s"} ahead, ${q.running} running on ${q.slots} worker slot${q.slots === 1 ? "" : "s"}. Finished ${eta}.`
      : `Finished ${eta} (${q.how}).`;
  }

  let queueTimer = null;
  async function pollQueue() {
    clearTimeout(queueTimer);
    if (!job || FINAL.has(job.status)) { queueLine(null, "succeeded"); return; }
    try { meta = await api(`/api/jobs/${jobId}/views`); queueLine(meta.queue, job.status); } catch (e) { /* next time */ }
    queueTimer = setTimeout(pollQueue, 5000);
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
    if (!job) { // the first load: the job, its views and its history at once
      const quiet = (p) => { p.catch(() => null); return p; };
      early = { views: quiet(api(`/api/jobs/${jobId}/views`)), history: quiet(api(`/api/jobs/${jobId}/history`)) };
    }
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
    if (FINAL.has(job.status)) { results(job); return; }
    try { meta = await take("views", `/api/jobs/${jobId}/views`); } catch (e) { /* plain labels */ }
    header(job);
    queueLine(meta && meta.queue, job.status);
    try { await convergence(await take("history", `/api/jobs/${jobId}/history`)); } catch (e) { /* shown as waiting */ }
    pollQueue();
    follow();
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
    $("video").addEventListener("click", (e) => {
      if (!GM.token()) return; // a plain link does it
      e.preventDefault();
      GM.download(`/api/jobs/${jobId}/video`, `gaitmend-${jobId}.mp4`).catch((err) => {
        $("job-error").textContent = err.message;
        $("job-error").hidden = false;
      });
    });
    load();
  });
})();
