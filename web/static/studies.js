// Studies list (/studies) and one study (/studies/{id}): progress, aggregate, job links.
(() => {
  const { api, el, num, badge } = GM;
  const body = document.getElementById("st-body");
  const errBox = document.getElementById("st-error");
  const id = (location.pathname.match(/^\/studies\/([0-9a-f]+)/) || [])[1];
  const showError = (e) => { errBox.hidden = false; errBox.textContent = (e.body && e.body.detail) || String(e); };
  const cell = (st) => st.n ? `${num(st.median)} [${num(st.min)}, ${num(st.max)}]` : "–";
  const progress = (p) => `${p.done}/${p.points} done, ${p.running} running, ${p.failed} failed, ${p.cancelled} cancelled`;

  async function list() {
    const r = await api("/api/studies");
    body.replaceChildren(el("table", { class: "jobs" },
      el("thead", {}, el("tr", {}, ["Study", "Status", "Progress", "Created"].map((h) => el("th", { text: h })))),
      el("tbody", {}, r.items.map((s) => el("tr", {},
        el("td", {}, el("a", { href: `/studies/${s.id}`, text: s.name })), el("td", {}, badge(s.status)),
        el("td", { text: progress(s.progress) }), el("td", { text: s.created_at }))))));
  }

  async function one() {
    const s = await api(`/api/studies/${id}`);
    const a = s.aggregate;
    const head = [...a.group_by, "done/points", ...a.metrics.map((m) => `${m} median [min, max]`)];
    body.replaceChildren(
      el("h2", { text: s.name }), el("p", {}, badge(s.status), " ", progress(s.progress), " · ",
        el("a", { href: s.links.bundle, text: "study bundle" })),
      s.status === "running" || s.status === "queued" ? el("button", { class: "secondary", onclick: async () => {
        await api(`/api/studies/${id}/cancel`, { method: "POST" }).catch(showError); one(); }, text: "Cancel unfinished points" }) : null,
      el("table", { class: "jobs", id: "aggregate" }, el("thead", {}, el("tr", {}, head.map((h) => el("th", { text: h })))),
        el("tbody", {}, a.rows.map((r) => el("tr", {}, r.group.map((g) => el("td", { text: JSON.stringify(g) })),
          el("td", { text: `${r.succeeded}/${r.points}` }), a.metrics.map((m) => el("td", { text: cell(r.metrics[m]) })))))),
      s.infeasible.length ? el("p", { class: "small muted", text: `Infeasible, listed and never run: ${s.infeasible.map((x) => JSON.stringify(x.overrides)).join(", ")}` }) : null,
      el("div", { id: "study-views" }),
      el("h3", { text: "Points" }),
      el("ul", {}, s.jobs.map((j) => el("li", {}, el("a", { href: `/jobs/${j.id}`, text: JSON.stringify(j.overrides) }), " ", badge(j.status),
        j.error ? ` ${j.error}` : ""))));
    const v = await api(s.links.views);
    GMViews.panels(document.getElementById("study-views"), v.panels);
    if (s.status === "running" || s.status === "queued") setTimeout(() => one().catch(showError), 3000);
  }

  // The built-in studies come from the kinds (GET /api/studies/builtin): the page names none.
  const builtin = document.getElementById("builtin");
  const submitBuiltin = document.querySelector("#builtin-form button[type=submit]");
  async function builtins() {
    const r = await api("/api/studies/builtin");
    builtin.replaceChildren(...r.items.map((b) => el("option", { value: b.name, title: b.title, text: b.name })));
    submitBuiltin.disabled = !r.items.length;
  }

  document.getElementById("builtin-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    if (!builtin.value) return;
    try {
      const spec = await api(`/api/studies/builtin/${encodeURIComponent(builtin.value)}`);
      const s = await api("/api/studies", { method: "POST", json: spec });
      location.href = `/studies/${s.id}`;
    } catch (e) { showError(e); }
  });
  builtins().catch(showError);
  (id ? one() : list()).catch(showError);
})();
