// Renders what a job's kind supplies (GET /api/jobs/{id}/views): headline rows, tables and
// plotly figures built on the server, and the shared controls / robustness tables. Nothing
// here knows a kind: every label, unit and direction comes with the data.
"use strict";

const GMViews = (() => {
  const { el, num, plot } = GM;

  const isCell = (c) => c !== null && typeof c === "object" && !Array.isArray(c);
  // a headline value in words: numbers rounded, yes / no, lists joined
  const show = (v, digits = 2) => (typeof v === "number" ? num(v, digits) : typeof v === "boolean" ? (v ? "yes" : "no")
    : Array.isArray(v) ? v.map((x) => show(x, digits)).join(", ") : v === null || v === undefined ? "–" : String(v));

  // A value with its unit; a judged cell also says met / not met and better / worse in
  // words (colour alone is not enough), and a worse value is marked as clearly as a better one.
  function cell(c, tag = "td") {
    if (!isCell(c)) {
      return el(tag, { class: typeof c === "number" ? "num" : null, text: typeof c === "number" ? num(c, 3) : c === null || c === undefined ? "–" : String(c) });
    }
    const text = c.text !== undefined ? c.text : typeof c.value === "number" ? num(c.value, 3) : c.value === null || c.value === undefined ? "–" : String(c.value);
    const verdict = c.met !== undefined && (text === "met" || text === "not met");
    const parts = verdict ? [el("span", { class: `mark ${c.met ? "met" : "unmet"}`, text: `${c.met ? "✓" : "✗"} ${text}` })]
      : [el("span", { class: "v", text: c.unit && text !== "–" ? `${text} ${c.unit}` : text })];
    const classes = [typeof c.value === "number" ? "num" : ""];
    if (c.better === true) { parts.push(el("span", { class: "mark better", text: "▲ better" })); classes.push("is-better"); }
    if (c.better === false) { parts.push(el("span", { class: "mark worse", text: "▼ worse" })); classes.push("is-worse"); }
    if (c.met === true && !verdict) parts.push(el("span", { class: "mark met", text: "✓ met" }));
    if (c.met === false && !verdict) parts.push(el("span", { class: "mark unmet", text: "✗ not met" }));
    if (c.note) parts.push(el("div", { class: "cell-note", text: c.note }));
    if (c.met === true) classes.push("is-met");
    if (c.met === false) classes.push("is-unmet");
    // a number to sort the column by (studies.js sorts the verdict over the seeds with it)
    return el(tag, { class: classes.filter(Boolean).join(" ") || null, "data-sort": typeof c.value === "number" ? String(c.value) : null }, parts);
  }

  // a column header: right-aligned over a column of numbers; an unnamed column (the row
  // labels) still named for a screen reader
  const isNum = (c) => typeof c === "number" || (isCell(c) && typeof c.value === "number" && !(c.met !== undefined && c.text));
  const colHead = (name, i, rows) => el("th", { scope: "col", class: i > 0 && rows.length && rows.every((r) => isNum(r[i]) || r[i] === null) ? "num" : null },
    name === "" || name === null || name === undefined ? el("span", { class: "sr-only", text: i === 0 ? "row" : `column ${i + 1}` }) : String(name));

  function table(t, caption) {
    const head = el("thead", {}, el("tr", {}, t.columns.map((c, i) => colHead(c, i, t.rows))));
    const body = el("tbody", {}, t.rows.map((r) => el("tr", {}, r.map((c, i) => (i === 0 ? cell(c, "th") : cell(c))))));
    const out = [el("table", { class: "data" }, caption ? el("caption", { class: "sr-only", text: caption }) : null, head, body)];
    if (t.foot && t.foot.length) {
      out.push(el("table", { class: "data small" }, el("caption", { class: "small muted", style: "text-align:left", text: "Spread over the cases" }),
        el("thead", {}, el("tr", {}, t.foot_columns.map((c, i) => colHead(c, i, t.foot)))),
        el("tbody", {}, t.foot.map((r) => el("tr", {}, r.map((c, i) => (i === 0 ? cell(c, "th") : cell(c))))))));
    }
    return el("div", { class: "table-wrap", tabindex: "0", role: "region", "aria-label": caption ? `${caption}, table` : "table" }, out);
  }

  // Headline rows: {label, value, unit, better, baseline?, baseline_label?, target?, met?}.
  function headline(rows) {
    const hasBase = rows.some((r) => r.baseline !== undefined && r.baseline !== null);
    const hasTarget = rows.some((r) => r.target);
    const cols = ["Quantity", "Value", "Better when"].concat(hasBase ? ["Control", "Against the control"] : [],
                                                             hasTarget ? ["Target", "Met"] : []);
    const fmt = (v, unit) => (v === null || v === undefined ? "–" : `${show(v)}${unit ? ` ${unit}` : ""}`);
    const cmp = (r) => {
      if (typeof r.value !== "number" || typeof r.baseline !== "number" || r.value === r.baseline) return null;
      if (r.better === "higher") return r.value > r.baseline;
      if (r.better === "lower") return r.value < r.baseline;
      if (r.better === "closer to 0") return Math.abs(r.value) < Math.abs(r.baseline);
      return null;
    };
    return el("table", { class: "data headline" },
      el("thead", {}, el("tr", {}, cols.map((c) => el("th", { scope: "col", text: c })))),
      el("tbody", {}, rows.map((r) => {
        const b = cmp(r);
        const tds = [el("th", { scope: "row", text: r.label }),
                     el("td", { class: typeof r.value === "string" && r.value.length > 24 ? "small" : "num big", text: fmt(r.value, r.unit) }),
                     el("td", { class: "small", text: r.better || "–" })];
        if (hasBase) {
          tds.push(el("td", { class: "num", title: r.baseline_label || "control", text: r.baseline === undefined || r.baseline === null ? "–" : `${fmt(r.baseline, r.unit)}${r.baseline_label ? ` (${r.baseline_label})` : ""}` }));
          tds.push(b === null ? el("td", { text: "–" }) : el("td", { class: b ? "is-better" : "is-worse" },
            el("span", { class: `mark ${b ? "better" : "worse"}`, text: b ? "▲ better" : "▼ worse" })));
        }
        if (hasTarget) {
          tds.push(el("td", { text: r.target || "–" }));
          tds.push(r.met === true ? el("td", { class: "is-met" }, el("span", { class: "mark met", text: "✓ met" }))
            : r.met === false ? el("td", { class: "is-unmet" }, el("span", { class: "mark unmet", text: "✗ not met" })) : el("td", { text: "–" }));
        }
        return el("tr", { "data-met": r.met === undefined || r.met === null ? null : String(r.met) }, tds);
      })));
  }

  // One panel: a card with a title, a caption, and a figure or a table.
  function panel(p) {
    const hid = `panel-${p.id}-h`;
    const sec = el("section", { class: "card", id: `panel-${p.id}`, "aria-labelledby": hid, "data-panel": p.id },
      el("h2", { id: hid, text: p.title }));
    if (p.summary && typeof p.summary.met === "number") {
      const all = p.summary.met === p.summary.total;
      sec.append(el("p", { class: `small ${all ? "is-met" : "is-unmet"}` },
        el("span", { class: `mark ${all ? "met" : "unmet"}`, text: `${all ? "✓" : "✗"} ${p.summary.met} of ${p.summary.total} cases meet the target` })));
    }
    if (p.figure) {
      const div = el("div", { class: "plot", id: `plot-${p.id}`, role: "figure", "aria-label": `${p.title}. ${p.caption || ""}` });
      sec.append(div);
      if (p.caption) sec.append(el("p", { class: "small muted caption", text: p.caption }));
      if (p.figure.layout && p.figure.layout.height) div.style.minHeight = `${p.figure.layout.height}px`;
      sec._draw = () => plot(div, p.figure.data, Object.assign({}, p.figure.layout));
    } else if (p.table) {
      if (p.caption) sec.append(el("p", { class: "small muted caption", text: p.caption }));
      sec.append(table(p.table, p.title));
    }
    return sec;
  }

  // Cards go into the page first (plotly sizes a graph by its container), then draw one
  // after another, those on the first screen first, yielding between them so the page
  // stays responsive; each card's _drawn resolves once its plot is drawn.
  function panels(container, list) {
    const secs = list.map(panel);
    container.replaceChildren(...secs);
    const figs = secs.filter((s) => s._draw);
    const near = (s) => s.getBoundingClientRect().top < window.innerHeight * 1.2;
    let chain = Promise.resolve();
    for (const s of [...figs.filter(near), ...figs.filter((x) => !near(x))]) {
      s._drawn = chain = chain.then(() => new Promise((r) => setTimeout(r, 0))).then(() => s._draw())
        .catch((e) => { s.append(el("p", { class: "alert", text: `This plot could not be drawn: ${e.message}` })); });
    }
    return secs;
  }

  return { cell, table, headline, panel, panels, show };
})();
