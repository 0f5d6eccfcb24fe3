// simplebot viewer: draws the frames of /frame on a canvas, in the fixed frame (odom), and sends 2D Nav Goals.
"use strict";

(() => {
  const { LAYERS, COLOURS, gridImage, decode } = window.SimplebotFrames;

  const canvas = document.getElementById("canvas");
  const ctx = canvas.getContext("2d");
  const $ = (id) => document.getElementById(id);

  const state = {
    frame: null,           // last decoded header
    layers: {},            // name -> Float32Array (and stride)
    grids: {},             // name -> {meta, image (canvas)}
    body: null,            // [Float32Array outline in the base frame]
    bodyVersion: null,
    version: -1,
    view: { x: 0, y: 0, scale: 40 }, // centre in world metres, pixels per metre
    fitted: false,
    follow: false,
    tool: null,            // null, "goal" (2D Nav Goal) or "pose" (2D Pose Estimate)
    drag: null,            // {kind: "pan"|"goal"|"pose", ...}
    sentGoal: null,
    frameTimes: [],
    visible: Object.fromEntries(LAYERS.map(([name]) => [name, true])),
  };

  // -- frames --------------------------------------------------------------------------------------
  function apply({ header, arrays }) {
    state.frame = header;
    state.version = header.version;
    for (const [name, meta] of Object.entries(header.costmaps)) {
      if (meta.buffer !== undefined) state.grids[name] = { meta, image: gridImage(meta, arrays[meta.buffer]) };
    }
    for (const name of Object.keys(state.grids)) if (!(name in header.costmaps)) delete state.grids[name];
    state.layers = {};
    for (const [name, layer] of Object.entries(header.layers)) {
      state.layers[name] = { data: arrays[layer.buffer], stride: layer.stride, origin: layer.origin };
    }
    if (header.body) {
      state.body = header.body.outlines.map((i) => arrays[i]);
      state.bodyVersion = header.body.version;
    }
    if (!state.fitted && state.grids.global_costmap) { fit(); state.fitted = true; }
    if (state.follow && header.robot) { state.view.x = header.robot[0]; state.view.y = header.robot[1]; }
    const now = performance.now();
    state.frameTimes.push(now);
    while (state.frameTimes.length && state.frameTimes[0] < now - 2000) state.frameTimes.shift();
    updatePanel();
    draw();
  }

  async function poll() {
    for (;;) {
      const query = new URLSearchParams({ after: state.version });
      for (const [name, grid] of Object.entries(state.grids)) query.set(name, grid.meta.version);
      if (state.bodyVersion !== null) query.set("body", state.bodyVersion);
      try {
        const response = await fetch("frame?" + query);
        if (!response.ok) throw new Error(await response.text());
        apply(decode(await response.arrayBuffer()));
        setLink(true);
      } catch (err) {
        setLink(false, String(err));
        await new Promise((r) => setTimeout(r, 1000));
      }
    }
  }

  function setLink(ok, why) {
    const link = $("link");
    link.className = ok ? "ok" : "bad";
    link.textContent = ok ? "live" : "disconnected";
    link.title = why || "";
  }

  // -- view ----------------------------------------------------------------------------------------
  function size() {
    const ratio = window.devicePixelRatio || 1;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== Math.round(w * ratio) || canvas.height !== Math.round(h * ratio)) {
      canvas.width = Math.round(w * ratio);
      canvas.height = Math.round(h * ratio);
    }
    return { w, h, ratio };
  }

  // Canvas CSS pixels <-> fixed-frame metres (y up).
  function toScreen(x, y) {
    const { w, h } = size();
    return [w / 2 + (x - state.view.x) * state.view.scale, h / 2 - (y - state.view.y) * state.view.scale];
  }

  function toWorld(sx, sy) {
    const { w, h } = size();
    return [state.view.x + (sx - w / 2) / state.view.scale, state.view.y - (sy - h / 2) / state.view.scale];
  }

  function fit() {
    const grid = state.grids.global_costmap;
    if (!grid) return;
    const { w, h } = size();
    const m = grid.meta;
    const wm = m.width * m.resolution, hm = m.height * m.resolution;
    const [ox, oy, yaw] = m.origin;
    const c = Math.cos(yaw), s = Math.sin(yaw);
    state.view.x = ox + c * wm / 2 - s * hm / 2;
    state.view.y = oy + s * wm / 2 + c * hm / 2;
    state.view.scale = Math.min(w / wm, h / hm) * 0.95;
    draw();
  }

  // -- drawing -------------------------------------------------------------------------------------
  let drawPending = false;
  function draw() {
    if (drawPending) return;
    drawPending = true;
    requestAnimationFrame(() => { drawPending = false; render(); });
  }

  function worldTransform() {
    const { w, h, ratio } = size();
    const k = state.view.scale * ratio;
    ctx.setTransform(k, 0, 0, -k, (w / 2 - state.view.x * state.view.scale) * ratio,
      (h / 2 + state.view.y * state.view.scale) * ratio);
  }

  function px(n) { return n / state.view.scale; }  // n screen pixels in metres

  function polyline(data, stride, colour, width) {
    if (!data || data.length < 2 * stride) return;
    ctx.beginPath();
    ctx.moveTo(data[0], data[1]);
    for (let i = stride; i < data.length; i += stride) {  // a NaN point lifts the pen (several outlines)
      if (Number.isNaN(data[i - stride])) ctx.moveTo(data[i], data[i + 1]); else ctx.lineTo(data[i], data[i + 1]);
    }
    ctx.strokeStyle = colour;
    ctx.lineWidth = px(width);
    ctx.stroke();
  }

  function arrow(x, y, yaw, length, colour, width) {
    const c = Math.cos(yaw), s = Math.sin(yaw);
    const hx = x + c * length, hy = y + s * length, head = length * 0.35;
    ctx.beginPath();
    ctx.moveTo(x, y);
    ctx.lineTo(hx, hy);
    ctx.moveTo(hx - head * Math.cos(yaw - 0.5), hy - head * Math.sin(yaw - 0.5));
    ctx.lineTo(hx, hy);
    ctx.lineTo(hx - head * Math.cos(yaw + 0.5), hy - head * Math.sin(yaw + 0.5));
    ctx.strokeStyle = colour;
    ctx.lineWidth = px(width);
    ctx.stroke();
  }

  function render() {
    size();
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    worldTransform();
    ctx.imageSmoothingEnabled = false;
    for (const name of ["global_costmap", "local_costmap"]) {
      const grid = state.grids[name];
      if (!grid || !state.visible[name]) continue;
      const m = grid.meta;
      ctx.save();
      ctx.translate(m.origin[0], m.origin[1]);
      ctx.rotate(m.origin[2]);
      ctx.scale(m.resolution, m.resolution);
      ctx.drawImage(grid.image, 0, 0);
      ctx.restore();
    }
    if (state.visible.grid) drawGrid();
    const L = state.layers;
    if (state.visible.trail && L.trail) polyline(L.trail.data, 2, COLOURS.trail, 1.5);
    if (state.visible.global_plan && L.global_plan) polyline(L.global_plan.data, 3, COLOURS.global_plan, 2.5);
    if (state.visible.local_plan && L.local_plan) polyline(L.local_plan.data, 3, COLOURS.local_plan, 2.5);
    if (state.visible.moving_obstacles && L.moving_obstacles) {
      polyline(L.moving_obstacles.data, 2, COLOURS.moving_obstacles, 2);
    }
    if (state.visible.teb_poses && L.teb_poses) {
      const d = L.teb_poses.data;
      for (let i = 0; i + 2 < d.length; i += 3) arrow(d[i], d[i + 1], d[i + 2], px(14), COLOURS.teb_poses, 1.5);
    }
    for (const name of ["front_scan", "back_scan"]) {
      if (!state.visible[name] || !L[name]) continue;
      const d = L[name].data, r = px(1.5);
      ctx.fillStyle = COLOURS[name];
      for (let i = 0; i + 1 < d.length; i += 2) ctx.fillRect(d[i] - r, d[i + 1] - r, 2 * r, 2 * r);
    }
    const robot = state.frame && state.frame.robot;
    if (state.visible.robot && robot && state.body) {
      ctx.save();
      ctx.translate(robot[0], robot[1]);
      ctx.rotate(robot[2]);
      ctx.fillStyle = "rgba(110,110,110,0.45)";
      ctx.strokeStyle = "#444";
      ctx.lineWidth = px(1);
      for (const outline of state.body) {  // lowest first, so wheels and lidars show on the deck
        ctx.beginPath();
        ctx.moveTo(outline[0], outline[1]);
        for (let j = 2; j < outline.length; j += 2) ctx.lineTo(outline[j], outline[j + 1]);
        ctx.closePath();
        ctx.fill();
        ctx.stroke();
      }
      ctx.restore();
    }
    if (state.visible.footprint && L.footprint && L.footprint.data.length >= 4) {
      const d = L.footprint.data;
      polyline(Float32Array.from([...d, d[0], d[1]]), 2, COLOURS.footprint, 1.5);
    }
    if (robot && state.visible.robot) arrow(robot[0], robot[1], robot[2], px(30), "#d00", 2.5);
    if (state.visible.goal && L.goal) {
      const d = L.goal.data;
      arrow(d[0], d[1], d[2], px(40), COLOURS.goal, 3);
    }
    const drag = state.drag;
    if (drag && drag.kind !== "pan") arrow(drag.x, drag.y, drag.yaw, px(40), TOOLS[drag.kind].dataset.colour, 3);
    if (!(drag && drag.kind === "goal") && state.sentGoal && !(L.goal && sameGoal(L.goal.data, state.sentGoal))) {
      const g = state.sentGoal;
      arrow(g.x, g.y, g.yaw, px(40), "#2a6", 2);
    }
  }

  function sameGoal(d, g) { return Math.abs(d[0] - g.x) < 1e-3 && Math.abs(d[1] - g.y) < 1e-3; }

  function drawGrid() {
    const { w, h } = size();
    const [x0, y1] = toWorld(0, 0), [x1, y0] = toWorld(w, h);
    if ((x1 - x0) > 400) return;
    ctx.beginPath();
    for (let x = Math.ceil(x0); x <= x1; x++) { ctx.moveTo(x, y0); ctx.lineTo(x, y1); }
    for (let y = Math.ceil(y0); y <= y1; y++) { ctx.moveTo(x0, y); ctx.lineTo(x1, y); }
    ctx.strokeStyle = "rgba(0,0,0,0.08)";
    ctx.lineWidth = px(1);
    ctx.stroke();
  }

  // -- panel ---------------------------------------------------------------------------------------
  const f2 = (v) => (v === null || v === undefined ? "-" : (Math.abs(v) < 0.005 ? 0 : v).toFixed(2));
  const deg = (a) => `${Math.round(a * 180 / Math.PI) || 0}°`;

  function updatePanel() {
    const h = state.frame;
    const st = h.status || {};
    $("mb-state").textContent = st.state ? st.state + (st.text ? " - " + st.text : "") : "no status yet";
    const rec = h.recoveries;
    $("recoveries").textContent = rec.count ? `${rec.count}, last: ${rec.last}` : "none";
    const goal = state.layers.goal;
    $("mb-goal").textContent = goal
      ? `${f2(goal.data[0])}, ${f2(goal.data[1])}, ${deg(goal.data[2])}` : "none";
    $("robot-pose").textContent = h.robot
      ? `${f2(h.robot[0])}, ${f2(h.robot[1])}, ${deg(h.robot[2])}` : "no transform";
    $("odom-speed").textContent = `${f2(h.velocity[0])} m/s, ${f2(h.velocity[1])} rad/s`;
    $("cmd-speed").textContent = `${f2(h.command[0])} m/s, ${f2(h.command[1])} rad/s`;
    $("sim-time").textContent = h.sim_time === null ? "no odometry yet" : h.sim_time.toFixed(1) + " s";
    $("rtf").textContent = h.rtf === null ? "-" : h.rtf.toFixed(2);
    $("fps").textContent = `${(state.frameTimes.length / 2).toFixed(0)} / s`;
    $("missing").textContent = h.missing.length ? "no transform: " + h.missing.join(", ") : "";
    const log = $("log");
    log.replaceChildren(...h.log.map((line) => {
      const li = document.createElement("li");
      li.className = line.level;
      li.textContent = `[${line.node}] ${line.text}`;
      li.title = li.textContent;
      return li;
    }));
  }

  function buildLayerToggles() {
    const box = $("layers");
    for (const [name, label, colour] of LAYERS) {
      const row = document.createElement("label");
      const input = document.createElement("input");
      input.type = "checkbox";
      input.checked = true;
      input.dataset.layer = name;
      input.addEventListener("change", () => { state.visible[name] = input.checked; draw(); });
      const swatch = document.createElement("i");
      swatch.style.background = colour;
      row.append(input, swatch, label);
      box.append(row);
    }
  }

  // -- input ---------------------------------------------------------------------------------------
  // The two pose tools, as RViz's: each button's data-path is where the clicked and dragged pose goes.
  const TOOLS = { goal: $("goal-tool"), pose: $("pose-tool") };

  function setTool(tool) {
    state.tool = tool;
    for (const [name, button] of Object.entries(TOOLS)) button.classList.toggle("on", name === tool);
    canvas.classList.toggle("goal", tool !== null);
    $("hint").textContent = tool ? TOOLS[tool].dataset.hint : "";
  }

  function setFollow(on) {
    state.follow = on;
    $("follow").classList.toggle("on", on);
    if (on && state.frame && state.frame.robot) {
      state.view.x = state.frame.robot[0]; state.view.y = state.frame.robot[1]; draw();
    }
  }

  function local(event) {
    const r = canvas.getBoundingClientRect();
    return [event.clientX - r.left, event.clientY - r.top];
  }

  async function sendPose(kind, pose) {
    if (kind === "goal") state.sentGoal = pose;
    const path = TOOLS[kind].dataset.path;
    const response = await fetch(path, { method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify(pose) });
    $("hint").textContent = response.ok ? "" : `${path} refused: ` + await response.text();
    draw();
  }

  canvas.addEventListener("mousedown", (event) => {
    if (event.button !== 0 && event.button !== 1) return;
    const [sx, sy] = local(event);
    if (state.tool && event.button === 0) {
      const [x, y] = toWorld(sx, sy);
      state.drag = { kind: state.tool, x, y, yaw: 0, sx, sy };
    } else {
      state.drag = { kind: "pan", sx, sy, vx: state.view.x, vy: state.view.y };
      if (state.follow) setFollow(false);
    }
    event.preventDefault();
  });

  window.addEventListener("mousemove", (event) => {
    const d = state.drag;
    if (!d) return;
    const [sx, sy] = local(event);
    if (d.kind === "pan") {
      state.view.x = d.vx - (sx - d.sx) / state.view.scale;
      state.view.y = d.vy + (sy - d.sy) / state.view.scale;
    } else if (Math.hypot(sx - d.sx, sy - d.sy) >= 3) {
      d.yaw = Math.atan2(-(sy - d.sy), sx - d.sx);
    }
    draw();
  });

  window.addEventListener("mouseup", () => {
    const d = state.drag;
    state.drag = null;
    if (d && d.kind !== "pan") {
      setTool(null);
      sendPose(d.kind, { x: d.x, y: d.y, yaw: d.yaw });
    }
    draw();
  });

  canvas.addEventListener("wheel", (event) => {
    const [sx, sy] = local(event);
    const [wx, wy] = toWorld(sx, sy);
    const factor = Math.exp(-event.deltaY * 0.0015);
    state.view.scale = Math.min(2000, Math.max(2, state.view.scale * factor));
    const [nx, ny] = toWorld(sx, sy);  // keep the point under the cursor where it is
    state.view.x += wx - nx;
    state.view.y += wy - ny;
    draw();
    event.preventDefault();
  }, { passive: false });

  window.addEventListener("keydown", (event) => {
    if (event.target.tagName === "INPUT") return;
    if (event.key === "g") setTool(state.tool === "goal" ? null : "goal");
    else if (event.key === "p") setTool(state.tool === "pose" ? null : "pose");
    else if (event.key === "f") setFollow(!state.follow);
    else if (event.key === "0") fit();
    else if (event.key === "Escape") { state.drag = null; setTool(null); draw(); }
  });

  for (const [name, button] of Object.entries(TOOLS)) button.onclick = () => setTool(state.tool === name ? null : name);
  $("follow").addEventListener("click", () => setFollow(!state.follow));
  $("fit").addEventListener("click", fit);
  window.addEventListener("resize", draw);

  // For scripted use (tests, screenshots): coordinates in page pixels.
  window.viewer = {
    state,
    worldToPage(x, y) {
      const r = canvas.getBoundingClientRect();
      const [sx, sy] = toScreen(x, y);
      return [r.left + sx, r.top + sy];
    },
    setView(x, y, scale) {
      state.view = { x, y, scale }; state.fitted = true; setFollow(false); render();
    },
    render,
  };

  buildLayerToggles();
  setLink(false, "waiting for the first frame");
  poll();
})();
