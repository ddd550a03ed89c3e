// The jobs page: the new-job form for every kind (fields generated from the kind's JSON
// schema, the robot drawing where the kind takes lost legs, the spec's own budget, the API's
// validation message inline) and the jobs table (filters, keyset pages, live refresh).
"use strict";

(() => {
  const { api, el, num, age, badge, progressText, FINAL } = GM;
  const $ = (id) => document.getElementById(id);
  const REFRESH_MS = 2000;
  let robots = [];
  let picker = null;
  let mappedDamage = null; // MappedDamage of an uploaded robot (robot.js)

  // ---------- new job form (generated from each kind's JSON schema) ----------
  let kinds = [];
  let form = null; // SpecForm of the chosen kind
  let drawDamage = false; // the robot drawing stands in for damage.lost_legs / locked_joints

  const kindOf = () => kinds.find((k) => k.name === $("kind").value) || kinds[0];
  const props = (k) => (k && k.schema.properties) || {};
  const damageSchema = (k) => (props(k).damage ? SpecForm.unwrap(props(k).damage, k.schema) : null);
  const same = (a, b) => JSON.stringify(a) === JSON.stringify(b);

  // The damage an untouched form runs: the damage field's default (the schema carries it),
  // else each drawn field's own default.
  function damageDefault(k) {
    const dmg = damageSchema(k);
    const whole = props(k).damage.default;
    const d = whole && typeof whole === "object" ? whole : {};
    const field = (name) => {
      if (d[name] !== undefined) return d[name];
      const s = dmg.properties[name] ? SpecForm.unwrap(dmg.properties[name], k.schema) : {};
      return s.default ?? [];
    };
    return { lost_legs: field("lost_legs"), locked_joints: field("locked_joints") };
  }
  // a drawn field's default within a damage section the spec states ([] here: "none")
  function innerDefault(k, name) {
    const s = damageSchema(k).properties[name];
    return (s && SpecForm.unwrap(s, k.schema).default) ?? [];
  }

  function describeDamage(d) {
    const parts = [];
    if (d.lost_legs.length) parts.push(`lost ${d.lost_legs.length === 1 ? "leg" : "legs"} ${d.lost_legs.join(", ")}`);
    for (const j of d.locked_joints) parts.push(`leg ${j.leg} ${j.joint} locked`);
    $("damage-summary").textContent = parts.length ? `Damage: ${parts.join("; ")}.` : "No damage.";
    const list = $("locked-list");
    const key = d.locked_joints.map((j) => `${j.leg}.${j.joint}`).join(",");
    if (list.dataset.key === key) { checkSoon(); return; } // same joints: keep the inputs (and focus) as they are
    list.dataset.key = key;
    list.replaceChildren(...d.locked_joints.map((j) => {
      const id = `angle-${j.leg}-${j.joint}`;
      const input = el("input", { id, type: "number", step: "5", value: j.angle_deg, inputmode: "decimal",
                                  "data-field": "damage.locked_joints" });
      input.addEventListener("input", () => { picker.setAngle(j.leg, j.joint, Number(input.value)); checkSoon(); });
      return el("li", {},
        el("label", { for: id, style: "display:inline;font-weight:400", text: `Leg ${j.leg} ${j.joint} held at (°)` }), input,
        el("button", { type: "button", class: "secondary", "aria-label": `Unlock leg ${j.leg} ${j.joint}`,
                       onclick: () => picker.unlock(j.leg, j.joint) }, "Unlock"));
    }));
    checkSoon();
  }

  // an uploaded robot is named by its id in a job: shown by its name
  function robotLabel(id) {
    const r = id && robots.find((x) => x.builtin === false && x.id === id);
    return r ? r.name : id || "–";
  }

  // the robot field: fixed by the schema (const), its enum, or the catalog's robots for this kind
  function robotChoices(k) {
    const r = props(k).robot ? SpecForm.unwrap(props(k).robot, k.schema) : null;
    if (!r) return null;
    if (r.const !== undefined) return { names: [r.const], fixed: true, def: r.const };
    if (r.enum) { // the built-ins, then the caller's uploaded robots that run this kind (by id)
      const own = robots.filter((x) => x.builtin === false && (x.kinds || []).includes(k.name));
      return { names: r.enum.concat(own.map((x) => x.id)), def: r.default,
               labels: Object.fromEntries(own.map((x) => [x.id, `${x.name} (yours, ${x.legs.legs.length} legs)`])) };
    }
    const tagged = robots.some((x) => Array.isArray(x.kinds));
    let names = tagged ? robots.filter((x) => x.kinds.includes(k.name)).map((x) => x.name) : robots.map((x) => x.name);
    if (r.default !== undefined && !names.includes(r.default)) names = [r.default];
    return { names, def: r.default };
  }

  function selectKind() {
    const k = kindOf();
    if (!k) return;
    $("kind-desc").textContent = k.description || "";
    const rc = robotChoices(k);
    $("robot-field").hidden = !rc;
    if (rc) {
      $("robot").replaceChildren(...rc.names.map((n) => el("option", { value: n, text: (rc.labels || {})[n] || n, selected: n === rc.def ? true : null })));
      $("robot").disabled = !!rc.fixed && rc.names.length === 1;
    }
    selectRobot();
  }

  function selectRobot() {
    const k = kindOf();
    const r = robots.find((x) => (x.builtin === false ? x.id : x.name) === $("robot").value);
    $("robot-desc").textContent = r ? r.description : "";
    const dmg = damageSchema(k);
    drawDamage = !!(r && r.hips_m && dmg && dmg.properties && dmg.properties.lost_legs);
    // an uploaded robot: its damage by its leg map's names (robot_damage), drawn from its map
    const mapped = !!(r && r.builtin === false && props(k).robot_damage);
    $("mapped-picker").hidden = !mapped;
    mappedDamage = mapped ? MappedDamage.create($("mapped-drawing"), $("mapped-joints"), r, (d) => {
      $("mapped-summary").textContent = MappedDamage.describe(d);
      checkSoon();
    }) : null;
    $("damage-picker").hidden = !drawDamage;
    if (drawDamage) {
      picker = RobotPicker.create($("robot-drawing"), r, describeDamage, damageDefault(k));
      picker.setMode(document.querySelector("input[name=mode]:checked").value);
    } else picker = null;
    const skip = ["robot"].concat(drawDamage ? ["damage.lost_legs", "damage.locked_joints"] : [])
      .concat(mapped ? ["damage", "robot_damage"] : []);
    form = SpecForm.build($("spec-fields"), k, { skip, onChange: checkSoon });
    clearErrors();
    checkSoon();
  }

  function specOf() {
    const spec = form.read();
    if (!$("robot-field").hidden && !$("robot").disabled) spec.robot = $("robot").value;
    if (mappedDamage) spec.robot_damage = mappedDamage.damage();
    if (drawDamage && picker) {
      // The drawing's damage is always sent, as drawn: an emptied drawing is the intact robot
      // ({"lost_legs": []}), never "no damage section", which would run the kind's default damage.
      const k = kindOf();
      const d = picker.damage();
      spec.damage = Object.assign({}, spec.damage || {}, { lost_legs: d.lost_legs });
      if (damageSchema(k).properties.locked_joints && !same(d.locked_joints, innerDefault(k, "locked_joints"))) {
        spec.damage.locked_joints = d.locked_joints;
      }
    }
    return spec;
  }

  // The budget as the spec states it (the server's formula, the one the compare page shows).
  let checkTimer = null, checkSeq = 0;
  function checkSoon() {
    clearTimeout(checkTimer);
    checkTimer = setTimeout(async () => {
      if (!form) return;
      const seq = ++checkSeq;
      try {
        const b = await api("/api/web/check", { method: "POST", json: specOf() });
        if (seq !== checkSeq) return;
        $("budget").textContent = `Budget: ${b.evaluations} evaluations${b.formula ? ` (${b.formula})` : ""}. ${estimateText(b.estimate)}`;
      } catch (e) {
        if (seq === checkSeq) $("budget").textContent = "Budget: – (the spec is not valid yet; submit to see why).";
      }
    }, 250);
  }

  // The wall time a spec will take at this server's measured rate (app/api/job_overview.py says how).
  function estimateText(e) {
    if (!e) return "";
    return e.wall_s === null || e.wall_s === undefined ? `Wall time: no estimate yet (${e.basis}).`
      : `Estimated wall time: about ${GM.duration(e.wall_s)} (${e.basis}).`;
  }

  // Above the server's threshold the form asks before queueing (the estimate says why).
  let confirmed = false;
  function askFirst(e) {
    $("confirm-text").textContent = `This job is estimated to take about ${GM.duration(e.wall_s)} of worker time, more than `
      + `${GM.duration(e.confirm_above_s)}: ${e.basis}. Submit it anyway?`;
    $("confirm").hidden = false;
    $("confirm-yes").focus();
  }

  function clearErrors() {
    $("form-error").hidden = true;
    for (const e of document.querySelectorAll("#new-job [aria-invalid]")) e.removeAttribute("aria-invalid");
    for (const e of document.querySelectorAll("#new-job .field-error")) e.remove();
  }

  // A field path from the API, e.g. "scenario.tilt.rate_deg_s" (pydantic names the union
  // member) or "damage.lost_legs.0": the closest input that carries it.
  function inputFor(f) {
    const all = [...document.querySelectorAll("#new-job [data-field]")].filter((e) => !e.closest("[hidden]"));
    const parts = f.split(".");
    const candidates = [f];
    for (let i = 1; i < parts.length; i++) candidates.push(parts.filter((_, k) => k !== i).join("."));
    for (const c of candidates) {
      const hit = all.find((e) => e.dataset.field === c);
      if (hit) return hit;
    }
    for (const c of candidates) {
      const hit = all.filter((e) => c.startsWith(`${e.dataset.field}.`)).sort((a, b) => b.dataset.field.length - a.dataset.field.length)[0];
      if (hit) return hit;
    }
    return null;
  }

  function showErrors(err) {
    $("form-error").textContent = err.message;
    $("form-error").hidden = false;
    let first = null;
    for (const fe of err.body.errors || []) {
      const input = inputFor(fe.field || "");
      if (!input) continue;
      const group = input.closest("details");
      if (group) group.open = true;
      input.setAttribute("aria-invalid", "true");
      const msg = el("div", { class: "field-error", id: `${input.id || "damage"}-err`, text: fe.message });
      input.setAttribute("aria-describedby", msg.id);
      input.after(msg);
      first = first || input;
    }
    // focus moves to the first bad field, or to the message itself (focusable: tabindex -1),
    // so a mouse user whose button was disabled meanwhile does not lose their place
    (first || $("form-error")).focus();
  }

  async function submit(e) {
    e.preventDefault();
    clearErrors();
    $("form-ok").hidden = true;
    const spec = specOf();
    $("submit").disabled = true;
    $("confirm").hidden = true;
    try {
      if (!confirmed) { // an invalid spec goes on to POST /api/jobs, whose own message the form shows
        const b = await api("/api/web/check", { method: "POST", json: spec }).catch(() => null);
        if (b && b.estimate && b.estimate.confirm) { askFirst(b.estimate); return; }
      }
      confirmed = false;
      const job = await api("/api/jobs", { method: "POST", json: spec });
      $("form-ok").replaceChildren(`Queued ${job.kind} job `, el("a", { href: `/jobs/${job.id}`, class: "id", text: job.id.slice(0, 8) }),
                                   ". It appears in the list; open it to watch it run.");
      $("form-ok").hidden = false;
      window.gmSubmittedAt = performance.now();
      await refresh(true);
      const row = rows.get(job.id);
      if (row) row.tr.classList.add("fresh");
    } catch (err) {
      $("submit").disabled = false;
      if (err instanceof GM.ApiError) showErrors(err);
      else { $("form-error").textContent = String(err); $("form-error").hidden = false; $("form-error").focus(); }
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

  // What the list shows beside each job (GET /api/web/rows): the kind's list headline and its
  // verdict in brief once succeeded, seed, budget and study, queue position and ETA while
  // queued or running. Finished jobs are asked once; unfinished ones on every refresh.
  const extras = new Map(); // id -> {status, row}

  let extrasBusy = false;
  function extrasSoon() {
    if (extrasBusy) return;
    extrasBusy = true;
    fetchExtras().finally(() => { extrasBusy = false; });
  }

  async function fetchExtras() {
    const want = order.filter((id) => { const e = extras.get(id); return !e || e.status !== rows.get(id).item.status || !FINAL.has(e.status); });
    for (let i = 0; i < want.length; i += 100) {
      const ids = want.slice(i, i + 100);
      let got;
      try { got = await api(`/api/web/rows?ids=${ids.join(",")}`); } catch (e) { return; }
      for (const id of ids) {
        const r = rows.get(id);
        if (r && got[id]) { extras.set(id, { status: r.item.status, row: got[id] }); upsert(r.item); }
      }
    }
  }

  // The kind's list headline (what a user came for, with its unit and direction) and the
  // verdict: target met, the method against its controls, robustness k of n.
  function resultText(item) {
    const x = (extras.get(item.id) || {}).row || {};
    const r = x.headline;
    if (!r) return item.status === "succeeded" ? "…" : "–";
    const v = x.verdict || {};
    const c = v.controls || {};
    const tally = ["beat", "tied", "lost"].filter((w) => c[w]).map((w) => `${w} ${c[w]}`).join(", ");
    return el("div", { title: v.sentence || null },
      el("span", { class: "headline-value" }, `${r.label}: `, el("strong", { text: `${GMViews.show(r.value, 3)}${r.unit ? ` ${r.unit}` : ""}` }),
         r.better ? el("span", { class: "small muted", text: ` (${r.better} better)` }) : null),
      el("div", { class: "verdict-brief small" },
        v.target_met === true ? el("span", { class: "mark met", text: "✓ target" }) : v.target_met === false ? el("span", { class: "mark unmet", text: "✗ target" }) : null,
        tally ? ` vs controls: ${tally}` : "", heldText(v.held_out), v.robustness ? ` · robust ${v.robustness[0]}/${v.robustness[1]}` : ""));
  }

  // the held-out random models first (app/jobs/verdict.py's brief): kept k/n, falls, fragile
  function heldText(h) {
    if (!h) return "";
    const falls = h.fell === null || h.fell === undefined ? "" : `, ${h.fell} fall`;
    return el("span", { class: "held-out", title: h.text }, " · ",
      h.fragile ? el("span", { class: "mark unmet", text: "✗ fragile" }) : null, h.fragile ? " " : "",
      h.judged ? `held-out ${h.met}/${h.judged}${falls}` : `held-out ${h.n} not judged${falls}`);
  }

  function runText(item) {
    const x = (extras.get(item.id) || {}).row || {};
    const parts = [];
    if (x.seed !== null && x.seed !== undefined) parts.push(`seed ${x.seed}`);
    if (x.budget) parts.push(`${x.budget} evals`);
    if (FINAL.has(item.status) && typeof item.wall_s === "number") parts.push(`${GM.duration(item.wall_s)} wall`);
    const q = x.queue;
    if (q && item.status === "queued") parts.push(`queue #${q.position}`);
    if (q && q.eta_s !== null && q.eta_s !== undefined) parts.push(`ETA ${GM.duration(q.eta_s)}`);
    return parts.join(" · ") || "–";
  }

  function studyTag(item) {
    const st = ((extras.get(item.id) || {}).row || {}).study;
    return st ? el("a", { class: "tag", href: `/studies/${st.id}`, title: `point ${st.point} of study ${st.name}` }, `study: ${st.name}`) : null;
  }

  // The job's link; a succeeded job's animated gait shows under it when the link is
  // hovered or focused (rendered by the server on first request: on demand, not per page view).
  function jobCell(item) {
    const link = el("a", { class: "id", href: `/jobs/${item.id}`, text: item.id.slice(0, 8) });
    const cell = el("td", { "data-label": "Job" }, link, studyTag(item));
    if (item.status === "succeeded") {
      let timer = null; // a pointer passing over (or a click on the way) asks the server for nothing
      const show = () => { timer = setTimeout(() => { if (!cell.querySelector(".thumb")) cell.append(GM.thumbnail(item.id)); }, 600); };
      const hide = () => clearTimeout(timer);
      link.addEventListener("mouseenter", show);
      link.addEventListener("focus", show);
      link.addEventListener("mouseleave", hide);
      link.addEventListener("blur", hide);
    }
    return cell;
  }

  function cells(item) {
    const bar = item.status === "running" || item.status === "queued"
      ? el("progress", { max: 1, value: item.progress.fraction, "aria-label": `progress ${progressText(item)}` }) : null;
    const pick = el("input", { type: "checkbox", "aria-label": `pick job ${item.id.slice(0, 8)} to compare`,
                               checked: picked.has(item.id) });
    pick.addEventListener("change", () => { pick.checked ? picked.add(item.id) : picked.delete(item.id); updateCompare(); });
    return [
      el("td", { class: "sel" }, pick),
      jobCell(item),
      el("td", { "data-label": "Kind", text: item.kind }),
      el("td", { "data-label": "Robot", text: robotLabel(item.robot) }),
      el("td", { "data-label": "Damage", text: item.damage || "–" }),
      el("td", { "data-label": "Status" }, badge(item.status), " ",
         el("span", { class: "small muted", text: item.status === "running" ? progressText(item) : "" }), bar),
      el("td", { class: "result", "data-label": "Result" }, resultText(item)),
      el("td", { class: "run small", "data-label": "Run" }, runText(item)),
      el("td", { "data-label": "Age", title: GM.date(item.created_at), text: age(item.created_at) }),
    ];
  }

  function upsert(item) {
    const sig = JSON.stringify([item.status, item.progress, item.damage, age(item.created_at), (extras.get(item.id) || {}).row]);
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
      extrasSoon();
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
      extrasSoon();
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

  async function init() {
    $("new-job").addEventListener("submit", submit);
    $("confirm-yes").addEventListener("click", (e) => { confirmed = true; $("confirm").hidden = true; submit(e); });
    $("confirm-no").addEventListener("click", () => { $("confirm").hidden = true; $("submit").focus(); });
    $("new-job").addEventListener("input", (e) => { if (e.target.id !== "kind" && e.target.id !== "robot") checkSoon(); });
    $("new-job").addEventListener("change", (e) => { if (e.target.type === "checkbox") checkSoon(); });
    $("kind").addEventListener("change", selectKind);
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
    try {
      [kinds, robots] = await Promise.all([api("/api/web/kinds"), api("/api/robots")]);
      $("kind").replaceChildren(...kinds.map((k) => el("option", { value: k.name, text: k.name })));
      $("f-kind").append(...kinds.map((k) => el("option", { text: k.name })));
      $("f-robot").append(...robots.map((r) => el("option", { value: r.builtin === false ? r.id : r.name, text: r.name })));
      const want = new URLSearchParams(location.search).get("kind");
      if (want && kinds.some((k) => k.name === want)) $("kind").value = want;
      selectKind();
    } catch (e) {
      $("form-error").textContent = `Could not load the job kinds or the robot catalog: ${e.message}`;
      $("form-error").hidden = false;
    }
    await refresh(true);
    setInterval(() => { if (!document.hidden) refresh(); }, REFRESH_MS);
  }

  document.addEventListener("DOMContentLoaded", init);
})();
