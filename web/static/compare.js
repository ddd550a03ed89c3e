// Two or more jobs side by side: best-so-far (and, on request, mean) per generation on one
// plot, and a metrics table with one column per job. The ids live in ?ids=a,b,c.
"use strict";

(() => {
  const { api, el, num, badge, damageText, plot, empty, PALETTE } = GM;
  const $ = (id) => document.getElementById(id);
  const params = new URLSearchParams(location.search);
  let ids = [...new Set((params.get("ids") || "").split(",").map((s) => s.trim()).filter(Boolean))];
  const cache = new Map(); // id -> {job, history}

  function setUrl() {
    const q = ids.length ? `?ids=${ids.join(",")}` : "";
    history.replaceState(null, "", `/compare${q}`);
  }

  const short = (id) => id.slice(0, 8);

  function rowsFor(job) {
    const s = job.summary || {};
    const spec = job.spec || {};
    const search = spec.search || {};
    const out = [
      ["Status", job.status],
      ["Kind", job.kind],
      ["Robot", job.robot || "–"],
      ["Damage", damageText(spec)],
      ["Search", search.optimizer ? `${search.optimizer.toUpperCase()} ${search.population} × ${search.generations}, seed ${search.seed}` : "–"],
      ["Walk (s)", spec.sim && spec.sim.duration_s],
      ["Wall time (s)", job.wall_s === null || job.wall_s === undefined ? null : job.wall_s.toFixed(1)],
    ];
    if (s.kind === "recovery" && s.best) {
      const b = s.best.metrics, a = s.baseline.metrics;
      out.push(["Recovered gait", s.gait ? `${s.gait.name} (σ = ${s.gait.sigma})` : "–"],
               ["F recovered", s.best.fitness], ["F baseline", s.baseline.fitness],
               ["x recovered (cm)", b.x_f_m * 100], ["y recovered (cm)", b.y_f_m * 100], ["yaw recovered (°)", b.yaw_f_deg],
               ["roll amp. recovered (°)", b.roll_amp_deg], ["pitch amp. recovered (°)", b.pitch_amp_deg],
               ["fell (recovered)", b.fell ? "yes" : "no"],
               ["x baseline (cm)", a.x_f_m * 100], ["y baseline (cm)", a.y_f_m * 100], ["yaw baseline (°)", a.yaw_f_deg],
               ["roll amp. baseline (°)", a.roll_amp_deg], ["pitch amp. baseline (°)", a.pitch_amp_deg],
               ["fell (baseline)", a.fell ? "yes" : "no"]);
    } else {
      // other kinds: their top-level numbers and the numbers one level down
      for (const [k, v] of Object.entries(s)) {
        if (["kind", "robot", "seed", "history", "timing"].includes(k)) continue;
        if (typeof v === "number" || typeof v === "boolean") out.push([k, v]);
        else if (v && typeof v === "object" && !Array.isArray(v)) {
          for (const [k2, v2] of Object.entries(v)) if (typeof v2 === "number" || typeof v2 === "boolean") out.push([`${k}.${k2}`, v2]);
        }
      }
    }
    if (s.timing && typeof s.timing.evaluations === "number") out.push(["Evaluations", s.timing.evaluations]);
    return out;
  }

  function render() {
    const loaded = ids.filter((id) => cache.has(id));
    $("picked").replaceChildren(...ids.map((id, i) => {
      const c = cache.get(id);
      return el("li", {}, el("span", { style: `display:inline-block;width:1rem;height:.6rem;background:${PALETTE[i % PALETTE.length]}` }),
        el("a", { class: "id", href: `/jobs/${id}`, text: short(id) }), c ? badge(c.job.status) : "loading…",
        c ? el("span", { class: "small muted", text: `${c.job.kind} · ${damageText(c.job.spec)}` }) : null,
        el("button", { type: "button", class: "secondary", "aria-label": `Remove job ${short(id)}`,
                       onclick: () => { ids = ids.filter((x) => x !== id); setUrl(); render(); } }, "Remove"));
    }));
    const div = $("plot-compare");
    const traces = [];
    loaded.forEach((id) => {
      const { history } = cache.get(id);
      const i = ids.indexOf(id);
      const color = PALETTE[i % PALETTE.length];
      const rows = history.filter((r) => typeof r.best === "number");
      if (!rows.length) return;
      const x = rows.map((r, k) => ("generation" in r ? r.generation : k));
      traces.push({ x, y: rows.map((r) => r.best), name: `${short(id)} best`, mode: "lines+markers", line: { color, width: 3 },
                    legendgroup: id });
      if (rows.some((r) => typeof r.mean === "number")) {
        traces.push({ x, y: rows.map((r) => r.mean), name: `${short(id)} mean`, mode: "lines", visible: "legendonly",
                      line: { color, width: 1.5, dash: "dot" }, legendgroup: id });
      }
    });
    if (traces.length) {
      const maxX = Math.max(...traces.map((t) => t.x.length));
      plot(div, traces, { xaxis: { title: { text: "generation" }, dtick: maxX <= 12 ? 1 : undefined }, yaxis: { title: { text: "best fitness F so far" } } });
      div.dataset.rendered = "1";
    } else empty(div, ids.length < 2 ? "Add two or more jobs." : "None of these jobs has a fitness history yet.");

    const cols = loaded;
    if (!cols.length) { $("metrics").replaceChildren(); return; }
    const perJob = cols.map((id) => new Map(rowsFor(cache.get(id).job)));
    const names = [...new Set(perJob.flatMap((m) => [...m.keys()]))];
    $("metrics").replaceChildren(el("table", { class: "headline" },
      el("thead", {}, el("tr", {}, el("th", { scope: "col", text: "Metric" }),
        cols.map((id) => el("th", { scope: "col" }, el("a", { class: "id", href: `/jobs/${id}`, text: short(id) }))))),
      el("tbody", {}, names.map((n) => el("tr", {}, el("th", { scope: "row", text: n }),
        perJob.map((m) => {
          const v = m.get(n);
          return el("td", { text: typeof v === "number" ? num(v, 3) : v === undefined || v === null ? "–" : String(v) });
        }))))));
  }

  async function fetchJob(id) {
    const [job, history] = await Promise.all([api(`/api/jobs/${encodeURIComponent(id)}`),
                                              api(`/api/jobs/${encodeURIComponent(id)}/history`)]);
    cache.set(id, { job, history });
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
