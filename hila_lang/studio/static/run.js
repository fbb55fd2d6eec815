// hila studio, page 3: Run & watch -- write a program (checked as you type), run it or a recording, watch it.
import { $, api, post, socket, fitH, polyline, fill, refreshFiles, askingToOverwrite } from "/static/common.js";

export const html = `
  <p class="help">Write or open a program; problems show as you type. <b>Start</b> loads it on a back end,
  then <b>Step</b> or <b>Run</b>. Click a state in the graph to set a breakpoint. <span id="world-hint" data-testid="world-hint"></span>
  <br><span class="muted">Worlds a program may name (<code>world NAME</code>): <span id="world-list" data-testid="world-list"></span></span></p>
  <div class="toolbar">
    <label>Program <select id="program" data-testid="program-select"></select></label>
    <button id="program-save" data-testid="program-save">Save</button>
    <button id="program-save-as" data-testid="program-save-as">Save As…</button>
    <span id="program-dirty" data-testid="program-dirty" class="dirty-mark" hidden>● unsaved changes</span>
    <span id="program-save-status" data-testid="program-save-status" class="muted"></span>
    <label>back end <select id="backend" data-testid="backend"></select></label>
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
// session's last snapshot (state), what the program's world offers (offered: setting -> {value: label}),
// the program the editor holds (open: its file, or null for a new one; saved: its text as last
// read or written; files: the folder's files), the last check's problems and the program started last (running)
export const state = { breaks: new Set(), offered: {}, open: null, saved: "", files: [], problems: [], running: null };
const R = state;

const ws = socket("/ws/run", onMessage);
const send = (doc) => ws.send(doc);
function traceAdd(text) { const t = $("trace"); t.textContent += text; t.scrollTop = t.scrollHeight; }
// the line at the top of the run: what happened, lit by its kind ("failed", "done" or "")
function status(text, kind) { const el = $("run-status"); el.textContent = text; el.className = "status " + kind; }

function onMessage(msg) {
  if (msg.type === "fsm") { R.graph = msg.graph; $("trace").textContent = ""; drawFSM(null);
    const s = $("scrub"); s.disabled = msg.length == null; s.max = msg.length || 0; s.value = 0;
    if (msg.program != null && msg.program !== $("program-editor").value &&   // a recording: its program, unnamed
        (!dirty() || confirm("Show the recording's program in the editor? Its unsaved changes would be lost."))) {
      $("program-editor").value = msg.program; opened(null, msg.program); check(); } }
  else if (msg.type === "out") traceAdd(msg.text);
  else if (msg.type === "error") { traceAdd("error: " + msg.text + "\n"); status("error: " + msg.text, "failed"); }
  else if (msg.type === "state" || msg.type === "step") {
    R.state = msg;
    drawFSM(msg.current);
    const f = msg.failed;
    if (f) status(`failed in ${f.state}${f.line ? ` (line ${f.line})` : ""}: ${f.message}`, "failed");
    else if (msg.done) status(msg.outcome ? `finished: ${msg.outcome} (after ${msg.steps} steps)` : `finished after ${msg.steps} steps`,
      "done");
    else status(msg.waiting ? "your turn: choose on the board" : `at ${msg.current} (step ${msg.steps})`, "");
    $("run-status").dataset.done = msg.done ? "1" : "0";
    showProblems();
    drawBoard(msg.board, msg.waiting);
    if (msg.eye) { $("eye").src = "data:image/png;base64," + msg.eye; $("eye").hidden = false; }
    drawTop(msg.path);
    if (msg.robot) { $("robot").src = "data:image/png;base64," + msg.robot; $("robot-box").hidden = false; }
    if (msg.length != null)   // the step just replayed, and the state lit in the graph: the next one
      $("scrub-at").textContent = `after step ${msg.steps} of ${msg.length}` + (msg.entry ? ": " + msg.entry.trim() : "") +
        (msg.done ? " (the end)" : ` · next: ${msg.current}`);
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
  const failed = R.state && R.state.failed ? R.state.failed.state : null;
  for (const n of R.graph.nodes) { const [x, y] = pos[n.name], cur = n.name === current;
    const label = n.name.length > 26 ? "…" + n.name.slice(-25) : n.name;
    s += `<g class="node${cur ? " current" : ""}${n.name === failed ? " failed" : ""}${R.breaks.has(n.name) ? " brk" : ""}" data-state="${n.name}"${cur ? ' data-testid="fsm-current"' : ""}>` +
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
    b.dataset.testid = "cell-" + (i + 1); b.title = "cell " + (i + 1) + (cell.note ? ": " + cell.note : "");
    if (cell.note) { b.classList.add("note"); b.dataset.note = cell.note; }
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
  R.problems = r.problems; showProblems();
}
// the editor's problems: the check's, and the state a run failed in, at its program line (a click
// puts the editor's cursor on the line)
function showProblems() {
  const f = R.state && R.state.failed && R.running === $("program").value ? R.state.failed : null;  // this program's run
  const ul = $("problems"), items = R.problems.map((p) =>
    [p.severity, `${p.line + 1}:${p.character + 1}: ${p.severity}: ${p.message}`, p.line]);
  if (f) items.unshift(["error run-failed", `${f.line || "?"}: run failed in ${f.state}: ${f.message}`,
    f.line ? f.line - 1 : null]);
  ul.innerHTML = "";
  if (!items.some(([cls]) => cls !== "note")) items.unshift(["ok", "no problems", null]);  // a note is not a problem
  for (const [cls, text, line] of items) { const li = document.createElement("li"); li.className = cls; li.textContent = text;
    if (cls.includes("run-failed")) li.dataset.testid = "run-problem";
    if (line != null) li.addEventListener("click", () => showLine(line));
    ul.appendChild(li); }
}
function showLine(line) {   // select line (0-based) in the editor
  const ed = $("program-editor"), lines = ed.value.split("\n"), at = lines.slice(0, line).join("\n").length + (line ? 1 : 0);
  ed.focus(); ed.setSelectionRange(at, at + (lines[line] || "").length);
}

// ---------------------------------------------------------------- nothing lost: unsaved changes, Save, Save As
// The tab and the toolbar say when the editor holds unsaved changes (and leaving the page, or
// opening another program, asks); Save writes the file it opened, Save As asks a name and asks
// again before it replaces another file (the server refuses with 409 until told overwrite).
const dirty = () => $("program-editor").value !== R.saved;
function markDirty() {
  const d = dirty(), tab = document.querySelector('[data-testid="tab-run"]');
  $("program-dirty").hidden = !d;
  if (tab) tab.classList.toggle("dirty", d);
  document.title = (d ? "● " : "") + "hila studio";
}
function opened(name, text) { R.open = name || null; R.saved = text; $("program").value = name || ""; markDirty(); }

// write the editor's text to `name`; `overwrite`: replace an existing file (the person said so, or
// it is the file the editor opened); else a refusal because the file exists (409) asks first
async function saveTo(name, overwrite) {
  const text = $("program-editor").value, put = (o) => api("/api/file?path=" + encodeURIComponent(name) +
    (o ? "&overwrite=1" : ""), { method: "PUT", body: text });
  try { await (overwrite ? put(true) : askingToOverwrite(put)); }
  catch (e) { $("program-save-status").textContent = e.message.startsWith("not saved") ? e.message : "not saved: " + e.message; return false; }
  await refreshFiles(); opened(name, text);
  $("program-save-status").textContent = "saved " + name;
  return true;
}
async function saveAs() {
  let name = prompt("save the program as (a name in the studio's folder, e.g. mine.hila)", R.open || "mine.hila");
  if (!name || !(name = name.trim())) { $("program-save-status").textContent = "not saved: no name given"; return false; }
  if (!name.endsWith(".hila")) name += ".hila";
  const exists = name !== R.open && R.files.includes(name);
  if (exists && !confirm(`${name} exists. Replace it with the editor's program?`)) {
    $("program-save-status").textContent = `not saved: ${name} exists`; return false; }
  return saveTo(name, exists || name === R.open);
}

export async function mount() {
  $("program").addEventListener("change", async () => {
    const p = $("program").value;
    if (dirty() && !confirm(`The editor has unsaved changes${R.open ? " to " + R.open : ""}. Discard them?`)) {
      $("program").value = R.open || ""; return; }
    if (!p) { opened(null, $("program-editor").value === R.saved ? "" : $("program-editor").value); return; }
    const text = await api("/api/file?path=" + encodeURIComponent(p));
    $("program-editor").value = text; opened(p, text); check();
  });
  $("program-editor").addEventListener("input", () => { markDirty(); clearTimeout(checkTimer); checkTimer = setTimeout(check, 250); });
  $("program-save").addEventListener("click", () => (R.open ? saveTo(R.open, true) : saveAs()));
  $("program-save-as").addEventListener("click", saveAs);
  window.addEventListener("beforeunload", (e) => { if (dirty()) { e.preventDefault(); e.returnValue = "unsaved changes"; } });
  $("btn-start").addEventListener("click", async () => {   // a run reads the file: unsaved changes are offered a save first
    if (dirty() && confirm(`Start runs ${R.open || "a saved program"}, without the editor's unsaved changes. Save them first?`)
        && !(await (R.open ? saveTo(R.open, true) : saveAs()))) return;
    R.breaks.clear(); R.running = $("program").value;
    send({ cmd: "start", path: $("program").value, backend: $("backend").value, robot: $("robot-choice").value,
      settings: worldSettings() }); });
  for (const c of ["step", "run", "back", "reload", "stop"]) $("btn-" + c).addEventListener("click", () => send({ cmd: c }));
  $("recording").addEventListener("change", () => { if ($("recording").value) send({ cmd: "open", path: $("recording").value }); });
  $("azimuth").addEventListener("change", () => send({ cmd: "view", azimuth: +$("azimuth").value }));
  $("scrub").addEventListener("input", () => send({ cmd: "scrub", n: +$("scrub").value }));
  // the registry's plug-ins: back ends (--backend), robots a run may move (--robot; the default
  // first) and the worlds a program may name, each with its one-line doc
  const reg = await api("/api/plugins");
  for (const [id, list] of [["backend", reg.backends], ["robot-choice", reg.robots]]) {
    fill($(id), list.map((r) => [r.name, r.name]));
    [...$(id).options].forEach((o, i) => { o.title = list[i].doc; });
  }
  $("world-list").innerHTML = "";
  reg.worlds.forEach((w, i) => { const c = document.createElement("code"); c.textContent = w.name; c.title = w.doc;
    $("world-list").append(i ? ", " : "", c); });
}

export async function files(list) {
  R.files = list;
  fill($("program"), list.filter((f) => f.endsWith(".hila")).map((f) => [f, f]), '<option value="">choose…</option>');
  $("program").value = R.open || "";
  fill($("recording"), list.filter((f) => f.endsWith(".hilarec")).map((f) => [f, f]), '<option value="">choose…</option>');
}
