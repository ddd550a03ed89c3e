// A job-spec form generated from a kind's JSON schema (GET /api/web/kinds): every field of
// every kind, with its bounds as the browser's hints; the API still validates and its
// message is shown inline. The kind may name the groups to open first ("open"); the rest sit
// in collapsed groups. Each field starts at its default (the schema carries those made by a
// default factory too); a field left at it, or emptied, is left out of the spec.
"use strict";

const SpecForm = (() => {
  const { el } = GM;
  const UNITS = [["_deg_s", "°/s"], ["_deg", "°"], ["_s", "s"], ["_mu", "mu"], ["_m", "m"], ["_pct", "%"], ["_n", "N"], ["_kg", "kg"]];

  function deref(schema, root) {
    let s = schema;
    for (let i = 0; s && s.$ref && i < 20; i++) s = root.$defs[s.$ref.split("/").pop()];
    return s || {};
  }

  // anyOf [X, null] -> X with nullable; a discriminated oneOf stays a union
  function unwrap(schema, root) {
    const s = deref(schema, root);
    const alts = s.anyOf || (s.oneOf && !s.discriminator ? s.oneOf : null);
    if (alts) {
      const real = alts.filter((a) => a.type !== "null");
      if (real.length === 1) return Object.assign({}, deref(real[0], root), { default: s.default, title: s.title, description: s.description, nullable: true });
    }
    return s;
  }

  function labelOf(name, s) {
    let text = name.replace(/_/g, " ");
    let unit = "";
    for (const [suf, u] of UNITS) if (name.endsWith(suf)) { text = name.slice(0, -suf.length).replace(/_/g, " "); unit = u; break; }
    text = text.charAt(0).toUpperCase() + text.slice(1);
    return unit ? `${text} (${unit})` : text;
  }

  const idOf = (path) => `f-${path.replace(/[^a-zA-Z0-9]+/g, "-")}`;

  function hintOf(s) {
    const b = [];
    if (s.minimum !== undefined) b.push(`≥ ${s.minimum}`);
    if (s.exclusiveMinimum !== undefined) b.push(`> ${s.exclusiveMinimum}`);
    if (s.maximum !== undefined) b.push(`≤ ${s.maximum}`);
    if (s.exclusiveMaximum !== undefined) b.push(`< ${s.exclusiveMaximum}`);
    if (s.minItems !== undefined || s.maxItems !== undefined) b.push(`${s.minItems ?? 0}–${s.maxItems ?? "∞"} items`);
    return b.join(", ");
  }

  // One input for a scalar or a small list; returns {node, read()} where read() gives
  // undefined for "left at the default".
  function scalar(name, path, schema, root) {
    const s = unwrap(schema, root);
    const id = idOf(path);
    const label = el("label", { for: id, text: labelOf(name, s) });
    const hint = hintOf(s);
    const help = [s.description, hint && `allowed: ${hint}`].filter(Boolean).join(" · ");
    const helpEl = help ? el("div", { class: "small muted", id: `${id}-help`, text: help }) : null;
    let input, read;
    const def = s.default;
    if (s.enum || (s.type === "string" && s.const === undefined && s.enum)) {
      input = el("select", { id });
      if (s.nullable || def === undefined) input.append(el("option", { value: "", text: def === undefined || def === null ? "(default)" : `(default: ${def})` }));
      for (const v of s.enum) input.append(el("option", { value: String(v), text: String(v), selected: v === def && !s.nullable ? true : null }));
      read = () => (input.value === "" || input.value === String(def) ? undefined : input.value);
    } else if (s.type === "boolean") {
      input = el("input", { id, type: "checkbox", checked: def === true ? true : null });
      const row = el("div", { class: "field check", "data-path": path }, input, el("label", { for: id, text: labelOf(name, s) }), helpEl);
      input.dataset.field = path;
      if (helpEl) input.setAttribute("aria-describedby", helpEl.id);
      return { node: row, read: () => (input.checked === (def === true) ? undefined : input.checked), input };
    } else if (s.type === "integer" || s.type === "number") {
      input = el("input", { id, type: "number", inputmode: s.type === "integer" ? "numeric" : "decimal", step: s.type === "integer" ? "1" : "any",
                            value: def === null || def === undefined ? "" : String(def), placeholder: def === null || def === undefined ? "default" : null });
      read = () => {
        const t = input.value.trim();
        if (t === "" || Number(t) === def) return undefined;
        return Number.isFinite(Number(t)) ? Number(t) : t; // let the API name a bad value
      };
    } else if (s.type === "array" || s.type === "object" || s.additionalProperties) {
      const flat = s.type === "array" && s.items && ["integer", "number"].includes(deref(s.items, root).type);
      input = el("input", { id, type: "text", autocomplete: "off", spellcheck: "false",
                            placeholder: flat ? "e.g. 1, 3, 5 (empty: default)" : "JSON (empty: default)",
                            value: def === undefined || def === null ? "" : flat ? def.join(", ") : JSON.stringify(def) });
      read = () => {
        const t = input.value.trim();
        if (t === "" || (def !== undefined && t === (flat ? (def || []).join(", ") : JSON.stringify(def)))) return undefined;
        if (flat) {
          const parts = t.replace(/^\[|\]$/g, "").split(/[\s,]+/).filter(Boolean);
          return parts.every((p) => Number.isFinite(Number(p))) ? parts.map(Number) : t;
        }
        try { return JSON.parse(t); } catch (e) { return t; }
      };
    } else {
      input = el("input", { id, type: "text", autocomplete: "off", value: def === undefined || def === null ? "" : String(def),
                            placeholder: def === undefined || def === null ? "default" : null });
      read = () => (input.value.trim() === "" || input.value.trim() === def ? undefined : input.value.trim());
    }
    input.dataset.field = path;
    if (helpEl) input.setAttribute("aria-describedby", helpEl.id);
    return { node: el("div", { class: "field", "data-path": path }, label, input, helpEl), read, input };
  }

  // An object's fields; a discriminated union gets a select for its variant.
  function object(schema, root, path, opts) {
    const s = unwrap(schema, root);
    const readers = [];
    const nodes = [];
    for (const [name, sub0] of Object.entries(s.properties || {})) {
      const p = path ? `${path}.${name}` : name;
      if (opts.skip && opts.skip.includes(p)) continue;
      const sub = unwrap(sub0, root);
      if (sub.const !== undefined) continue; // kind, variant tags: fixed
      if (sub.oneOf && sub.discriminator) {
        const u = union(name, p, sub, root, opts);
        nodes.push(u.node);
        readers.push([name, u.read]);
      } else if (sub.type === "object" && sub.properties) {
        const inner = object(sub, root, p, opts);
        const open = (opts.open || []).some((o) => o === p || o.startsWith(`${p}.`));
        const box = el("details", { class: "group", open: open ? true : null, "data-path": p },
          el("summary", { text: labelOf(name, sub) }), sub.description ? el("p", { class: "small muted", text: sub.description }) : null,
          el("div", { class: "row" }, inner.nodes));
        nodes.push(box);
        readers.push([name, inner.read]);
      } else {
        const f = scalar(name, p, sub0, root);
        nodes.push(f.node);
        readers.push([name, f.read]);
      }
    }
    const read = () => {
      const out = {};
      for (const [k, r] of readers) {
        const v = r();
        if (v !== undefined && !(v && typeof v === "object" && !Array.isArray(v) && !Object.keys(v).length)) out[k] = v;
      }
      return out;
    };
    return { nodes, read };
  }

  function union(name, path, s, root, opts) {
    const key = s.discriminator.propertyName;
    const variants = s.oneOf.map((v) => deref(v, root));
    const tags = variants.map((v) => v.properties[key].const);
    const id = idOf(`${path}.${key}`);
    const select = el("select", { id, "data-field": `${path}.${key}` }, tags.map((t) => el("option", { value: t, text: t })));
    const body = el("div", { class: "row" });
    const holder = el("fieldset", { class: "group union", "data-path": path },
      el("legend", { text: labelOf(name, s) }),
      el("div", { class: "field" }, el("label", { for: id, text: `${labelOf(name, s)}: ${key}` }), select), body);
    let cur = null;
    const show = () => {
      const v = variants[tags.indexOf(select.value)];
      cur = object(v, root, path, opts);
      body.replaceChildren(...(v.description ? [el("p", { class: "small muted", style: "grid-column:1/-1", text: v.description })] : []), ...cur.nodes);
    };
    select.addEventListener("change", () => { show(); opts.onChange && opts.onChange(); });
    show();
    return { node: holder, read: () => Object.assign({ [key]: select.value }, cur.read()) };
  }

  // build(container, kind) -> {read(): spec}; opts.skip: paths drawn elsewhere (robot, damage picker)
  function build(container, kind, opts = {}) {
    const root = kind.schema;
    const o = object(root, root, "", { open: kind.open || [], skip: opts.skip || [], onChange: opts.onChange });
    container.replaceChildren(...o.nodes);
    return { read: () => Object.assign({ kind: kind.name }, o.read()) };
  }

  return { build, unwrap, deref };
})();
