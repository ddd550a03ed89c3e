// Two or more jobs side by side. Jobs are grouped by what their numbers mean: the kind and
// what its history's objective is (units and which way is better, from GET /views); each
// group gets its own convergence plot and metrics table, so coverage in percent is never
// drawn on the axis of a fitness, nor a distance (lower is better) beside a coverage. The
// ids live in ?ids=a,b,c.
"use strict";

(() => {
  const { api, el, num, badge, plot, empty, PALETTE } = GM;
  const $ = (id) => document.getElementById(id);
  const params = new URLSearchParams(location.search);
  let ids = [...new Set((params.get("ids") || "").split(",").map((s) => s.trim()).filter(Boolean))];
  const cache = new Map(); // id -> {job, history, views}

  function setUrl() {
    const q = ids.length ? `?ids=${ids.join(",")}` : "";
    history.replaceState(null, "", `/compare${q}`);
  }

  const short = (id) => id.slice(0, 8);
  const colorOf = (id) => PALETTE[ids.indexOf(id) % PALETTE.length];
  // A job as a person names it: its kind and damage, the id only to tell twins apart.
  const nameOf = (c) => `${c.job.kind} · ${c.job.damage || "–"} · ${short(c.job.id)}`;

  function groupKey(c) {
    const conv = c.views && c.views.convergence;
    return JSON.stringify([c.job.kind, conv ? [conv.x, conv.y, conv.better] : null]);
  }

  function groupTitle(c) {
    const conv = c.views && c.views.convergence;
    return conv ? `${c.job.kind} jobs: ${conv.y}${conv.better ? `, ${conv.better} is better` : ""}` : `${c.job.kind} jobs`;
  }

  function specText(job) {
    const s = (job.spec || {}).search || {};
    const size = s.population ?? s.particles;
    return s.optimizer && size !== undefined ? `${s.optimizer.toUpperCase()} ${size} × ${s.generations}, seed ${s.seed}` : null;
  }

  function metricRows(list) {
    const rows = [["Status", list.map((c) => badge(c.job.status))], ["Robot", list.map((c) => c.job.robot || "–")],
                  ["Damage", list.map((c) => c.job.damage || "–")]];
    if (list.some((c) => specText(c.job))) rows.push(["Search", list.map((c) => specText(c.job) || "–")]);
    rows.push(["Budget (evaluations, the spec's formula)", list.map((c) => (c.views && c.views.budget ? c.views.budget.evaluations : "–"))]);
    rows.push(["Wall time (s)", list.map((c) => (GM.FINAL.has(c.job.status) && typeof c.job.wall_s === "number" ? num(c.job.wall_s, 1) : "–"))]);
    // the verdict's held-out figure (app/jobs/verdict.py), the same words as the job page
    const held = (c) => ((c.views && c.views.verdict && c.views.verdict.robustness) || {}).held_out;
    if (list.some(held)) {
      rows.push(["Held-out random models (the verdict)", list.map((c) => {
        const h = held(c);
        if (!h) return "–";
        return el("span", { class: "held-out", "data-fragile": String(!!h.fragile) },
          el("span", { class: `mark ${h.fragile ? "unmet" : "met"}`, text: h.fragile ? "✗ fragile" : "✓ robust" }), " ", h.text);
      })]);
    }
    // the kind's headline rows, by label, with units and direction in the row name
    const labels = [];
    for (const c of list) for (const r of (c.views && c.views.headline) || []) {
      const key = `${r.label}${r.unit ? ` (${r.unit})` : ""}${r.better ? `, ${r.better} is better` : ""}`;
      if (!labels.some((l) => l[0] === key)) labels.push([key, r.label]);
    }
    for (const [key, label] of labels) {
      rows.push([key, list.map((c) => {
        const r = ((c.views && c.views.headline) || []).find((x) => x.label === label);
        if (!r) return "–";
        const v = GMViews.show(r.value, 3);
        if (r.met !== true && r.met !== false) return v;
        const mark = el("span", { class: `mark ${r.met ? "met" : "unmet"}`, text: r.met ? "✓ met" : "✗ not met" });
        // a row whose value is the verdict itself ("not met") says it once, in the mark
        // (it read "not met ✗ not met"); a number keeps its value beside the mark
        return v === "met" || v === "not met" ? el("span", { class: "verdict-only" }, mark) : el("span", {}, v, mark);
      })]);
    }
    return rows;
  }

  function groupCard(key, list, n) {
    const hid = `grp-${n}-h`;
    const card = el("section", { class: "card", "aria-labelledby": hid, "data-group": key }, el("h2", { id: hid, text: groupTitle(list[0]) }));
    const conv = list[0].views && list[0].views.convergence;
    const div = el("div", { class: "plot plot-empty", id: `plot-compare-${n}`, role: "figure",
                            "aria-label": conv ? `${conv.y} per ${conv.x} of each job` : "no per-generation objective" });
    if (conv) card.append(div);
    else card.append(el("p", { class: "small muted", text: "These jobs report no objective per generation (their history holds runs); their numbers are in the table." }));
    const rows = metricRows(list);
    // Each succeeded job's animated gait, loaded when opened (the server renders a
    // thumbnail on its first request).
    const done = list.filter((c) => c.job.status === "succeeded");
    if (done.length) {
      const prev = el("details", { class: "previews" }, el("summary", { text: "Gait previews" }));
      prev.addEventListener("toggle", () => {
        if (prev.open && !prev.querySelector(".thumbs")) {
          prev.append(el("div", { class: "thumbs" }, done.map((c) => el("figure", {}, GM.thumbnail(c.job.id),
            el("figcaption", { class: "small", text: c.job.id.slice(0, 8) })))));
        }
      });
      card.append(prev);
    }
    card.append(el("div", { class: "table-wrap", tabindex: "0", role: "region", "aria-label": `metrics of ${groupTitle(list[0])}` },
      el("table", { class: "data headline metrics" },
        el("thead", {}, el("tr", {}, el("th", { scope: "col", text: "Metric" }),
          list.map((c) => el("th", { scope: "col" }, el("span", { class: "swatch", style: `background:${colorOf(c.job.id)}` }),
                                el("a", { href: `/jobs/${c.job.id}`, text: nameOf(c) }))))),
        el("tbody", {}, rows.map(([name, vals]) => el("tr", {}, el("th", { scope: "row", text: name }),
          vals.map((v) => el("td", {}, v))))))));
    card._draw = () => {
      if (!conv) return;
      const traces = [];
      // on a phone a legend entry ("recovery · lost 1,6 · 52f13fb7: mean of population") is
      // wider than the plot and plotly cut it: there the series' words go on a second line
      const twoLines = (div.clientWidth || window.innerWidth) < 600;
      const sep = twoLines ? ":<br>" : ": ";
      if (conv) {
        const series = conv.series || { best: "best so far" };
        const secondary = Object.keys(series).find((k) => k === "mean");
        for (const c of list) {
          const hist = c.history.filter((r) => typeof r.best === "number");
          if (!hist.length) continue;
          const x = hist.map((r, k) => (conv.x in r ? r[conv.x] : k));
          const color = colorOf(c.job.id);
          traces.push({ x, y: hist.map((r) => r.best), name: `${nameOf(c)}${sep}${series.best || "best"}`, mode: "lines+markers",
                        line: { color, width: 3 }, legendgroup: c.job.id });
          if (secondary && hist.some((r) => typeof r[secondary] === "number")) {
            traces.push({ x, y: hist.map((r) => r[secondary]), name: `${nameOf(c)}${sep}${series[secondary]}`, mode: "lines",
                          visible: "legendonly", line: { color, width: 1.5, dash: "dot" }, legendgroup: c.job.id });
          }
        }
      }
      if (traces.length) {
        const maxX = Math.max(...traces.map((t) => t.x.length));
        // the legend above the plot (below it, it sat on the x axis's title)
        plot(div, traces, { xaxis: { title: { text: conv.x }, dtick: maxX <= 12 ? 1 : undefined },
                            yaxis: { title: { text: `${conv.y}${conv.better ? `, ${conv.better} better` : ""}` } },
                            legend: { orientation: "h", y: 1.02, yanchor: "bottom", x: 0 },
                            // two-line entries, one a row: the top margin holds them all (else plotly
                            // scrolled the legend over the plot)
                            ...(twoLines ? { height: 300 + 36 * traces.length } : {}),
                            margin: { l: 56, r: 16, t: twoLines ? 12 + 36 * traces.length : 24, b: 48 } });
      } else empty(div, conv ? "No history yet." : "These jobs report no objective per generation; their numbers are in the table.");
    };
    return card;
  }

  function render() {
    $("picked").replaceChildren(...ids.map((id) => {
      const c = cache.get(id);
      return el("li", {}, el("span", { class: "swatch", style: `background:${colorOf(id)}` }),
        el("a", { href: `/jobs/${id}`, text: c ? nameOf(c) : short(id) }), c ? badge(c.job.status) : "loading…",
        el("button", { type: "button", class: "secondary", "aria-label": `Remove ${c ? nameOf(c) : short(id)}`,
                       onclick: () => { ids = ids.filter((x) => x !== id); setUrl(); render(); } }, "Remove"));
    }));
    const groups = new Map();
    for (const id of ids) {
      const c = cache.get(id);
      if (!c) continue;
      const k = groupKey(c);
      if (!groups.has(k)) groups.set(k, []);
      groups.get(k).push(c);
    }
    const cards = [...groups.entries()].map(([k, list], n) => groupCard(k, list, n));
    if (groups.size > 1) {
      cards.unshift(el("p", { class: "notice", role: "note", id: "separated",
        text: `These jobs fall into ${groups.size} groups whose numbers mean different things; each group has its own plot and table.` }));
    }
    if (!cards.length) cards.push(el("p", { class: "small muted", text: "Add two or more jobs." }));
    $("groups").replaceChildren(...cards);
    for (const c of cards) if (c._draw) c._draw();
  }

  async function fetchJob(id) {
    const enc = encodeURIComponent(id);
    const [job, history, views] = await Promise.all([api(`/api/jobs/${enc}`), api(`/api/jobs/${enc}/history`),
                                                     api(`/api/jobs/${enc}/views`).catch(() => null)]);
    cache.set(id, { job, history, views });
  }

  async function loadAll() {
    const errors = [];
    await Promise.all(ids.filter((id) => !cache.has(id)).map((id) => fetchJob(id).catch((e) => {
      errors.push(`${id}: ${e.message}`);
      ids = ids.filter((x) => x !== id);
    })));
    $("cmp-error").hidden = !errors.length;
    $("cmp-error").textContent = errors.join("\n");
    setUrl();
    render();
  }

  document.addEventListener("DOMContentLoaded", () => {
    $("add-form").addEventListener("submit", async (e) => {
      e.preventDefault();
      const id = $("add-id").value.trim();
      if (!id || ids.includes(id)) return;
      ids.push(id);
      $("add-id").value = "";
      await loadAll();
    });
    loadAll();
    // jobs still running: refresh every few seconds
    setInterval(async () => {
      const open = ids.filter((id) => cache.has(id) && !GM.FINAL.has(cache.get(id).job.status));
      if (!open.length || document.hidden) return;
      await Promise.all(open.map((id) => fetchJob(id).catch(() => null)));
      render();
    }, 3000);
  });
})();
