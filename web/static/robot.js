// Top view of a robot from /api/robots: click a leg to mark it lost, or a leg segment to
// lock that joint. Keyboard: every leg is a button (Enter/Space); in "locked joint" mode
// Enter steps through coxa, femur, tibia, none. It starts from `initial` ({lost_legs,
// locked_joints}, the spec's default damage), so it shows what an untouched form runs.
"use strict";

const RobotPicker = (() => {
  const NS = "http://www.w3.org/2000/svg";
  const JOINTS = ["coxa", "femur", "tibia"];
  const S = 900; // px per metre

  function svg(tag, attrs = {}) {
    const e = document.createElementNS(NS, tag);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
    return e;
  }

  function create(container, robot, onChange, initial = {}) {
    const hips = robot.hips_m;
    const legs = robot.legs;
    const mine = (leg) => legs.includes(Number(leg));
    const state = {
      lost: new Set((initial.lost_legs || []).map(Number).filter(mine)),
      locked: new Map((initial.locked_joints || []).filter((j) => mine(j.leg) && JOINTS.includes(j.joint))
        .map((j) => [`${Number(j.leg)}.${j.joint}`, j.angle_deg ?? 0])),
      mode: "lost",
    };
    const [l1, l2, l3] = robot.link_lengths_m;
    const seg = [l1, l2 * 0.95, l3 * 0.6]; // lengths seen from above at the nominal stance
    const reach = seg.reduce((a, b) => a + b, 0);
    const xs = legs.map((l) => hips[l][0]), ys = legs.map((l) => hips[l][1]);
    const halfW = Math.max(...xs.map(Math.abs)) + reach + 0.06, halfH = Math.max(...ys.map(Math.abs)) + reach * 0.6 + 0.04;
    const root = svg("svg", { viewBox: `${-halfW * S} ${-halfH * S} ${2 * halfW * S} ${2 * halfH * S}`, class: "robot-svg",
                              role: "group", "aria-label": `${robot.name} seen from above, front at the top` });
    const order = [...legs].sort((a, b) => Math.atan2(-hips[a][1], hips[a][0]) - Math.atan2(-hips[b][1], hips[b][0]));
    root.append(svg("polygon", { class: "body", points: order.map((l) => `${hips[l][0] * S},${-hips[l][1] * S}`).join(" ") }));
    const front = svg("text", { class: "front", x: 0, y: (-Math.max(...ys) * S) + 40 });
    front.textContent = "▲ front";
    root.append(front);
    const groups = {};
    for (const leg of legs) {
      const [hx, hy] = hips[leg];
      const side = hx < 0 ? -1 : 1;
      const tilt = hy > 0.01 ? 0.5 : hy < -0.01 ? -0.5 : 0; // front legs splay forward, rear backward
      const dir = [side * Math.cos(tilt), Math.sin(tilt)];
      const pts = [[hx, hy]];
      for (const L of seg) { const p = pts[pts.length - 1]; pts.push([p[0] + dir[0] * L, p[1] + dir[1] * L]); }
      const P = pts.map(([x, y]) => [x * S, -y * S]);
      const sideName = robot.leg_sides ? robot.leg_sides[String(leg)] : (side < 0 ? "left" : "right");
      const g = svg("g", { class: "leg", "data-leg": leg, tabindex: 0, role: "button", "aria-pressed": "false" });
      g.dataset.side = sideName;
      g.append(svg("line", { class: "hit", x1: P[0][0], y1: P[0][1], x2: P[3][0], y2: P[3][1] }));
      JOINTS.forEach((j, i) => {
        const line = svg("line", { class: "seg", "data-joint": j, x1: P[i][0], y1: P[i][1], x2: P[i + 1][0], y2: P[i + 1][1] });
        line.addEventListener("click", (e) => { if (state.mode === "lock") { e.stopPropagation(); toggleLock(leg, j); } });
        g.append(line);
      });
      JOINTS.forEach((j, i) => g.append(svg("circle", { class: "joint", "data-joint": j, cx: P[i][0], cy: P[i][1], r: 10 })));
      g.append(svg("circle", { class: "foot", cx: P[3][0], cy: P[3][1], r: 12 }));
      const t = svg("text", { x: P[3][0] + dir[0] * 34, y: P[3][1] - dir[1] * 34 });
      t.textContent = leg;
      g.append(t);
      g.addEventListener("click", () => (state.mode === "lost" ? toggleLost(leg) : stepLock(leg)));
      g.addEventListener("keydown", (e) => {
        if (e.key === "Enter" || e.key === " ") { e.preventDefault(); g.dispatchEvent(new MouseEvent("click")); }
      });
      groups[leg] = g;
      root.append(g);
    }
    container.replaceChildren(root);

    function toggleLost(leg) {
      if (state.lost.has(leg)) state.lost.delete(leg);
      else {
        state.lost.add(leg);
        for (const j of JOINTS) state.locked.delete(`${leg}.${j}`);
      }
      render();
    }
    function toggleLock(leg, joint) {
      const k = `${leg}.${joint}`;
      if (state.locked.has(k)) state.locked.delete(k);
      else { state.lost.delete(leg); state.locked.set(k, 0); }
      render();
    }
    function stepLock(leg) { // keyboard and clicks off a segment: none -> coxa -> femur -> tibia -> none
      const cur = JOINTS.findIndex((j) => state.locked.has(`${leg}.${j}`));
      for (const j of JOINTS) state.locked.delete(`${leg}.${j}`);
      if (cur < JOINTS.length - 1) { state.lost.delete(leg); state.locked.set(`${leg}.${JOINTS[cur + 1]}`, 0); }
      render();
    }
    function label(leg) {
      const g = groups[leg];
      const locks = JOINTS.filter((j) => state.locked.has(`${leg}.${j}`));
      const what = state.lost.has(leg) ? "lost" : locks.length ? `${locks.join(", ")} locked` : "working";
      return `Leg ${leg} (${g.dataset.side}): ${what}`;
    }
    function render() {
      for (const leg of legs) {
        const g = groups[leg];
        g.classList.toggle("lost", state.lost.has(leg));
        g.setAttribute("aria-pressed", state.mode === "lost" ? String(state.lost.has(leg))
          : String(JOINTS.some((j) => state.locked.has(`${leg}.${j}`))));
        g.setAttribute("aria-label", label(leg));
        for (const e of g.querySelectorAll("[data-joint]")) e.classList.toggle("locked", state.locked.has(`${leg}.${e.dataset.joint}`));
        let title = g.querySelector("title");
        if (!title) { title = svg("title"); g.prepend(title); }
        title.textContent = label(leg);
      }
      onChange(damage());
    }
    function damage() {
      const locked_joints = [...state.locked.entries()].map(([k, angle]) => {
        const [leg, joint] = k.split(".");
        return { leg: Number(leg), joint, angle_deg: angle };
      }).sort((a, b) => a.leg - b.leg || JOINTS.indexOf(a.joint) - JOINTS.indexOf(b.joint));
      return { lost_legs: [...state.lost].sort((a, b) => a - b), locked_joints };
    }
    function setMode(m) { state.mode = m; render(); }
    function setAngle(leg, joint, angle) { if (state.locked.has(`${leg}.${joint}`)) state.locked.set(`${leg}.${joint}`, angle); }
    function unlock(leg, joint) { state.locked.delete(`${leg}.${joint}`); render(); }
    render();
    return { damage, setMode, setAngle, unlock, toggleLost, toggleLock };
  }

  return { create };
})();

// An uploaded robot (GET /api/robots: its leg map `legs` and `points`, each leg's hip and
// foot in the trunk frame): the top view, front at the top, each leg drawn from its hip to
// its foot with its joints spaced along that line (the points hold no elbow positions),
// numbered in map order and named. draw() is the Add robot page's and the form's drawing;
// onLeg(name) makes each leg a button (Enter/Space too).
const LegMapView = (() => {
  const NS = "http://www.w3.org/2000/svg";
  const FWD = { "+x": [1, 0], "-x": [-1, 0], "+y": [0, 1], "-y": [0, -1] };
  const svg = (tag, attrs = {}) => {
    const e = document.createElementNS(NS, tag);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
    return e;
  };

  // trunk frame (m) -> drawing plane: front up, the robot's left on the left
  function planar(forward) {
    const f = FWD[forward] || FWD["+x"], l = [-f[1], f[0]];
    return (p) => [-(p[0] * l[0] + p[1] * l[1]), -(p[0] * f[0] + p[1] * f[1])];
  }

  function draw(container, robot, opts = {}) {
    const map = robot.legs, legs = map.legs, pts = robot.points || {};
    const to = planar(map.forward);
    const plane = legs.map((leg) => ({ leg, hip: to((pts[leg.name] || {}).hip || [0, 0, 0]), foot: to((pts[leg.name] || {}).foot || [0, 0, 0]) }));
    const ext = Math.max(0.05, ...plane.flatMap((p) => [...p.hip, ...p.foot].map(Math.abs)));
    const S = 300 / ext, half = 300 + 70;
    const root = svg("svg", { viewBox: `${-half} ${-half} ${2 * half} ${2 * half}`, class: "robot-svg legmap-svg", role: "group",
                              "aria-label": `${robot.name || "robot"} seen from above, front at the top: ${legs.length} legs` });
    const hull = [...plane].sort((a, b) => Math.atan2(a.hip[1], a.hip[0]) - Math.atan2(b.hip[1], b.hip[0]));
    root.append(svg("polygon", { class: "body", points: hull.map((p) => `${p.hip[0] * S},${p.hip[1] * S}`).join(" ") }));
    const front = svg("text", { class: "front", x: 0, y: -half + 26 });
    front.textContent = "▲ front";
    root.append(front);
    const groups = {};
    plane.forEach(({ leg, hip, foot }, i) => {
      const [hx, hy, fx, fy] = [hip[0] * S, hip[1] * S, foot[0] * S, foot[1] * S];
      const g = svg("g", { class: "leg", "data-leg": leg.name });
      if (opts.onLeg) {
        g.setAttribute("tabindex", 0);
        g.setAttribute("role", "button");
        g.addEventListener("click", () => opts.onLeg(leg.name));
        g.addEventListener("keydown", (e) => { if (e.key === "Enter" || e.key === " ") { e.preventDefault(); opts.onLeg(leg.name); } });
      }
      const title = svg("title");
      title.textContent = `Leg ${i + 1}: ${leg.name} (${leg.side}, order ${leg.order}), joints ${leg.joints.join(", ")}`;
      g.append(title, svg("line", { class: "hit", x1: hx, y1: hy, x2: fx, y2: fy }),
               svg("line", { class: "seg", x1: hx, y1: hy, x2: fx, y2: fy }));
      leg.joints.forEach((j, k) => {
        const t = k / Math.max(1, leg.joints.length);
        g.append(svg("circle", { class: "joint", "data-joint": j, cx: hx + (fx - hx) * t, cy: hy + (fy - hy) * t, r: 9 }));
      });
      g.append(svg("circle", { class: "foot", cx: fx, cy: fy, r: 11 }));
      const dx = fx - hx, dy = fy - hy, n = Math.hypot(dx, dy) || 1;
      const label = svg("text", { x: fx + (dx / n) * 34, y: fy + (dy / n) * 34 });
      label.textContent = i + 1;
      g.append(label);
      groups[leg.name] = g;
      root.append(g);
    });
    container.replaceChildren(root);
    return { root, groups };
  }

  return { draw, planar };
})();

// The New job form's damage for an uploaded robot, by its leg map's names (the spec's
// robot_damage): a click on a leg (or Enter) marks it lost; each joint of a working leg has
// a state (working, locked at an angle, weak at a torque scale, passive) and each leg a cut.
const MappedDamage = (() => {
  const STATES = [["ok", "working"], ["locked", "locked"], ["weak", "weak"], ["passive", "passive (unpowered)"]];

  function create(drawing, table, robot, onChange) {
    const lost = new Set();
    const joints = new Map(); // "leg\u0000joint" -> {state, value}
    const cuts = new Map(); // leg -> m
    const view = LegMapView.draw(drawing, robot, { onLeg: (name) => { if (!lost.delete(name)) lost.add(name); render(); } });
    const el = GM.el;
    const key = (leg, j) => `${leg}\u0000${j}`;

    function row(leg, i) {
      const out = [];
      leg.joints.forEach((j, k) => {
        const id = `dmg-${i}-${k}`;
        const cur = joints.get(key(leg.name, j)) || { state: "ok", value: "" };
        const sel = el("select", { id, "data-field": "robot_damage", "data-leg": leg.name, "data-joint": j },
          STATES.map(([v, t]) => el("option", { value: v, text: t, selected: v === cur.state ? true : null })));
        const num = el("input", { type: "number", step: "any", "aria-label": `${leg.name} ${j}: angle (°) or torque scale`,
                                  value: cur.value, hidden: cur.state === "locked" || cur.state === "weak" ? null : true,
                                  placeholder: cur.state === "weak" ? "0.5" : "0" });
        const save = () => {
          if (sel.value === "ok") joints.delete(key(leg.name, j));
          else joints.set(key(leg.name, j), { state: sel.value, value: num.value });
        };
        sel.addEventListener("change", () => {
          save();
          num.hidden = !(sel.value === "locked" || sel.value === "weak");
          num.placeholder = sel.value === "weak" ? "0.5" : "0";
          paint();
          onChange(damage());
        });
        num.addEventListener("input", () => { save(); onChange(damage()); });
        out.push(el("tr", {}, k === 0 ? el("th", { scope: "row", rowspan: leg.joints.length + 1, text: `${i + 1} ${leg.name} (${leg.side})` }) : null,
          el("td", {}, el("label", { for: id, text: j })), el("td", {}, sel, " ", num)));
      });
      const cid = `cut-${i}`;
      const cut = el("input", { id: cid, type: "number", step: "0.005", min: "0", value: cuts.get(leg.name) ?? "", placeholder: "0",
                                "data-field": "robot_damage.shortened_legs" });
      cut.addEventListener("input", () => { const v = Number(cut.value); v > 0 ? cuts.set(leg.name, v) : cuts.delete(leg.name); onChange(damage()); });
      out.push(el("tr", {}, el("td", {}, el("label", { for: cid, text: "foot segment cut (m)" })), el("td", {}, cut)));
      return out;
    }

    function paint() {
      for (const [name, g] of Object.entries(view.groups)) {
        g.classList.toggle("lost", lost.has(name));
        if (g.getAttribute("role") === "button") g.setAttribute("aria-pressed", String(lost.has(name)));
        g.setAttribute("aria-label", `Leg ${name}: ${lost.has(name) ? "lost" : "working"}`);
        for (const c of g.querySelectorAll("[data-joint]")) c.classList.toggle("locked", joints.has(key(name, c.dataset.joint)));
      }
    }

    function render() { // the table is rebuilt only when a leg is lost or found: a select keeps its focus
      paint();
      const legs = robot.legs.legs;
      table.replaceChildren(GM.el("caption", { class: "small muted", text: "Joints of the working legs, from the body out" }),
        ...legs.flatMap((leg, i) => (lost.has(leg.name) ? [] : row(leg, i))));
      onChange(damage());
    }

    function damage() {
      const d = { lost_legs: robot.legs.legs.map((l) => l.name).filter((n) => lost.has(n)),
                  locked_joints: [], weak_joints: [], passive_joints: [], shortened_legs: [] };
      for (const [k, v] of joints) {
        const [leg, joint] = k.split("\u0000");
        if (lost.has(leg)) continue;
        const x = v.value === "" ? undefined : Number(v.value);
        if (v.state === "locked") d.locked_joints.push(Object.assign({ leg, joint }, x === undefined ? {} : { angle_deg: x }));
        if (v.state === "weak") d.weak_joints.push(Object.assign({ leg, joint }, x === undefined ? {} : { torque_scale: x }));
        if (v.state === "passive") d.passive_joints.push({ leg, joint });
      }
      for (const [leg, m] of cuts) if (!lost.has(leg)) d.shortened_legs.push({ leg, length_m: m });
      for (const k of Object.keys(d)) if (!d[k].length) delete d[k];
      return d;
    }

    render();
    return { damage };
  }

  function describe(d) {
    const parts = [];
    if (d.lost_legs) parts.push(`lost ${d.lost_legs.length === 1 ? "leg" : "legs"} ${d.lost_legs.join(", ")}`);
    for (const j of d.locked_joints || []) parts.push(`${j.leg} ${j.joint} locked at ${j.angle_deg ?? 0}°`);
    for (const j of d.weak_joints || []) parts.push(`${j.leg} ${j.joint} weak (${j.torque_scale ?? 0.5} of its torque)`);
    for (const j of d.passive_joints || []) parts.push(`${j.leg} ${j.joint} passive`);
    for (const s of d.shortened_legs || []) parts.push(`${s.leg} shortened by ${s.length_m} m`);
    return parts.length ? `Damage: ${parts.join("; ")}.` : "No damage.";
  }

  return { create, describe };
})();

// The Add robot page (/robots/new): upload, POST /api/robots?check=true (nothing stored)
// for the detected leg map and its points, the drawing and the 3D view, the map edited in a
// table, checked again on request, and saved with POST /api/robots and the edited map as
// `legs`. A refusal shows the API's message (it names what was refused).
(() => {
  const form = document.getElementById("robot-upload");
  if (!form) return;
  const { api, el } = GM;
  const $ = (id) => document.getElementById(id);
  let checked = null; // the last check's answer: {name, legs, points, stats, detected}
  let origin = []; // per row: the leg's name in `checked` (its points are keyed by it)

  function parts(legs) {
    const fd = new FormData();
    const model = $("up-model").files[0];
    if (!model) throw new Error("choose the model file (.xml) or a zip first");
    if (/\.zip$/i.test(model.name)) {
      fd.append("archive", model, model.name);
      if ($("up-model-path").value.trim()) fd.append("model_path", $("up-model-path").value.trim());
    } else fd.append("model", model, model.name);
    for (const f of $("up-assets").files) fd.append("assets", f, f.name);
    if ($("up-name").value.trim()) fd.append("name", $("up-name").value.trim());
    if ($("up-forward").value && !legs) fd.append("forward", $("up-forward").value);
    if (legs) fd.append("legs", JSON.stringify(legs));
    return fd;
  }

  function fail(box, e) {
    const msg = e.body && e.body.detail ? e.body.detail : e.message;
    const fields = e.body && e.body.errors ? e.body.errors.map((x) => x.field).filter(Boolean) : [];
    box.textContent = e.status ? `Refused (${e.status}): ${msg}${fields.length ? ` [field: ${fields.join(", ")}]` : ""}` : msg;
    box.hidden = false;
    box.focus();
  }

  // the map as edited in the table (rows in map order; foot, stance and gains kept)
  function edited() {
    const map = JSON.parse(JSON.stringify(checked.legs));
    map.trunk = $("lm-trunk").value.trim();
    map.forward = $("lm-forward").value;
    map.legs = map.legs.map((leg, i) => Object.assign(leg, {
      name: $(`lm-name-${i}`).value.trim(), side: $(`lm-side-${i}`).value, order: Number($(`lm-order-${i}`).value),
      joints: $(`lm-joints-${i}`).value.split(",").map((j) => j.trim()).filter(Boolean),
    }));
    for (const leg of map.legs) if (leg.stance && leg.stance.length !== leg.joints.length) delete leg.stance;
    return map;
  }

  function rows(map) {
    origin = map.legs.map((l) => l.name);
    $("lm-trunk").value = map.trunk;
    $("lm-forward").value = map.forward;
    $("legmap-rows").replaceChildren(...map.legs.map((leg, i) => {
      const cell = (id, input, text) => el("td", {}, el("label", { for: id, class: "sr-only", text }), input);
      const side = el("select", { id: `lm-side-${i}`, "data-field": `legs.legs.${i}.side` },
        ["left", "right"].map((s) => el("option", { text: s, selected: s === leg.side ? true : null })));
      return el("tr", { "data-leg": i },
        el("th", { scope: "row", text: String(i + 1) }),
        cell(`lm-name-${i}`, el("input", { id: `lm-name-${i}`, type: "text", value: leg.name, autocomplete: "off", spellcheck: "false",
                                           "data-field": `legs.legs.${i}.name` }), `Leg ${i + 1} name`),
        cell(`lm-side-${i}`, side, `Leg ${i + 1} side`),
        cell(`lm-order-${i}`, el("input", { id: `lm-order-${i}`, type: "number", min: "0", max: "15", step: "1", value: leg.order,
                                            "data-field": `legs.legs.${i}.order` }), `Leg ${i + 1} order`),
        cell(`lm-joints-${i}`, el("input", { id: `lm-joints-${i}`, type: "text", value: leg.joints.join(", "), autocomplete: "off",
                                             spellcheck: "false", "data-field": `legs.legs.${i}.joints` }), `Leg ${i + 1} joints`),
        el("td", { class: "small", text: `${leg.foot.kind} ${leg.foot.name}` }));
    }));
  }

  function drawAll(map) {
    const points = Object.fromEntries(map.legs.map((l, i) => [l.name, checked.points[origin[i]] || checked.points[l.name]]));
    const robot = { name: checked.name, legs: map, points };
    LegMapView.draw($("legmap-drawing"), robot);
    draw3d(robot);
  }

  function draw3d(robot) {
    const legs = robot.legs.legs.filter((l) => robot.points[l.name]);
    const hips = legs.map((l) => robot.points[l.name].hip);
    const ring = [...hips].sort((a, b) => Math.atan2(a[1], a[0]) - Math.atan2(b[1], b[0]));
    ring.push(ring[0]);
    const traces = [{ type: "scatter3d", mode: "lines", name: "trunk (hips)", x: ring.map((p) => p[0]), y: ring.map((p) => p[1]),
                      z: ring.map((p) => p[2]), line: { color: "#40536b", width: 6 }, hoverinfo: "skip" }];
    legs.forEach((l, i) => {
      const { hip, foot } = robot.points[l.name];
      traces.push({ type: "scatter3d", mode: "lines+markers+text", name: `${i + 1} ${l.name}`, x: [hip[0], foot[0]], y: [hip[1], foot[1]],
                    z: [hip[2], foot[2]], text: ["", `${i + 1}`], line: { width: 8, color: l.side === "left" ? "#2563eb" : "#b45309" },
                    marker: { size: [3, 5] }, hovertemplate: `${l.name} (${l.side}, order ${l.order})<extra></extra>` });
    });
    // equal metres on every axis, the whole robot in view (a flat robot is not stretched to a cube)
    const all = legs.flatMap((l) => [robot.points[l.name].hip, robot.points[l.name].foot]);
    const ext = Math.max(0.05, ...all.flatMap((p) => p.map(Math.abs))) * 1.1;
    const zr = [Math.min(-ext * 0.4, ...all.map((p) => p[2] * 1.1)), Math.max(ext * 0.4, ...all.map((p) => p[2] * 1.1))];
    const axis = (title, range) => ({ title, range, autorange: false });
    GM.plot($("legmap-3d"), traces, { hovermode: "closest", margin: { l: 0, r: 0, t: 0, b: 0 }, showlegend: false,
      scene: { aspectmode: "manual", aspectratio: { x: 1, y: 1, z: (zr[1] - zr[0]) / (2 * ext) },
               camera: { eye: { x: -0.75, y: -1.0, z: 0.6 } },
               xaxis: axis("x (m)", [-ext, ext]), yaxis: axis("y (m)", [-ext, ext]), zaxis: axis("z (m)", zr) } })
      .catch((e) => GM.empty($("legmap-3d"), `3D view unavailable: ${e.message}`));
  }

  function show(answer, rebuild) {
    checked = answer;
    const n = answer.legs.legs.length;
    $("legs-what").textContent = `${answer.name}: ${n} legs ${answer.detected ? "found in the model: check them, edit if need be, then save" : "as given"}`
      + ` (trunk ${answer.legs.trunk}, forward ${answer.legs.forward}).`;
    $("legs-stats").replaceChildren(...Object.entries(answer.stats || {}).flatMap(([k, v]) =>
      [el("dt", { text: k.replace(/_/g, " ") }), el("dd", { text: typeof v === "object" ? JSON.stringify(v) : String(v) })]));
    if (rebuild) rows(answer.legs);
    else origin = answer.legs.legs.map((l) => l.name);
    $("legs-card").hidden = false;
    drawAll(answer.legs);
  }

  // your stored robots: preview or delete each (delete is refused while a job uses it)
  async function mine() {
    let list = [];
    try { list = (await api("/api/robots")).filter((r) => r.builtin === false); } catch (err) { return; }
    $("mine-count").textContent = list.length ? `${list.length} stored.` : "None stored yet.";
    $("mine-rows").replaceChildren(...list.map((r) => el("tr", { "data-id": r.id },
      el("td", { text: r.name }), el("td", { text: r.legs.legs.map((l) => l.name).join(", ") }),
      el("td", { class: "small", text: r.id }), el("td", { class: "small", text: GM.age(r.created_at) }),
      el("td", {},
        el("button", { type: "button", class: "secondary", "aria-label": `Preview ${r.name} in 3D`, onclick: () => preview(r.id, r.name) }, "Preview"), " ",
        el("button", { type: "button", class: "danger", "aria-label": `Delete ${r.name}`, onclick: () => remove(r) }, "Delete")))));
  }

  async function remove(r) {
    $("mine-error").hidden = true;
    if (!window.confirm(`Delete ${r.name} (${r.id})? Its jobs keep their bundles.`)) return;
    try {
      await api(`/api/robots/${r.id}`, { method: "DELETE" });
      if ($("preview-card").dataset.id === r.id) { $("preview-card").hidden = true; $("robot-preview").removeAttribute("src"); }
    } catch (err) { fail($("mine-error"), err); }
    mine();
  }

  // a stored robot in viser's client (a .viser recording of the stored model, by a signed link)
  async function preview(id, name) {
    try {
      $("preview-card").dataset.id = id;
      $("preview-name").textContent = name ? `: ${name}` : "";
      const link = await api(`/api/robots/${id}/preview-link`);
      const src = `/viser/?playbackPath=${encodeURIComponent(link.url)}`;
      $("preview-open").href = src;
      $("preview-card").hidden = false;
      $("robot-preview").src = src;
    } catch (err) { /* the top view and the 3D plot stand; the preview is extra */ }
  }

  async function send(legs, check) {
    return api(`/api/robots${check ? "?check=true" : ""}`, { method: "POST", body: parts(legs) });
  }

  form.addEventListener("submit", async (e) => {
    e.preventDefault();
    $("up-error").hidden = true;
    $("save-ok").hidden = true;
    $("up-check").disabled = true;
    $("up-status").textContent = "Checking the model (compiled in a confined process)…";
    try {
      const answer = await send(null, true);
      $("up-status").textContent = `Checked in ${answer.seconds} s; nothing is stored until you save.`;
      show(answer, true);
      $("legs-h").scrollIntoView({ block: "start" });
    } catch (err) {
      $("up-status").textContent = "";
      $("legs-card").hidden = true;
      fail($("up-error"), err);
    } finally {
      $("up-check").disabled = false;
    }
  });

  document.addEventListener("DOMContentLoaded", mine);

  $("legmap-form").addEventListener("input", () => {
    if (!checked) return;
    try { drawAll(edited()); } catch (err) { /* half-typed: the drawing waits */ }
  });

  $("lm-recheck").addEventListener("click", async () => {
    $("save-error").hidden = true;
    try {
      show(await send(edited(), true), false);
      $("save-ok").textContent = "The edited leg map is valid for this model.";
      $("save-ok").hidden = false;
    } catch (err) { fail($("save-error"), err); }
  });

  $("legmap-form").addEventListener("submit", async (e) => {
    e.preventDefault();
    $("save-error").hidden = true;
    $("save-ok").hidden = true;
    $("lm-save").disabled = true;
    try {
      const robot = await send(edited(), false);
      const box = $("save-ok");
      box.replaceChildren(`Saved ${robot.created ? "" : "(stored before) "}as `, el("strong", { text: robot.name }),
        ` (id ${robot.id}), ${robot.legs.legs.length} legs. `, el("a", { href: "/", text: "New job with it" }),
        " — pick it in the Robot list of the New job form.");
      box.hidden = false;
      box.dataset.robotId = robot.id;
      box.focus();
      preview(robot.id, robot.name);
      mine();
    } catch (err) { fail($("save-error"), err); } finally { $("lm-save").disabled = false; }
  });
})();
