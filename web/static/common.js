// Shared by every dashboard page: API calls (with an optional bearer token), formatting,
// server-sent events read through fetch (so the token can ride in a header), plot defaults,
// and the colour table (app/core/colors.py, which the server puts in every page's head).
"use strict";

const GM = (() => {
  const TOKEN_KEY = "gaitmend.token";
  const FINAL = new Set(["succeeded", "failed", "cancelled"]);
  const TABLE = (() => {
    try { return JSON.parse(document.getElementById("gm-colors").textContent); } catch (e) { return {}; }
  })();
  const ROLES = TABLE.roles || {};
  const PALETTE = TABLE.palette || [];
  // history column -> colour (best, mean, worst ...), by the role the table gives each
  const COLORS = Object.fromEntries(Object.entries(TABLE.history || {}).map(([col, role]) => [col, ROLES[role]]));
  // ... and its line [dash, width] (the bundle's convergence figure draws the same: colors.history_styles)
  const HISTORY_LINES = TABLE.history_lines || {};

  const token = () => localStorage.getItem(TOKEN_KEY) || "";
  const authHeaders = () => (token() ? { Authorization: `Bearer ${token()}` } : {});

  class ApiError extends Error {
    constructor(status, body) {
      super((body && body.detail) || `HTTP ${status}`);
      this.status = status;
      this.body = body || {};
    }
  }

  async function api(path, opts = {}) {
    const headers = Object.assign({ Accept: "application/json" }, authHeaders(), opts.headers || {});
    if (opts.json !== undefined) {
      headers["Content-Type"] = "application/json";
      opts = Object.assign({}, opts, { body: JSON.stringify(opts.json) });
    }
    const r = await fetch(path, Object.assign({}, opts, { headers }));
    const type = r.headers.get("content-type") || "";
    const body = type.includes("json") ? await r.json().catch(() => null) : null;
    if (!r.ok) {
      if (r.status === 401) showAuth(body && body.detail);
      throw new ApiError(r.status, body);
    }
    return body;
  }

  // Reads a text/event-stream with fetch; calls onEvent(name, data). Resolves when the
  // stream closes (the server sends `end` last), rejects on network errors.
  async function events(path, onEvent, signal) {
    const r = await fetch(path, { headers: Object.assign({ Accept: "text/event-stream" }, authHeaders()), signal });
    if (!r.ok || !r.body) throw new ApiError(r.status, await r.json().catch(() => null));
    const reader = r.body.getReader();
    const dec = new TextDecoder();
    let buf = "";
    for (;;) {
      const { value, done } = await reader.read();
      if (done) return;
      buf += dec.decode(value, { stream: true });
      let i;
      while ((i = buf.indexOf("\n\n")) >= 0) {
        const block = buf.slice(0, i);
        buf = buf.slice(i + 2);
        let name = "message";
        const data = [];
        for (const line of block.split("\n")) {
          if (line.startsWith("event:")) name = line.slice(6).trim();
          else if (line.startsWith("data:")) data.push(line.slice(5).trimStart());
        }
        if (data.length) onEvent(name, JSON.parse(data.join("\n")));
      }
    }
  }

  function el(tag, attrs = {}, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs)) {
      if (v === null || v === undefined || v === false) continue;
      if (k === "class") e.className = v;
      else if (k === "text") e.textContent = v;
      else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
      else e.setAttribute(k, v === true ? "" : v);
    }
    for (const c of children.flat()) if (c !== null && c !== undefined) e.append(c.nodeType ? c : String(c));
    return e;
  }

  function num(v, digits = 3) {
    if (v === null || v === undefined || Number.isNaN(v)) return "–";
    if (typeof v !== "number") return String(v);
    if (Number.isInteger(v)) return String(v);
    const a = Math.abs(v);
    if (a !== 0 && (a < 1e-3 || a >= 1e5)) return v.toExponential(2);
    return v.toFixed(digits);
  }

  function age(iso) {
    const s = (Date.now() - Date.parse(iso)) / 1000;
    if (!Number.isFinite(s)) return "–";
    if (s < 60) return `${Math.max(0, Math.round(s))} s ago`;
    if (s < 3600) return `${Math.round(s / 60)} min ago`;
    if (s < 86400) return `${Math.round(s / 3600)} h ago`;
    return `${Math.round(s / 86400)} d ago`;
  }

  function badge(status) {
    return el("span", { class: `badge ${status}`, text: status });
  }

  function progressText(job) {
    const p = job.progress || {};
    if (!p.total) return job.status === "queued" ? "waiting for a worker" : "";
    return `${p.done}/${p.total} (${Math.round(100 * p.fraction)} %)`;
  }

  // Plotly is loaded only by a page that draws a plot, once, after the page's own content:
  // its cartesian bundle (scatter, bar, heatmap: 1.5 MB unpacked) unless the page draws other
  // traces (polar, 3D), then the full one (4.8 MB); the server names both versioned URLs in
  // the head (gm-plotly-cartesian, gm-plotly). Both are the same plotly.js release.
  const CARTESIAN = new Set(["scatter", "bar", "heatmap"]);
  const plotlyLoads = {};
  let fullPlotly = null; // once the full bundle ran, a cartesian one arriving later does not replace it
  function loadPlotly(types = []) {
    const which = types.every((t) => CARTESIAN.has(t || "scatter")) ? "cartesian" : "full";
    if (fullPlotly) return Promise.resolve(fullPlotly);
    if (which === "cartesian" && plotlyLoads.full) return plotlyLoads.full;
    if (!plotlyLoads[which]) {
      plotlyLoads[which] = new Promise((resolve, reject) => {
        const meta = document.querySelector(`meta[name="${which === "full" ? "gm-plotly" : "gm-plotly-cartesian"}"]`);
        const s = document.createElement("script");
        s.src = meta ? meta.content : `/vendor/plotly${which === "full" ? "" : "-cartesian"}.min.js`;
        s.onload = () => {
          if (which === "full") fullPlotly = window.Plotly;
          else if (fullPlotly) window.Plotly = fullPlotly;
          performance.mark("gm-plotly");
          resolve(window.Plotly);
        };
        s.onerror = () => { plotlyLoads[which] = null; reject(new Error(`${s.src} did not load`)); };
        document.head.append(s);
      });
    }
    return plotlyLoads[which];
  }

  const narrow = () => window.matchMedia("(max-width: 700px)").matches;

  // On a phone a long axis title ("coverage (% of map cells), higher better") outgrew its axis: cut
  // off at the ends, and a y title reached up into the legend. Such a title goes on two lines there
  // (at its last comma, else its middle space), with room made for it (automargin).
  function phoneTitles(layout) {
    if (!narrow()) return layout;
    for (const [k, ax] of Object.entries(layout)) {
      const t = /^[xy]axis\d*$/.test(k) && ax && ax.title;
      const text = t && (typeof t === "string" ? t : t.text);
      if (!text || text.length <= 28 || text.includes("<br>")) continue;
      let at = text.lastIndexOf(", ") + 1;
      if (at <= 0) at = text.indexOf(" ", Math.floor(text.length / 2));
      if (at <= 0) continue;
      const two = `${text.slice(0, at).trimEnd()}<br>${text.slice(at).trimStart()}`;
      const title = { ...(typeof t === "string" ? {} : t), text: two, font: { size: 12 } };
      layout[k] = { ...ax, automargin: true, title };
    }
    layout.legend = { font: { size: 11 }, ...layout.legend }; // shorter rows leave the plot more height
    return layout;
  }

  // Plotly with the same look everywhere; responsive, no logo, hover on. On a phone the
  // toolbar is off (it covered the legends); pinch and the legend still work. Resolves once
  // drawn (the div then carries data-rendered="1").
  async function plot(div, traces, layout = {}) {
    const base = {
      margin: { l: 56, r: 16, t: 36, b: 44 }, font: { family: "system-ui, sans-serif", size: 13, color: "#18202b" },
      paper_bgcolor: "#ffffff", plot_bgcolor: "#ffffff", hovermode: "x unified",
      legend: { orientation: "h", y: 1.02, yanchor: "bottom", x: 0 },
      xaxis: { gridcolor: "#e3e8ee", zerolinecolor: "#b9c2cf" }, yaxis: { gridcolor: "#e3e8ee", zerolinecolor: "#b9c2cf" },
    };
    const P = await loadPlotly(traces.map((t) => t.type));
    if (div.classList.contains("plot-empty")) { // a placeholder text, not a graph yet
      div.classList.remove("plot-empty");
      div.textContent = "";
    }
    const out = await P.react(div, traces, phoneTitles(Object.assign(base, layout)),
      { responsive: true, displaylogo: false, displayModeBar: narrow() ? false : "hover",
        modeBarButtonsToRemove: ["lasso2d", "select2d"] });
    div.dataset.rendered = "1";
    return out;
  }

  function empty(div, text) {
    if (div.data && window.Plotly) window.Plotly.purge(div);
    div.classList.add("plot-empty");
    div.textContent = text;
  }

  // Durations and dates as a person reads them (a number and its unit never split over two
  // lines: a no-break space between them).
  function duration(s) {
    if (s === null || s === undefined || !Number.isFinite(s)) return "–";
    if (s < 90) return `${Math.max(1, Math.round(s))}\u00a0s`;
    if (s < 5400) return `${Math.round(s / 60)}\u00a0min`;
    if (s < 172800) return `${(s / 3600).toFixed(1)}\u00a0h`;
    return `${(s / 86400).toFixed(1)}\u00a0days`;
  }
  function date(iso) {
    const t = Date.parse(iso);
    return Number.isFinite(t) ? new Date(t).toLocaleString(undefined, { dateStyle: "medium", timeStyle: "short" }) : "–";
  }

  // Header: an API token box, shown when the server asks for one (non-loopback servers).
  function showAuth(message) {
    const box = document.getElementById("auth");
    if (!box) return;
    box.hidden = false;
    const msg = box.querySelector(".auth-msg");
    if (msg && message) msg.textContent = message;
  }

  function initAuth() {
    const box = document.getElementById("auth");
    if (!box) return;
    const input = box.querySelector("input");
    input.value = token();
    box.hidden = !token();
    box.querySelector("form").addEventListener("submit", (e) => {
      e.preventDefault();
      if (input.value.trim()) localStorage.setItem(TOKEN_KEY, input.value.trim());
      else localStorage.removeItem(TOKEN_KEY);
      location.reload();
    });
  }

  // A download that carries the token when one is set (an <a href> cannot send headers).
  async function download(path, filename) {
    if (!token()) {
      location.href = path;
      return;
    }
    const r = await fetch(path, { headers: authHeaders() });
    if (!r.ok) throw new ApiError(r.status, await r.json().catch(() => null));
    const url = URL.createObjectURL(await r.blob());
    const a = el("a", { href: url, download: filename });
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  }

  // A job's animated gait thumbnail (WebP; the server renders it on the first request and
  // keeps it with the bundle). With a token the picture is fetched with it (an <img src>
  // cannot send headers); a job without one (nothing to replay) shows nothing.
  function thumbnail(jobId, alt) {
    const img = el("img", { class: "thumb", width: 240, height: 136, alt: alt || `gait of job ${jobId.slice(0, 8)}` });
    img.addEventListener("error", () => img.remove());
    const path = `/api/jobs/${jobId}/thumbnail`;
    if (!token()) img.src = path;
    else fetch(path, { headers: authHeaders() }).then((r) => (r.ok ? r.blob() : Promise.reject(r.status)))
      .then((b) => { img.src = URL.createObjectURL(b); }).catch(() => img.remove());
    return img;
  }

  document.addEventListener("DOMContentLoaded", initAuth);
  return { api, events, el, num, age, badge, progressText, plot, empty, download, thumbnail, token, authHeaders,
           ApiError, FINAL, COLORS, HISTORY_LINES, PALETTE, ROLES, loadPlotly, duration, date, narrow };
})();
