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
