// hila studio, page 3: Run & watch -- write a program (checked as you type), run it or a recording, watch it.
import { $, api, post, socket, fitH, polyline, fill, refreshFiles, askingToOverwrite } from "/static/common.js";

export const html = `
  <p class="help">Write or open a program; problems show as you type. <b>Start</b> loads it on a back end,
  then <b>Step</b> or <b>Run</b>. Click a state in the graph to set a breakpoint. <span id="world-hint" data-testid="world-hint"></span></p>
  <div class="toolbar">
    <label>Program <select id="program" data-testid="program-select"></select></label>
    <button id="program-save" data-testid="program-save">Save</button>
    <label>back end <select id="backend" data-testid="backend"><option value="dry">dry (fast)</option><option value="pybullet">PyBullet</option></select></label>
    <label>robot <select id="robot-choice" data-testid="robot-choice"></select></label>
    <span id="world-settings"></span>
    <span class="sep"></span>
    <button id="btn-start" class="primary" data-testid="start">Start</button>
    <button id="btn-step" data-testid="step">Step</button>
    <button id="btn-run" data-testid="run">Run</button>
    <button id="btn-back" data-testid="back">Back</button>
    <button id="btn-reload" data-testid="reload">Reload</button>
    <button id="btn-stop" data-testid="stop">Stop</button>
    <span class="sep"></span>
    <label>Recording <select id="recording" data-testid="recording-select"></select></label>
    <input type="range" id="scrub" min="0" max="0" value="0" data-testid="scrub" disabled>
    <span id="scrub-at" data-testid="scrub-at"></span>
  </div>
  <div class="row">
    <div class="col">
      <textarea id="program-editor" data-testid="program-editor" spellcheck="false" wrap="off" rows="22"></textarea>
      <ul id="problems" data-testid="problems"></ul>
    </div>
    <div class="col">
      <div id="run-status" data-testid="run-status" class="status">not started</div>
      <svg id="fsm" data-testid="fsm" width="520" height="330"></svg>
      <div class="row">
        <div id="board" data-testid="board"></div>
        <img id="eye" data-testid="eye" alt="" hidden>
        <canvas id="top-view" data-testid="top-view" width="220" height="220"></canvas>
      </div>
      <div id="robot-box" hidden><img id="robot" data-testid="robot-view" alt="the robot, rendered by PyBullet">
        <br><label>turn the view <input type="range" id="azimuth" min="-180" max="180" value="35" data-testid="azimuth"></label>
        <span class="muted">planned path blue, executed orange</span></div>
      <pre id="trace" data-testid="trace"></pre>
    </div>
  </div>`;

// the page's state: the state machine (graph) and its layout, the breakpoints the page set, the
// session's last snapshot (state), what the program's world offers (offered: setting -> {value: label})
export const state = { breaks: new Set(), offered: {} };
const R = state;

const ws = socket("/ws/run", onMessage);
const send = (doc) => ws.send(doc);
function traceAdd(text) { const t = $("trace"); t.textContent += text; t.scrollTop = t.scrollHeight; }

function onMessage(msg) {
  if (msg.type === "fsm") { R.graph = msg.graph; $("trace").textContent = ""; drawFSM(null);
    const s = $("scrub"); s.disabled = msg.length == null; s.max = msg.length || 0; s.value = 0; }
  else if (msg.type === "out") traceAdd(msg.text);
  else if (msg.type === "error") { traceAdd("error: " + msg.text + "\n"); $("run-status").textContent = "error: " + msg.text; }
  else if (msg.type === "state" || msg.type === "step") {
    R.state = msg;
    drawFSM(msg.current);
    $("run-status").textContent = msg.done ? `finished after ${msg.steps} steps` :
      (msg.waiting ? "your turn: choose on the board" : `at ${msg.current} (step ${msg.steps})`);
    $("run-status").dataset.done = msg.done ? "1" : "0";
    drawBoard(msg.board, msg.waiting);
    if (msg.eye) { $("eye").src = "data:image/png;base64," + msg.eye; $("eye").hidden = false; }
    drawTop(msg.path);
    if (msg.robot) { $("robot").src = "data:image/png;base64," + msg.robot; $("robot-box").hidden = false; }
    if (msg.length != null) $("scrub-at").textContent = `step ${msg.steps} of ${msg.length}` + (msg.entry ? ": " + msg.entry : "");
  }
}

// the state machine's layout: layers by distance from the start state, in an svg 520 wide
export const FSM_WIDTH = 400, FSM_LEFT = 60, FSM_TOP = 20, FSM_HEIGHT = 300;
export function layout(graph) {
  const depth = { [graph.start]: 0 }, q = [graph.start], out = {};
  for (const [a, b] of graph.edges) (out[a] = out[a] || []).push(b);
  while (q.length) { const a = q.shift(); for (const b of out[a] || []) if (!(b in depth)) { depth[b] = depth[a] + 1; q.push(b); } }
  const rows = {}, pos = {};
  for (const n of graph.nodes) { const d = depth[n.name] ?? 0; (rows[d] = rows[d] || []).push(n.name); }
  const nRows = Object.keys(rows).length;
  for (const [d, names] of Object.entries(rows))
    names.forEach((n, i) => { pos[n] = [FSM_LEFT + (i + 0.5) * FSM_WIDTH / names.length, FSM_TOP + (+d) * FSM_HEIGHT / Math.max(nRows, 1)]; });
  return pos;
}
function drawFSM(current) {
  const svg = $("fsm"); if (!R.graph) return;
  const pos = R.pos && R.posFor === R.graph ? R.pos : (R.pos = layout(R.graph), R.posFor = R.graph, R.pos);
  const h = Math.max(...Object.values(pos).map((p) => p[1])) + 30; svg.setAttribute("height", Math.max(h, 120));
  let s = '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="6" markerHeight="6" orient="auto"><path d="M0,0L10,5L0,10z" fill="#9aa"/></marker></defs>';
  for (const [a, b] of R.graph.edges) { const p = pos[a], q = pos[b]; if (!p || !q) continue;
    const mx = (p[0] + q[0]) / 2 + (q[1] <= p[1] ? 70 : 0);
    s += `<path class="edge" d="M${p[0]},${p[1] + 9} Q${mx},${(p[1] + q[1]) / 2} ${q[0]},${q[1] - 9}"/>`; }
  for (const n of R.graph.nodes) { const [x, y] = pos[n.name], cur = n.name === current;
    const label = n.name.length > 26 ? "…" + n.name.slice(-25) : n.name;
    s += `<g class="node${cur ? " current" : ""}${R.breaks.has(n.name) ? " brk" : ""}" data-state="${n.name}"${cur ? ' data-testid="fsm-current"' : ""}>` +
      `<rect x="${x - 62}" y="${y - 9}" width="124" height="18" rx="4"/><text x="${x}" y="${y + 4}" text-anchor="middle">${label}</text><title>${n.name} (${n.kind}, line ${n.line})</title></g>`; }
  svg.innerHTML = s;
  svg.querySelectorAll(".node").forEach((g) => g.addEventListener("click", () => {
    const st = g.dataset.state;   // a click sets a breakpoint there, a second click clears it
    if (R.breaks.has(st)) { R.breaks.delete(st); send({ cmd: "clear", state: st }); }
    else { R.breaks.add(st); send({ cmd: "break", state: st }); }
    drawFSM(R.state ? R.state.current : current); }));
}

// the world's board (its plug-in's): a grid of buttons; a person's choice is answered to the world
function drawBoard(board, waiting) {
  const el = $("board"); el.innerHTML = ""; el.classList.toggle("waiting", !!waiting);
  if (!board) return;
  el.style.gridTemplateColumns = `repeat(${board.columns}, 48px)`;
  board.cells.forEach((cell, i) => { const b = document.createElement("button"); b.textContent = cell.label;
    b.dataset.testid = "cell-" + (i + 1); b.title = "cell " + (i + 1);
    b.disabled = !waiting || cell.answer === null;
    b.onclick = () => { send({ cmd: "answer", text: cell.answer }); el.classList.remove("waiting"); };
    el.appendChild(b); });
}
function drawTop(path) {
  const c = $("top-view"), ctx = c.getContext("2d"); ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  ctx.fillStyle = "#777"; ctx.font = "11px sans-serif"; ctx.fillText("last path, from above", 4, 12);
  if (path && path.length > 1) polyline(ctx, path, fitH(path, c.width, c.height, 24), "#1565c0", 2);
}

// what the program's world offers on this page: a menu per setting, and a line of help
function offer(offered, hint) {
  const box = $("world-settings"), keep = worldSettings();
  R.offered = offered; box.innerHTML = "";
  for (const [name, values] of Object.entries(offered)) {
    const label = document.createElement("label"), sel = document.createElement("select");
    sel.id = "setting-" + name; sel.dataset.testid = name; sel.dataset.setting = name;
    fill(sel, Object.entries(values));
    if (keep[name] in values) sel.value = keep[name];
    label.append(name + " ", sel); box.appendChild(label);
  }
  $("world-hint").textContent = hint || "";
}
function worldSettings() {
  return Object.fromEntries([...$("world-settings").querySelectorAll("select")].map((s) => [s.dataset.setting, s.value]));
}

let checkTimer = null;
async function check() {
  const r = await post("/api/check", { path: $("program").value || "untitled.hila", text: $("program-editor").value });
  offer(r.offered, r.hint);
  const ul = $("problems"); ul.innerHTML = "";
  if (!r.problems.length) { const li = document.createElement("li"); li.className = "ok"; li.textContent = "no problems"; ul.appendChild(li); }
  for (const p of r.problems) { const li = document.createElement("li"); li.className = p.severity;
    li.textContent = `${p.line + 1}:${p.character + 1}: ${p.severity}: ${p.message}`; ul.appendChild(li); }
}

export async function mount() {
  $("program").addEventListener("change", async () => {
    const p = $("program").value; if (!p) return;
    $("program-editor").value = await api("/api/file?path=" + encodeURIComponent(p)); check();
  });
  $("program-editor").addEventListener("input", () => { clearTimeout(checkTimer); checkTimer = setTimeout(check, 250); });
  $("program-save").addEventListener("click", async () => {
    const opened = $("program").value, p = opened || prompt("save as (e.g. mine.hila)"); if (!p) return;
    await askingToOverwrite((o) => api("/api/file?path=" + encodeURIComponent(p) + (o || opened ? "&overwrite=1" : ""),
      { method: "PUT", body: $("program-editor").value }));  // the file it opened is replaced; another name asks
    await refreshFiles(); $("program").value = p;
  });
  $("btn-start").addEventListener("click", () => { R.breaks.clear();
    send({ cmd: "start", path: $("program").value, backend: $("backend").value, robot: $("robot-choice").value,
      settings: worldSettings() }); });
  for (const c of ["step", "run", "back", "reload", "stop"]) $("btn-" + c).addEventListener("click", () => send({ cmd: c }));
  $("recording").addEventListener("change", () => { if ($("recording").value) send({ cmd: "open", path: $("recording").value }); });
  $("azimuth").addEventListener("change", () => send({ cmd: "view", azimuth: +$("azimuth").value }));
  $("scrub").addEventListener("input", () => send({ cmd: "scrub", n: +$("scrub").value }));
  const robots = await api("/api/robots");   // the robots a run may move (--robot), the default first
  fill($("robot-choice"), robots.map((r) => [r.name, r.name]));
  [...$("robot-choice").options].forEach((o, i) => { o.title = robots[i].doc; });
}

export async function files(list) {
  fill($("program"), list.filter((f) => f.endsWith(".hila")).map((f) => [f, f]), '<option value="">choose…</option>');
  fill($("recording"), list.filter((f) => f.endsWith(".hilarec")).map((f) => [f, f]), '<option value="">choose…</option>');
}
