// The jobs page: new-scenario form (robot drawing, search budget, the API's validation
// message inline) and the jobs table (filters, keyset pages, live refresh of the newest page).
"use strict";

(() => {
  const { api, el, num, age, badge, progressText, FINAL } = GM;
  const $ = (id) => document.getElementById(id);
  const REFRESH_MS = 2000;
  let robots = [];
  let picker = null;

  // ---------- new scenario form ----------
  const fields = ["population", "generations", "seed", "duration"];

  function updateBudget() {
    const p = Number($("population").value), g = Number($("generations").value);
    $("budget").textContent = Number.isFinite(p) && Number.isFinite(g) && p > 0 && g >= 0
      ? `Budget: ${p} × (${g} + 1) = ${p * (g + 1)} evaluations of a ${$("duration").value} s walk.` : "";
  }

  function describeDamage(d) {
    const parts = [];
    if (d.lost_legs.length) parts.push(`lost legs ${d.lost_legs.join(", ")}`);
    for (const j of d.locked_joints) parts.push(`leg ${j.leg} ${j.joint} locked`);
    $("damage-summary").textContent = parts.length ? `Damage: ${parts.join("; ")}.` : "No damage.";
    const list = $("locked-list");
    const key = d.locked_joints.map((j) => `${j.leg}.${j.joint}`).join(",");
    if (list.dataset.key === key) return; // same joints: keep the inputs (and focus) as they are
    list.dataset.key = key;
    list.replaceChildren(...d.locked_joints.map((j) => {
      const id = `angle-${j.leg}-${j.joint}`;
      const input = el("input", { id, type: "number", step: "5", value: j.angle_deg, inputmode: "decimal",
                                  "data-field": "damage.locked_joints" });
      input.addEventListener("input", () => picker.setAngle(j.leg, j.joint, Number(input.value)));
      return el("li", {},
        el("label", { for: id, style: "display:inline;font-weight:400", text: `Leg ${j.leg} ${j.joint} held at (°)` }), input,
        el("button", { type: "button", class: "secondary", "aria-label": `Unlock leg ${j.leg} ${j.joint}`,
                       onclick: () => picker.unlock(j.leg, j.joint) }, "Unlock"));
    }));
  }

  function selectRobot() {
    const r = robots.find((x) => x.name === $("robot").value) || robots[0];
    if (!r) return;
    $("robot-desc").textContent = r.description;
    picker = RobotPicker.create($("robot-drawing"), r, describeDamage);
    picker.setMode(document.querySelector("input[name=mode]:checked").value);
  }

  function clearErrors() {
    $("form-error").hidden = true;
    for (const e of document.querySelectorAll("#new-job [aria-invalid]")) e.removeAttribute("aria-invalid");
    for (const e of document.querySelectorAll("#new-job .field-error")) e.remove();
  }

  function showErrors(err) {
    $("form-error").textContent = err.message;
    $("form-error").hidden = false;
    let first = null;
    for (const fe of err.body.errors || []) {
      const f = fe.field || "";
      const input = document.querySelector(`#new-job [data-field="${CSS.escape(f)}"]`)
        || [...document.querySelectorAll("#new-job [data-field]")].find((e) => f.startsWith(e.dataset.field + "."));
      if (!input) continue;
      input.setAttribute("aria-invalid", "true");
      const msg = el("div", { class: "field-error", id: `${input.id || "damage"}-err`, text: fe.message });
      input.setAttribute("aria-describedby", msg.id);
      input.after(msg);
      first = first || input;
    }
    (first && first.focus ? first : $("form-error")).focus?.();
  }

  function numberOrRaw(v) {
    const t = String(v).trim();
    return t !== "" && Number.isFinite(Number(t)) ? Number(t) : t; // let the API name a bad value
  }

  async function submit(e) {
    e.preventDefault();
    clearErrors();
    $("form-ok").hidden = true;
    const spec = {
      kind: "recovery",
      robot: $("robot").value,
      damage: picker ? picker.damage() : { lost_legs: [] },
      search: { optimizer: $("optimizer").value, population: numberOrRaw($("population").value),
                generations: numberOrRaw($("generations").value), seed: numberOrRaw($("seed").value) },
      sim: { duration_s: numberOrRaw($("duration").value) },
    };
    $("submit").disabled = true;
    try {
      const job = await api("/api/jobs", { method: "POST", json: spec });
      $("form-ok").replaceChildren("Queued job ", el("a", { href: `/jobs/${job.id}`, class: "id", text: job.id.slice(0, 8) }),
                                   ". It appears in the list; open it to watch the search.");
      $("form-ok").hidden = false;
      window.gmSubmittedAt = performance.now();
      await refresh(true);
      const row = rows.get(job.id);
      if (row) row.tr.classList.add("fresh");
    } catch (err) {
      if (err instanceof GM.ApiError) showErrors(err);
      else { $("form-error").textContent = String(err); $("form-error").hidden = false; }
    } finally {
      $("submit").disabled = false;
    }
  }

  // ---------- jobs table ----------
  const rows = new Map(); // id -> {item, tr, sig}
  let order = [];
  let cursor = null; // next older page
  let loadedOlder = false;
  const picked = new Set();

  function filterQuery(extra = {}) {
    const q = new URLSearchParams();
    for (const [k, v] of new FormData($("filters"))) if (v) q.set(k, v);
    for (const [k, v] of Object.entries(extra)) if (v) q.set(k, v);
    return q.toString();
  }

  function cells(item) {
    const bar = item.status === "running" || item.status === "queued"
      ? el("progress", { max: 1, value: item.progress.fraction, "aria-label": `progress ${progressText(item)}` }) : null;
    const pick = el("input", { type: "checkbox", "aria-label": `pick job ${item.id.slice(0, 8)} to compare`,
                               checked: picked.has(item.id) });
    pick.addEventListener("change", () => { pick.checked ? picked.add(item.id) : picked.delete(item.id); updateCompare(); });
    return [
      el("td", { class: "sel" }, pick),
      el("td", { "data-label": "Job" }, el("a", { class: "id", href: `/jobs/${item.id}`, text: item.id.slice(0, 8) })),
      el("td", { "data-label": "Kind", text: item.kind }),
      el("td", { "data-label": "Robot", text: item.robot || "–" }),
      el("td", { "data-label": "Damage", text: item.damage || "–" }),
      el("td", { "data-label": "Status" }, badge(item.status), " ",
         el("span", { class: "small muted", text: item.status === "running" ? progressText(item) : "" }), bar),
      el("td", { class: "num", "data-label": "Best F", text: num(item.best_fitness, 4) }),
      el("td", { "data-label": "Age", title: item.created_at, text: age(item.created_at) }),
    ];
  }

  function upsert(item) {
    const sig = JSON.stringify([item.status, item.progress, item.best_fitness, item.damage, age(item.created_at)]);
    let r = rows.get(item.id);
    if (!r) {
      r = { item, tr: el("tr", { "data-id": item.id, "data-status": item.status }), sig: null };
      rows.set(item.id, r);
    }
    r.item = item;
    if (r.sig !== sig) {
      const focused = r.tr.contains(document.activeElement) ? document.activeElement.tagName : null;
      r.tr.replaceChildren(...cells(item));
      r.tr.dataset.status = item.status;
      r.sig = sig;
      if (focused) r.tr.querySelector(focused === "A" ? "a" : "input")?.focus();
    }
  }

  function draw() {
    const body = $("jobs-body");
    const want = order.map((id) => rows.get(id).tr);
    if (want.length !== body.children.length || want.some((tr, i) => body.children[i] !== tr)) body.replaceChildren(...want);
    $("jobs-count").textContent = order.length ? `${order.length} job${order.length > 1 ? "s" : ""} shown${cursor ? "; older ones on request" : ""}.`
      : "No jobs match. Submit one with the form.";
    $("more").hidden = !cursor;
  }

  let busy = false;
  async function refresh(force = false) {
    if (busy && !force) return;
    busy = true;
    try {
      const page = await api(`/api/jobs?${filterQuery({ limit: 50 })}`);
      const firstIds = page.items.map((i) => i.id);
      page.items.forEach(upsert);
      const seen = new Set(firstIds);
      // keep the older pages already loaded (below the newest page); drop what fell off it
      const last = page.items.length ? page.items[page.items.length - 1] : null;
      const older = loadedOlder ? order.filter((id) => !seen.has(id) && rows.get(id)
                                   && last && Date.parse(rows.get(id).item.created_at) <= Date.parse(last.created_at)) : [];
      for (const id of order) if (!seen.has(id) && !older.includes(id)) rows.delete(id);
      order = firstIds.concat(older);
      if (!loadedOlder) cursor = page.next_cursor;
      // running jobs in older pages: refresh them one by one (few, if any)
      for (const id of older.filter((id) => !FINAL.has(rows.get(id).item.status)).slice(0, 20)) {
        try {
          const j = await api(`/api/jobs/${id}`);
          upsert(Object.assign({}, rows.get(id).item, j, { spec: undefined, summary: undefined }));
        } catch (e) { /* deleted meanwhile: leave it until the filters change */ }
      }
      draw();
    } catch (e) {
      $("jobs-count").textContent = `Could not load jobs: ${e.message}`;
    } finally {
      busy = false;
    }
  }

  async function more() {
    if (!cursor) return;
    $("more").disabled = true;
    try {
      const page = await api(`/api/jobs?${filterQuery({ limit: 100, cursor })}`);
      page.items.forEach(upsert);
      order = order.concat(page.items.map((i) => i.id).filter((id) => !order.includes(id)));
      cursor = page.next_cursor;
      loadedOlder = true;
      draw();
    } finally {
      $("more").disabled = false;
    }
  }

  function resetList() {
    rows.clear();
    order = [];
    cursor = null;
    loadedOlder = false;
    refresh(true);
  }

  function updateCompare() {
    const b = $("compare-btn");
    b.disabled = picked.size < 2;
    b.textContent = picked.size ? `Compare selected (${picked.size})` : "Compare selected";
  }

  async function kinds() {
    try {
      const s = await api("/openapi.json");
      const spec = s.components.schemas.JobSpec;
      const names = spec.discriminator ? Object.keys(spec.discriminator.mapping)
        : [((spec.properties || {}).kind || {}).default || "recovery"];
      $("f-kind").append(...names.map((k) => el("option", { text: k })));
    } catch (e) { $("f-kind").append(el("option", { text: "recovery" })); }
  }

  async function init() {
    $("new-job").addEventListener("submit", submit);
    for (const id of fields) $(id).addEventListener("input", updateBudget);
    $("robot").addEventListener("change", selectRobot);
    for (const r of document.querySelectorAll("input[name=mode]")) {
      r.addEventListener("change", () => {
        picker && picker.setMode(r.value);
        $("mode-help").textContent = r.value === "lost"
          ? "Click a leg (or focus it and press Enter) to mark it lost."
          : "Click a leg segment (coxa, femur, tibia from the body out) to lock that joint; Enter on a leg steps through its joints.";
      });
    }
    $("filters").addEventListener("change", resetList);
    $("more").addEventListener("click", more);
    $("compare-btn").addEventListener("click", () => { location.href = `/compare?ids=${[...picked].join(",")}`; });
    updateBudget();
    kinds();
    try {
      robots = await api("/api/robots");
      $("robot").replaceChildren(...robots.map((r) => el("option", { value: r.name, text: r.name })));
      $("f-robot").append(...robots.map((r) => el("option", { text: r.name })));
      selectRobot();
    } catch (e) {
      $("form-error").textContent = `Could not load the robot catalog: ${e.message}`;
      $("form-error").hidden = false;
    }
    await refresh(true);
    setInterval(() => { if (!document.hidden) refresh(); }, REFRESH_MS);
  }

  document.addEventListener("DOMContentLoaded", init);
})();
