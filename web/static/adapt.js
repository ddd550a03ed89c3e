// One adaptation session (/adaptations/{id}): the gait to run next (with its download and,
// for the map's best gait, its replay), a form for the measurement that works on a phone,
// the trials in order, the stop decision and why, and the map coloured by its prior and by
// the posterior after the trials (GET /api/adaptations/{id}/views).
"use strict";

(() => {
  const { api, el, num, badge } = GM;
  const $ = (id) => document.getElementById(id);
  const sid = (location.pathname.match(/^\/adaptations\/([0-9a-f]+)/) || [])[1];
  const errBox = $("ad-error");
  const form = $("trial-form");
  let current = null;

  function showError(e) {
    errBox.hidden = false;
    const b = e && e.body;
    const fields = b && b.errors && b.errors.length ? b.errors.map((x) => `${x.field}: ${x.message}`).join("; ") : null;
    errBox.textContent = fields || (b && b.detail) || String((e && e.message) || e);
    form.querySelectorAll("[aria-invalid]").forEach((i) => i.removeAttribute("aria-invalid"));
    for (const x of (b && b.errors) || []) {
      const input = $(x.field);
      if (input) input.setAttribute("aria-invalid", "true");
    }
  }

  function nextGait(s) {
    const n = s.next;
    if (!n) return el("p", { id: "next-none", text: "No more trials: the session has stopped (see why above)." });
    const page = `/jobs/${n.job}`;
    return el("div", {},
      el("p", { id: "next-gait", class: "lead" },
        `Trial ${n.trial}: run elite ${n.elite} (cell ${n.cell}) of map “${n.map}” for ${num(n.trial_s, 3)} s.`),
      el("p", { class: "small" }, `Predicted ${num(n.predicted_m_s, 3)} m/s ± ${num(n.std, 3)} `
        + `(about ${num(n.predicted_forward_m, 3)} m forward over the trial); the map alone said ${num(n.prior_m_s, 3)} m/s.`),
      el("p", { class: "actions" },
        el("button", { type: "button", class: "secondary", id: "next-download", text: "Download the gait (set-points, controller)",
          onclick: () => GM.download(`/api/adaptations/${sid}/proposals/${n.trial}/bundle`,
            `adaptation-${sid.slice(0, 12)}-trial${n.trial}.zip`).catch(showError) }),
        " ",
        el("a", { href: page, id: "next-replay",
          text: n.map_best ? "Replay this gait (the map's best, on its job page)" : "The map's job page (its replay shows the map's best gait)" })));
  }

  function trialsTable(s) {
    if (!s.trials.length) return el("p", { class: "small muted", text: "No trial yet." });
    const heads = ["#", "Gait", "Forward (m)", "Lateral (m)", "Yaw (deg)", "Fell", "Duration (s)", "Speed (m/s)", "Predicted (m/s)", "Recovered", "Note"];
    return el("div", { class: "table-wrap", tabindex: "0", role: "region", "aria-label": "Trials" },
      el("table", { class: "data", id: "trials" },
        el("thead", {}, el("tr", {}, heads.map((h) => el("th", { scope: "col", text: h })))),
        el("tbody", {}, s.trials.map((t) => el("tr", {},
          el("td", { class: "num", text: String(t.trial) }), el("td", { text: `${t.map} #${t.elite}` }),
          el("td", { class: "num", text: num(t.forward_m, 3) }), el("td", { class: "num", text: num(t.lateral_m, 3) }),
          el("td", { class: "num", text: num(t.yaw_deg, 1) }), el("td", { text: t.fell ? "yes" : "no" }),
          el("td", { class: "num", text: num(t.duration_s, 2) }), el("td", { class: "num", text: num(t.speed_m_s, 3) }),
          el("td", { class: "num", text: num(t.predicted_m_s, 3) }),
          el("td", { text: t.recovered === null ? "–" : t.recovered ? "yes" : "no" }), el("td", { text: t.note || "" }))))));
  }

  function render(s) {
    current = s;
    document.title = `gaitmend · adaptation ${s.name || s.id.slice(0, 8)}`;
    const target = s.target_m_s === null ? "" : `; recovered: ≥ ${num(s.target_m_s, 3)} m/s without falling`;
    $("ad-status").replaceChildren(badge(s.status === "open" ? "running" : "succeeded"), ` ${s.status} · ${s.method} · `
      + `${s.trials_done} trial${s.trials_done === 1 ? "" : "s"} of at most ${s.spec.stop.max_trials}`
      + ` · maps: ${s.maps.map((m) => `${m.name} (${m.elites} elites)`).join(", ")}${target}`);
    const d = s.decision;
    $("ad-decision").replaceChildren(el("strong", { id: "stop-decision", text: d.stop ? "Stop." : "Go on." }), " ",
      el("span", { id: "stop-why", text: d.reason }));
    $("next-body").replaceChildren(nextGait(s));
    form.hidden = !s.next;
    if (s.next) {
      $("trial-legend").textContent = `Measured on trial ${s.next.trial}`;
      if (!$("duration_s").value) $("duration_s").value = String(s.next.trial_s);
    }
    $("trials-body").replaceChildren(trialsTable(s));
  }

  async function drawMap() {
    const body = $("map-body");
    const r = await api(`/api/adaptations/${sid}/views`);
    body.replaceChildren(...r.panels.map((p) => el("figure", { class: "panel", id: `panel-${p.id}` },
      el("figcaption", {}, el("strong", { text: p.title }), el("div", { class: "small muted", text: p.caption })),
      el("div", { class: "plot", id: `plot-${p.id}` }))));
    for (const p of r.panels) await GM.plot($(`plot-${p.id}`), p.figure.data, p.figure.layout);
  }

  async function load() {
    render(await api(`/api/adaptations/${sid}`));
    await drawMap();
  }

  form.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    errBox.hidden = true;
    const v = (id) => $(id).value.trim();
    const number = (id) => (v(id) === "" ? null : Number(v(id)));
    const body = { trial: current.next.trial, forward_m: number("forward_m"), lateral_m: number("lateral_m"),
      yaw_deg: number("yaw_deg"), fell: $("fell").checked, duration_s: number("duration_s"), note: v("note") };
    const button = $("trial-submit");
    button.disabled = true;
    try {
      render(await api(`/api/adaptations/${sid}/trials`, { method: "POST", json: body }));
      for (const id of ["forward_m", "note"]) $(id).value = "";
      form.querySelectorAll("[aria-invalid]").forEach((i) => i.removeAttribute("aria-invalid"));
      $("fell").checked = false;
      $("next").scrollIntoView({ block: "start" });
      await drawMap();
    } catch (e) {
      showError(e);
    } finally {
      button.disabled = false;
    }
  });

  if (sid) load().catch(showError);
})();
