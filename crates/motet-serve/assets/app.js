// The motet page: the machine's state pushed over the WebSocket, actions
// sent to the JSON API. Everything it knows comes from /api; nothing is
// cached between loads but the client's name.
"use strict";

const params = new URLSearchParams(location.search);
const token = params.get("token");
const client = sessionStorage.getItem("motet-client") ||
  (() => { const c = "page-" + Math.random().toString(36).slice(2, 10); sessionStorage.setItem("motet-client", c); return c; })();
const $ = (id) => document.getElementById(id);

// Figures the browser test reads: pushes received and their age on arrival.
// speeds: [server µs, speed, wall ms of the push] for the newest pushes.
window.motetStats = { updates: 0, ages: [], positions: 0, lastPosition: null, speeds: [] };

let machine = null;
let job = null;        // the uploaded job's description
let preview = null;    // its strokes
let trail = [];        // executed positions while running [x, y]
let samples = [];      // [t_s, speed] for the plot
let temps = [];        // [t_s, [[temp, target] per heater]], 5 minutes
let lastStatus = null;

function headers(json) {
  const h = { "X-Motet-Client": client };
  if (token) h["Authorization"] = "Bearer " + token;
  if (json) h["Content-Type"] = "application/json";
  return h;
}

async function api(method, path, body, raw) {
  const opts = { method, headers: headers(body !== undefined && !raw) };
  if (body !== undefined) opts.body = raw ? body : JSON.stringify(body);
  const r = await fetch(path, opts);
  const text = await r.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch (_) { data = { error: text }; }
  if (!r.ok) throw new Error((data && data.error) || r.status + " " + r.statusText);
  return data;
}

function showError(e) { $("error").textContent = e ? String(e.message || e) : ""; }

async function act(method, path, body) {
  try { showError(null); return await api(method, path, body); }
  catch (e) { showError(e); return null; }
}

// ---- machine view ----------------------------------------------------------

function bounds() {
  const ax = machine.axes;
  return [ax[0].travel[0], ax[1] ? ax[1].travel[0] : -1, ax[0].travel[1], ax[1] ? ax[1].travel[1] : 1];
}

function fitCanvas(c) {
  const r = c.getBoundingClientRect();
  const d = window.devicePixelRatio || 1;
  if (c.width !== Math.round(r.width * d) || c.height !== Math.round(r.height * d)) {
    c.width = Math.round(r.width * d);
    c.height = Math.round(r.height * d);
  }
  return d;
}

// Machine units to canvas pixels, y up, the whole travel in view.
function transform(c) {
  const [x0, y0, x1, y1] = bounds();
  const m = 12 * (window.devicePixelRatio || 1);
  const s = Math.min((c.width - 2 * m) / (x1 - x0 || 1), (c.height - 2 * m) / (y1 - y0 || 1));
  return (p) => [m + (p[0] - x0) * s, c.height - m - (p[1] - y0) * s];
}

function drawView() {
  const c = $("view");
  if (!machine) return;
  const d = fitCanvas(c);
  const g = c.getContext("2d");
  const T = transform(c);
  g.clearRect(0, 0, c.width, c.height);
  const [x0, y0, x1, y1] = bounds();
  const a = T([x0, y0]), b = T([x1, y1]);
  g.fillStyle = "#fff";
  g.fillRect(a[0], b[1], b[0] - a[0], a[1] - b[1]);
  g.strokeStyle = "#bbb";
  g.strokeRect(a[0], b[1], b[0] - a[0], a[1] - b[1]);
  if (preview) {
    for (const s of preview.strokes) {
      g.beginPath();
      g.strokeStyle = s.on ? "#9aa7b8" : "rgba(220,120,60,0.35)";
      g.lineWidth = (s.on ? 1.2 : 0.8) * d;
      s.points.forEach((p, i) => { const q = T(p); i ? g.lineTo(q[0], q[1]) : g.moveTo(q[0], q[1]); });
      g.stroke();
    }
  }
  if (trail.length > 1) {
    g.beginPath();
    g.strokeStyle = "#1d3557";
    g.lineWidth = 1.6 * d;
    // A null breaks the line: the pen went up.
    let up = true;
    for (const p of trail) {
      if (!p) { up = true; continue; }
      const q = T(p);
      up ? g.moveTo(q[0], q[1]) : g.lineTo(q[0], q[1]);
      up = false;
    }
    g.stroke();
  }
  const here = graphPos || (lastStatus && lastStatus.position);
  if (here) {
    const q = T(here);
    g.beginPath();
    g.fillStyle = "#e63946";
    g.arc(q[0], q[1], 5 * d, 0, 2 * Math.PI);
    g.fill();
  }
}

const HEAT_COLOURS = ["#e76f51", "#264653", "#8338ec", "#2a9d8f"];

// The heaters' temperatures and targets (°C), and a plot of the last five
// minutes, kept at one sample a second.
function showHeaters(s) {
  $("temps-panel").hidden = false;
  $("temps").textContent = s.heaters.map((h) => h.name + " " + h.temp.toFixed(1) + " / " + h.target.toFixed(0) + " °C").join("   ");
  const t = s.t_us * 1e-6;
  if (!temps.length || t - temps[temps.length - 1][0] >= 1) temps.push([t, s.heaters.map((h) => [h.temp, h.target, h.max])]);
  while (temps.length > 2 && temps[0][0] < t - 300) temps.shift();
}

function drawTemps() {
  const c = $("temp-plot");
  if (!temps.length || $("temps-panel").hidden) return;
  const d = fitCanvas(c);
  const g = c.getContext("2d");
  g.clearRect(0, 0, c.width, c.height);
  const top = Math.max(...temps[temps.length - 1][1].map((h) => h[2]), 50);
  // The window grows to five minutes, so the first minutes fill the plot.
  const t1 = temps[temps.length - 1][0], span = Math.max(t1 - temps[0][0], 30);
  const X = (t) => ((t - (t1 - span)) / span) * c.width;
  const Y = (v) => c.height - (v / top) * c.height;
  temps[0][1].forEach((_, k) => {
    for (const [idx, dash] of [[0, []], [1, [4 * d, 4 * d]]]) {
      g.strokeStyle = HEAT_COLOURS[k % HEAT_COLOURS.length]; g.lineWidth = 1.5 * d; g.setLineDash(dash);
      g.beginPath();
      temps.forEach(([t, hs], i) => { const y = Y(hs[k][idx]); i ? g.lineTo(X(t), y) : g.moveTo(X(t), y); });
      g.stroke();
    }
  });
  g.setLineDash([]);
}

function drawPlot() {
  const c = $("plot");
  if (!machine) return;
  const d = fitCanvas(c);
  const g = c.getContext("2d");
  g.clearRect(0, 0, c.width, c.height);
  const vmax = Math.max(...machine.axes.filter((a) => a.path).map((a) => a.max_velocity), 1);
  const amax = Math.max(...machine.axes.filter((a) => a.path).map((a) => a.max_acceleration), 1);
  const n = samples.length;
  if (n < 2) return;
  const t1 = samples[n - 1][0], t0 = t1 - 10;
  const X = (t) => ((t - t0) / 10) * c.width;
  const Yv = (v) => c.height - (v / (vmax * 1.1)) * c.height;
  const Ya = (a) => c.height / 2 - (a / (amax * 1.1)) * (c.height / 2);
  g.strokeStyle = "#c1121f"; g.setLineDash([4 * d, 4 * d]); g.lineWidth = d;
  g.beginPath(); g.moveTo(0, Yv(vmax)); g.lineTo(c.width, Yv(vmax)); g.stroke();
  g.setLineDash([]);
  g.strokeStyle = "#1d3557"; g.lineWidth = 1.5 * d; g.beginPath();
  samples.forEach(([t, v], i) => { i ? g.lineTo(X(t), Yv(v)) : g.moveTo(X(t), Yv(v)); });
  g.stroke();
  g.strokeStyle = "#2a9d8f"; g.beginPath();
  for (let i = 1; i < n; i++) {
    const dt = samples[i][0] - samples[i - 1][0];
    const acc = dt > 0 ? (samples[i][1] - samples[i - 1][1]) / dt : 0;
    const y = Ya(Math.max(-amax * 1.1, Math.min(amax * 1.1, acc)));
    i > 1 ? g.lineTo(X(samples[i][0]), y) : g.moveTo(X(samples[i][0]), y);
  }
  g.stroke();
}

// ---- status ----------------------------------------------------------------

const LABELS = { idle: "idle", running: "running", holding: "holding…", paused: "paused", stopping: "stopping…", stopped: "stopped", alarm: "alarm" };

function showStatus(s, wallMs) {
  lastStatus = s;
  const st = $("state");
  st.textContent = (LABELS[s.state] || s.state) + (s.connecting ? " · connecting to nodes…" : "");
  st.dataset.state = s.state;
  document.body.dataset.state = s.state;
  const names = machine ? machine.axes.map((a) => a.name) : [];
  $("position").textContent = s.position.map((v, i) => (names[i] || i) + " " + v.toFixed(2)).join("  ");
  $("speed").textContent = s.speed.toFixed(1) + " units/s";
  if (s.state === "running" || s.state === "holding" || s.state === "stopping") {
    const p = [s.position[0], s.position[1] || 0];
    const last = trail[trail.length - 1];
    if (!last || last[0] !== p[0] || last[1] !== p[1]) trail.push(p);
    if (trail.length > 50000) trail = trail.slice(-40000);
  }
  if (s.heaters && s.heaters.length) showHeaters(s);
  samples.push([s.t_us * 1e-6, s.speed]);
  while (samples.length > 2 && samples[0][0] < s.t_us * 1e-6 - 10) samples.shift();
  const j = s.job;
  $("progress-bar").style.width = j ? (100 * j.progress).toFixed(1) + "%" : "0";
  $("job-name").textContent = j ? j.name : (job ? job.name + " (ready)" : "no job");
  $("time-left").textContent = j ? fmtTime(j.left_s) + " left" : "";
  const busy = ["running", "holding", "paused", "stopping"].includes(s.state);
  $("start").disabled = !job || busy || s.state === "alarm";
  $("enqueue").disabled = !job;
  $("queue-start").disabled = !s.queued || busy || s.state === "alarm";
  if (s.queued !== lastQueued) { lastQueued = s.queued; refreshQueue(); }
  $("pause").disabled = s.state !== "running" || !j;
  $("resume").disabled = s.state !== "paused";
  $("cancel").disabled = !["running", "holding", "paused"].includes(s.state);
  $("unlock").disabled = !["alarm", "stopped"].includes(s.state);
  $("control").disabled = !s.controller || s.controller === client;
  // A hand-driven machine takes no jobs, jogs or tool changes.
  for (const b of document.querySelectorAll(".pad button, #zero, #tools button")) b.disabled = busy || s.state === "alarm" || graphMode;
  if (graphMode) $("start").disabled = $("queue-start").disabled = true;
  if (s.reason) $("state").title = s.reason;
  const stats = window.motetStats;
  stats.updates += 1;
  if (wallMs) { stats.ages.push(Date.now() - wallMs); if (stats.ages.length > 1000) stats.ages.shift(); }
  stats.speeds.push([s.t_us, s.speed, wallMs]);
  if (stats.speeds.length > 500) stats.speeds.shift();
  const pos = JSON.stringify(s.position);
  if (pos !== stats.lastPosition) { stats.positions += 1; stats.lastPosition = pos; }
}

function fmtTime(s) {
  s = Math.max(0, Math.round(s));
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), r = s % 60;
  return (h ? h + ":" + String(m).padStart(2, "0") : m) + ":" + String(r).padStart(2, "0");
}

function addEvents(list) {
  const ol = $("events");
  for (const e of list) {
    const li = document.createElement("li");
    li.className = e.level;
    li.textContent = (e.t_us * 1e-6).toFixed(1) + " s  " + e.message;
    ol.prepend(li);
  }
  while (ol.children.length > 100) ol.lastChild.remove();
}

function connect() {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  const ws = new WebSocket(proto + "//" + location.host + "/api/ws" + (token ? "?token=" + encodeURIComponent(token) : ""));
  ws.onmessage = (m) => {
    const msg = JSON.parse(m.data);
    if (msg.type === "status") {
      showStatus(msg.status, msg.wall_ms);
      if (msg.graph) showGraph(msg.graph);
      addEvents(msg.events || []);
      if ((msg.events || []).length) refreshQueue();
    }
  };
  ws.onclose = () => { $("state").textContent = "disconnected"; setTimeout(connect, 1000); };
}

function frame() {
  drawView();
  drawTemps();
  drawPlot();
  requestAnimationFrame(frame);
}

// ---- actions ---------------------------------------------------------------

// The placement query for drawings (G-code is placed by its own
// coordinates: no placement is sent for it).
function placement(name) {
  if (/\.(gcode|gco|g|nc|ngc|tap)(\.gz)?$/i.test(name)) return "";
  let q = "";
  if ($("place").value === "fit") q += "&fit=" + encodeURIComponent($("margin").value || "10");
  else if ($("scale").value) q += "&scale=" + encodeURIComponent($("scale").value);
  if ($("rotate").value) q += "&rotate=" + encodeURIComponent($("rotate").value);
  return q;
}

let lastFile = null;

async function upload(file) {
  showError(null);
  lastFile = file;
  $("job-info").textContent = "reading " + file.name + "…";
  try {
    const body = await file.arrayBuffer();
    job = await api("POST", "/api/jobs?name=" + encodeURIComponent(file.name) + placement(file.name), body, true);
    preview = await api("GET", "/api/jobs/" + job.id + "/preview");
    window.motetStats.previewStrokes = preview.strokes.length;
    window.motetStats.jobId = job.id;
    trail = [];
    const placed = job.placed ? ", " + (job.placed.max[0] - job.placed.min[0]).toFixed(1) + " × " +
      (job.placed.max[1] - job.placed.min[1]).toFixed(1) + " at " + job.placed.min.map((v) => v.toFixed(1)).join(", ") : "";
    $("job-info").textContent = job.name + ": " + job.command_count + " commands, " + fmtTime(job.planned_s) + placed +
      (job.warnings.length ? ", " + job.warnings.length + " warnings" : "");
    $("start").disabled = false;
  } catch (e) {
    job = null; preview = null;
    $("job-info").textContent = "";
    showError(e);
  }
}

function buildJog() {
  const pad = $("pad");
  for (const a of machine.axes.filter((a) => a.name !== "e")) {
    for (const sign of [-1, 1]) {
      const b = document.createElement("button");
      b.textContent = a.name.toUpperCase() + (sign < 0 ? "−" : "+");
      b.dataset.axis = a.name;
      b.dataset.sign = sign;
      b.onclick = () => act("POST", "/api/jog", { axes: { [a.name]: sign * Number($("jog-step").value) } });
      pad.appendChild(b);
    }
  }
  for (const t of machine.tools) {
    for (const [label, value] of [["on", 1], ["off", 0]]) {
      const b = document.createElement("button");
      b.textContent = t.name + " " + label;
      b.onclick = () => act("POST", "/api/tool", { tool: t.name, value });
      $("tools").appendChild(b);
    }
  }
}

let lastQueued = null;

// The queue and the history, read again when the queue or an event changes
// them (the status says how many are queued).
async function refreshQueue() {
  try {
    const q = await api("GET", "/api/queue");
    $("queue").replaceChildren(...q.jobs.map((j, i) => {
      const li = document.createElement("li");
      li.textContent = j.name + " ";
      const b = document.createElement("button");
      b.textContent = "remove";
      b.onclick = () => act("DELETE", "/api/queue/" + i).then(refreshQueue);
      li.appendChild(b);
      return li;
    }));
    const h = await api("GET", "/api/history");
    $("history").replaceChildren(...h.slice(-20).reverse().map((e) => {
      const li = document.createElement("li");
      li.className = e.outcome === "finished" ? "info" : "warn";
      const when = e.ended_wall_ms ? new Date(e.ended_wall_ms).toLocaleString() + "  " : "";
      li.textContent = when + e.name + ": " + e.outcome;
      return li;
    }));
  } catch (_) { /* shown by the state badge */ }
}

// ---- a hand-driven machine: the graph's inputs as sliders -------------------

let graphPos = null;
let graphMode = false;
const RANGES = { analog: [0, 1023, 1], encoder: [-4000, 4000, 1] };

function buildGraph(g) {
  graphMode = true;
  $("graph-panel").hidden = false;
  $("graph-file").textContent = g.file;
  const box = $("graph-inputs");
  for (const inp of g.inputs) {
    if (inp.kind === "stream") continue;
    const label = document.createElement("label");
    const name = document.createElement("span");
    name.textContent = inp.name;
    const out = document.createElement("output");
    out.textContent = inp.value;
    const el = document.createElement("input");
    el.id = "graph-" + inp.name;
    if (inp.kind === "digital") {
      el.type = "checkbox";
      el.checked = inp.value !== 0;
    } else {
      const [lo, hi, step] = RANGES[inp.kind];
      Object.assign(el, { type: "range", min: lo, max: hi, step, value: inp.value });
    }
    let pending = null;
    // Sends the newest value at most every 30 ms while the slider moves.
    const send = () => {
      const v = el.type === "checkbox" ? (el.checked ? 1 : 0) : Number(el.value);
      out.textContent = v;
      if (pending) return;
      pending = setTimeout(async () => {
        pending = null;
        const now = el.type === "checkbox" ? (el.checked ? 1 : 0) : Number(el.value);
        try { $("graph-error").textContent = ""; await api("POST", "/api/graph/inputs", { [inp.name]: now }); }
        catch (e) { $("graph-error").textContent = String(e.message || e); }
      }, 30);
    };
    el.oninput = send;
    el.onchange = send;
    label.append(name, el, out);
    box.appendChild(label);
  }
  buildParams(g);
}

// ---- the graph's live component parameters as sliders ----------------------

let paramChanges = 0;

// A slider's range: the declared bounds, and where a side is unbounded,
// twice the value's size (at least 1) beyond it.
function paramRange(p) {
  const v = p.value == null ? (p.min != null ? p.min : 0) : p.value;
  const span = 2 * Math.max(Math.abs(v), 1);
  const lo = p.min != null ? p.min : v - span;
  const hi = p.max != null ? p.max : v + span;
  return [lo, hi, p.integer ? 1 : (hi - lo) / 200, v];
}

function buildParams(g) {
  paramChanges = g.param_changes;
  const box = $("graph-params");
  box.replaceChildren();
  for (const c of g.components || []) {
    for (const p of c.params) {
      const label = document.createElement("label");
      const name = document.createElement("span");
      name.textContent = c.name + "." + p.name;
      name.title = (p.doc || c.kind) + (p.unit ? " (" + p.unit + ")" : "");
      const out = document.createElement("output");
      const el = document.createElement("input");
      el.id = "param-" + c.name + "-" + p.name;
      const [lo, hi, step, v] = paramRange(p);
      Object.assign(el, { type: "range", min: lo, max: hi, step, value: v });
      out.textContent = p.value == null ? "–" : p.value;
      let pending = null;
      // Sends the newest value at most every 30 ms while the slider moves.
      el.oninput = el.onchange = () => {
        out.textContent = el.value;
        if (pending) return;
        pending = setTimeout(async () => {
          pending = null;
          try {
            $("graph-error").textContent = "";
            const now = await api("POST", "/api/graph/params", { component: c.name, param: p.name, value: Number(el.value) });
            paramChanges = now.param_changes;
          } catch (e) { $("graph-error").textContent = String(e.message || e); }
        }, 30);
      };
      label.append(name, el, out);
      box.appendChild(label);
    }
  }
}

// A stage (or another client) changed a parameter: show the values now.
async function refreshParams() {
  try {
    const g = await api("GET", "/api/graph");
    paramChanges = g.param_changes;
    for (const c of g.components || []) {
      for (const p of c.params) {
        const el = $("param-" + c.name + "-" + p.name);
        if (!el || p.value == null || document.activeElement === el) continue;
        el.value = p.value;
        el.nextSibling.textContent = p.value;
      }
    }
  } catch (_) { /* shown by the state badge */ }
}

function showGraph(g) {
  const p = g.position;
  if (!graphPos || graphPos[0] !== p[0] || graphPos[1] !== p[1]) {
    trail.push(g.pen_down ? p : null);
    if (trail.length > 50000) trail = trail.slice(-40000);
  }
  graphPos = p;
  $("position").textContent = "x " + p[0].toFixed(2) + "  y " + p[1].toFixed(2) + (g.pen_down ? "" : "  (pen up)");
  if (g.error) $("graph-error").textContent = "the graph stopped: " + g.error;
  if (g.param_changes !== paramChanges) { paramChanges = g.param_changes; refreshParams(); }
}

async function refreshNodes() {
  try {
    const nodes = await api("GET", "/api/nodes");
    // Nodes simulated in the server have no link to pair on.
    $("pair").hidden = nodes.every((n) => n.kind === "sim");
    const tb = document.querySelector("#nodes tbody");
    tb.replaceChildren(...nodes.map((n) => {
      const tr = document.createElement("tr");
      const link = n.link && n.link.startsWith("Established") ? "up" : (n.link || "–");
      for (const v of [n.name, n.kind, link, n.rtt_us, n.retransmits, n.clock_error_us == null ? "–" : n.clock_error_us.toFixed(1), n.firmware]) {
        const td = document.createElement("td"); td.textContent = v == null ? "–" : v; tr.appendChild(td);
      }
      const td = document.createElement("td");
      const b = document.createElement("button");
      b.textContent = n.identifying ? "blinking" : "identify";
      b.title = "Blink the node's LED for 5 s";
      b.onclick = () => act("POST", "/api/nodes/" + encodeURIComponent(n.name) + "/identify", { seconds: 5 }).then(refreshNodes);
      td.appendChild(b); tr.appendChild(td);
      return tr;
    }));
  } catch (_) { /* shown by the state badge */ }
}

async function main() {
  machine = await api("GET", "/api/machine");
  $("machine-name").textContent = machine.name;
  document.title = "motet · " + machine.name;
  buildJog();
  $("file").onchange = (e) => e.target.files[0] && upload(e.target.files[0]);
  $("replace").onclick = () => lastFile && upload(lastFile);
  $("start").onclick = () => { trail = []; if (job) act("POST", "/api/jobs/" + job.id + "/start"); };
  $("enqueue").onclick = () => job && act("POST", "/api/queue", { job: job.id }).then(refreshQueue);
  $("queue-start").onclick = () => { trail = []; act("POST", "/api/queue/start"); };
  $("pause").onclick = () => act("POST", "/api/pause");
  $("resume").onclick = () => act("POST", "/api/resume");
  $("cancel").onclick = () => act("POST", "/api/cancel");
  $("unlock").onclick = () => act("POST", "/api/unlock");
  $("control").onclick = () => act("POST", "/api/control");
  $("estop").onclick = () => {
    // When the person pressed it, for the stop's own figure (docs/api.md).
    window.motetStats.estopPressedWall = Date.now();
    return act("POST", "/api/estop");
  };
  $("pair").onclick = async () => {
    const done = await act("POST", "/api/nodes/pair");
    if (done) addEvents([{ t_us: 0, level: "info", message: "paired: " + done.file }]);
    refreshNodes();
  };
  $("zero").onclick = () => act("POST", "/api/position", { axes: Object.fromEntries(machine.axes.map((a) => [a.name, 0])) });
  try { buildGraph(await api("GET", "/api/graph")); } catch (_) { /* no graph: a job machine */ }
  connect();
  refreshNodes();
  setInterval(refreshNodes, 2000);
  requestAnimationFrame(frame);
  document.body.dataset.ready = "1";
}

main().catch(showError);
