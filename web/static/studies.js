// Studies list (/studies) and one study (/studies/{id}): progress, the verdict over the
// seeds, the aggregate with readable names and units, the kind's study views, every point's
// job; and a new study, built-in or written here (a base job from the kind's form, a grid
// editor), checked for size and wall time before anything is queued, confirmed above the
// server's threshold. Plotly is loaded only when a study's page has a plot to draw.
"use strict";

(() => {
  const { api, el, badge } = GM;
  const $ = (id) => document.getElementById(id);
  const body = $("st-body");
  const errBox = $("st-error");
  const id = (location.pathname.match(/^\/studies\/([0-9a-f]+)/) || [])[1];
  const showError = (e) => { errBox.hidden = false; errBox.textContent = (e.body && e.body.detail) || String(e.message || e); };
  // "3 of 3 done": the other counts only where they are not 0 (a finished study never reads
  // "0 cancelled" beside its badge)
  const progress = (p) => [`${p.done} of ${p.points} done`,
    ...["queued", "running", "failed", "cancelled"].filter((k) => p[k]).map((k) => `${p[k]} ${k}`)].join(", ");
  // an override as a person reads it: "seed 2, lost legs 1, 6" (no JSON, no null)
  const valueText = (v) => (v === null || v === undefined ? "default" : Array.isArray(v) ? (v.map(valueText).join(", ") || "none")
    : typeof v === "object" ? JSON.stringify(v) : String(v));
  const overridesText = (o) => Object.entries(o || {}).map(([k, v]) => `${k.split(".").pop().replace(/_/g, " ")} ${valueText(v)}`).join("; ") || "the base spec";

  async function list() {
    const r = await api("/api/studies");
    body.replaceChildren(el("h2", { text: "Submitted studies" }),
      r.items.length ? el("div", { class: "table-wrap", tabindex: "0", role: "region", "aria-label": "Submitted studies" },
        el("table", { class: "data", id: "study-list" },
          el("thead", {}, el("tr", {}, ["Study", "Status", "Progress", "Created"].map((h) => el("th", { scope: "col", text: h })))),
          el("tbody", {}, r.items.map((s) => el("tr", {},
            el("td", {}, el("a", { href: `/studies/${s.id}`, text: s.name })), el("td", {}, badge(s.status)),
            el("td", { text: progress(s.progress) }), el("td", { text: GM.date(s.created_at) }))))))
        : el("p", { class: "small muted", text: "No studies yet: submit one below." }));
  }

  // The verdict over the seeds has six columns with long notes: on a phone each row is a card
  // (app.css, table.stack), every cell under its column's name; a desktop keeps the table.
  function stackOnPhone(table) {
    if (!table) return;
    const heads = [...table.querySelectorAll("thead th")].map((th) => th.textContent.trim());
    for (const tr of table.querySelectorAll("tbody tr")) {
      [...tr.children].forEach((c, i) => { if (i > 0 && heads[i]) c.setAttribute("data-label", heads[i]); });
    }
    table.classList.add("stack");
  }

  // A table whose columns sort on a click (or Enter) on their name: by the cell's number
  // (data-sort, e.g. the held-out share) where it has one, else by its words; cells without
  // a value go last either way. The header keeps its words (stackOnPhone labels cells by them).
  function sortable(table) {
    if (!table) return;
    const heads = [...table.querySelectorAll("thead th")];
    const key = (tr, i) => {
      const c = tr.children[i];
      if (!c) return null;
      if (c.dataset.sort !== undefined) return Number(c.dataset.sort);
      const t = c.textContent.trim();
      return t === "–" || t === "" ? null : t;
    };
    heads.forEach((th, i) => {
      const words = th.textContent.trim();
      const b = el("button", { type: "button", class: "sort", text: words, title: `sort by ${words}` });
      th.replaceChildren(b);
      b.addEventListener("click", () => {
        const down = th.getAttribute("aria-sort") !== "descending";
        heads.forEach((h) => h.removeAttribute("aria-sort"));
        th.setAttribute("aria-sort", down ? "descending" : "ascending");
        const body = table.querySelector("tbody");
        const rows = [...body.children].map((tr, k) => [tr, key(tr, i), k]);
        rows.sort((a, b) => {
          if (a[1] === null || b[1] === null) return (a[1] === null) - (b[1] === null) || a[2] - b[2];
          const d = typeof a[1] === "number" && typeof b[1] === "number" ? a[1] - b[1] : String(a[1]).localeCompare(String(b[1]));
          return (down ? -d : d) || a[2] - b[2];
        });
        body.replaceChildren(...rows.map((r) => r[0]));
      });
    });
  }

  async function one() {
    $("new-study").hidden = true;
    const s = await api(`/api/studies/${id}`);
    document.title = `gaitmend · study ${s.name}`;
    $("st-h").textContent = `Study: ${s.name}`;
    // (replaceChildren writes a null child as the text "null": the old page printed it twice)
    body.replaceChildren(...[
      el("p", {}, badge(s.status), " ", progress(s.progress), " · created ", GM.date(s.created_at), " · ",
        el("a", { href: s.links.bundle, text: "study bundle (zip)" })),
      s.status === "running" || s.status === "queued" ? el("button", { class: "secondary", type: "button", onclick: async () => {
        await api(`/api/studies/${id}/cancel`, { method: "POST" }).catch(showError); one(); }, text: "Cancel unfinished points" }) : null,
      s.infeasible.length ? el("p", { class: "small muted", text: `Infeasible, listed and never run: ${s.infeasible.map((x) => `${overridesText(x.overrides)} (${x.reason})`).join("; ")}` }) : null,
      el("div", { id: "study-views", class: "panels" }),
      el("h2", { text: "Points" }),
      el("ul", { class: "points" }, s.jobs.map((j) => el("li", {}, el("a", { href: `/jobs/${j.id}`, text: overridesText(j.overrides) }), " ", badge(j.status),
        j.error ? ` ${j.error}` : "")))].filter(Boolean));
    const v = await api(s.links.views);
    GMViews.panels($("study-views"), v.panels);
    sortable($("study-views").querySelector("#panel-verdict table"));
    stackOnPhone($("study-views").querySelector("#panel-verdict table"));
    if (s.status === "running" || s.status === "queued") setTimeout(() => one().catch(showError), 3000);
  }

  // ---------- a new study: size and time first, then confirmation ----------
  let pending = null; // the study spec waiting for its confirmation

  async function checkStudy(spec, submitAfter) {
    errBox.hidden = true;
    const e = await api("/api/web/study-check", { method: "POST", json: spec });
    const time = e.wall_s === null || e.wall_s === undefined ? `no estimate of the wall time yet (${e.basis})`
      : `about ${GM.duration(e.wall_s)} on ${e.slots} worker slot${e.slots === 1 ? "" : "s"} (${e.basis})`;
    const text = `${e.points} job${e.points === 1 ? "" : "s"}, ${e.evaluations} evaluations in all: ${time}.`
      + (e.infeasible ? ` ${e.infeasible} infeasible point(s) listed, never run.` : "");
    $("st-estimate").textContent = `“${e.name}”: ${text}`;
    if (!submitAfter) return;
    if (e.confirm) {
      pending = spec;
      $("st-confirm-text").textContent = `Queue “${e.name}”: ${text}${e.wall_s ? ` That is more than ${GM.duration(e.confirm_above_s)} of work.` : ""} Submit it?`;
      $("st-confirm").hidden = false;
      $("st-confirm-yes").focus();
    } else await submitStudy(spec);
  }

  async function submitStudy(spec) {
    const s = await api("/api/studies", { method: "POST", json: spec });
    location.href = `/studies/${s.id}`;
  }

  // The built-in studies come from the kinds (GET /api/studies/builtin): the page names none.
  async function builtins() {
    const r = await api("/api/studies/builtin");
    $("builtin").replaceChildren(...r.items.map((b) => el("option", { value: b.name, title: b.title, text: `${b.name} (${b.kind})` })));
    $("builtin-submit").disabled = !r.items.length;
  }

  // ---------- the custom study form ----------
  let kinds = [];
  let base = null; // SpecForm of the chosen kind

  function leaves(schema, root, prefix = "", out = []) {
    const s = SpecForm.unwrap(schema, root);
    for (const [name, sub0] of Object.entries(s.properties || {})) {
      const sub = SpecForm.unwrap(sub0, root);
      const path = prefix ? `${prefix}.${name}` : name;
      if (sub.const !== undefined || (sub.oneOf && sub.discriminator)) continue;
      if (sub.type === "object" && sub.properties) leaves(sub, root, path, out);
      else out.push(path);
    }
    return out;
  }

  const kindOf = () => kinds.find((k) => k.name === $("st-kind").value) || kinds[0];

  function gridRow(path) {
    const k = kindOf();
    const n = $("grid-rows").children.length;
    const sel = el("select", { id: `grid-path-${n}`, "aria-label": `axis ${n + 1}: field` },
      leaves(k.schema, k.schema).map((p) => el("option", { value: p, text: p, selected: p === path ? true : null })));
    const vals = el("input", { id: `grid-values-${n}`, type: "text", autocomplete: "off", "aria-label": `axis ${n + 1}: values`,
                               value: path === "search.seed" ? "0, 1, 2" : "" });
    const grp = el("input", { type: "checkbox", "aria-label": `group the results by axis ${n + 1}`, checked: path !== "search.seed" ? true : null });
    const tr = el("tr", {}, el("td", {}, sel), el("td", {}, vals), el("td", {}, grp),
      el("td", {}, el("button", { type: "button", class: "secondary", "aria-label": `remove axis ${n + 1}`, onclick: () => tr.remove() }, "Remove")));
    $("grid-rows").append(tr);
  }

  function parseValues(text) {
    const t = text.trim();
    if (!t) return [];
    try { return JSON.parse(`[${t}]`); } catch (e) { /* words */ }
    return t.split(",").map((x) => x.trim()).filter(Boolean).map((x) => (Number.isFinite(Number(x)) ? Number(x) : x));
  }

  function customSpec() {
    const grid = {};
    const groupBy = [];
    for (const tr of $("grid-rows").children) {
      const [sel, vals, grp] = tr.querySelectorAll("select, input");
      grid[sel.value] = parseValues(vals.value);
      if (grp.checked) groupBy.push(sel.value);
    }
    const spec = { name: $("st-name").value.trim(), base: base.read(), grid, report: { group_by: groupBy } };
    const metrics = $("st-metrics").value.split(",").map((x) => x.trim()).filter(Boolean);
    if (metrics.length) spec.report.metrics = metrics;
    return spec;
  }

  function selectKind() {
    base = SpecForm.build($("st-base"), kindOf(), {});
    $("grid-rows").replaceChildren();
    gridRow("search.seed");
  }

  async function initCustom() {
    kinds = await api("/api/web/kinds");
    $("st-kind").replaceChildren(...kinds.map((k) => el("option", { value: k.name, text: k.name })));
    $("st-kind").addEventListener("change", selectKind);
    $("grid-add").addEventListener("click", () => gridRow(null));
    $("custom-check").addEventListener("click", () => checkStudy(customSpec(), false).catch(showError));
    $("custom-form").addEventListener("submit", (ev) => { ev.preventDefault(); checkStudy(customSpec(), true).catch(showError); });
    selectKind();
  }

  $("builtin-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    if (!$("builtin").value) return;
    try {
      await checkStudy(await api(`/api/studies/builtin/${encodeURIComponent($("builtin").value)}`), true);
    } catch (e) { showError(e); }
  });
  $("st-confirm-yes").addEventListener("click", () => {
    $("st-confirm").hidden = true;
    if (pending) submitStudy(pending).catch(showError);
  });
  $("st-confirm-no").addEventListener("click", () => { $("st-confirm").hidden = true; pending = null; });
  if (id) one().catch(showError);
  else {
    list().catch(showError);
    builtins().catch(showError);
    initCustom().catch(showError);
  }
})();
