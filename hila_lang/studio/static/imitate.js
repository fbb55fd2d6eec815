// hila studio, page 2: Imitate -- drag a task scene's ICPs, via points and avoid discs; OSILA redraws the path.
import { $, api, post, socket, applyH, inv3, fitH, polyline, handle, fill } from "/static/common.js";

export const html = `
  <p class="help">Drag the task's ICPs: OSILA redraws the path as you drag. Double-click an ICP to leave it out.
  Click <b>Add via</b> or <b>Add avoid</b>, then click on the picture.</p>
  <div class="toolbar">
    <label>Template <select id="imitate-template" data-testid="imitate-template"></select></label>
    <button id="add-via" data-testid="add-via">Add via</button>
    <button id="add-avoid" data-testid="add-avoid">Add avoid</button>
    <label>radius (mm) <input id="avoid-radius" type="number" value="10" min="1" style="width: 4.5em"></label>
    <label><input type="checkbox" id="show-controls" data-testid="show-controls"> controls (TPS, similarity, DMP)</label>
    <span id="unbound"></span>
    <button id="export" data-testid="export">Export CSV + .hila</button>
    <button id="explain" data-testid="explain">Explain</button>
  </div>
  <div class="row">
    <div class="stage"><canvas id="imitate-canvas" data-testid="imitate-canvas" width="760" height="560"></canvas><div id="imitate-handles" class="handles"></div></div>
    <div class="side">
      <div class="legend"><span class="sw tmpl"></span>demonstration <span class="sw osila"></span>OSILA
        <span class="sw tps"></span>TPS <span class="sw sim"></span>similarity <span class="sw dmp"></span>DMP</div>
      <div id="imitate-names" class="names" title="task points: rename them for the exported program"></div>
      <pre id="imitate-reason" data-testid="imitate-reason">open a template</pre>
      <textarea id="export-text" data-testid="export-text" rows="12" readonly></textarea>
      <div id="export-links"></div>
    </div>
  </div>`;

// the page's state: the template (t), its task scene (task ICPs, their names, via, avoid), the
// last path OSILA sent (seq: the last scene sent, shown: the last answered); H: plane -> pixels
export const state = { seq: 0, shown: 0, via: [], avoid: [], task: {}, names: {}, mode: null };
const I = state;
const CONTROL_COLOURS = { tps: "#8e24aa", similarity: "#43a047", "dmp-aligned": "#ef6c00" };

const ws = socket("/ws/imitate", (r) => {
  if (r.seq < I.shown) return;
  I.shown = r.seq; I.serverMs = r.server_ms;
  if (r.error) { $("imitate-reason").textContent = "OSILA: " + r.error; I.path = null; }
  else { I.path = r.path; I.controls = r.controls || null; $("imitate-reason").textContent = r.reason.join("\n"); }
  draw();
  $("imitate-canvas").dataset.seq = r.seq;
  if (I.onPath) I.onPath(r);
});
const scene = () => ({ template: I.name, icps: I.task, names: I.names, via: I.via, avoid: I.avoid, controls: $("show-controls").checked });
const request = () => ws.send(Object.assign(scene(), { seq: ++I.seq }));

async function openTemplate() {
  I.name = $("imitate-template").value; if (!I.name) return;
  I.t = await api("/api/template?path=" + encodeURIComponent(I.name));
  I.task = JSON.parse(JSON.stringify(I.t.icps)); I.names = {}; I.via = []; I.avoid = []; I.path = null;
  const c = $("imitate-canvas");
  I.H = fitH([...I.t.path, ...Object.values(I.t.icps)], c.width, c.height, 90); I.Hinv = inv3(I.H);
  draw(); request();
}

function draw() {
  const c = $("imitate-canvas"), ctx = c.getContext("2d");
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  if (!I.t) return;
  ctx.fillStyle = "#777"; ctx.font = "12px sans-serif";
  ctx.fillText(I.t.dim === 3 ? "seen from above (x right, y up); heights are kept while you drag" : "x right, y up", 8, 16);
  polyline(ctx, I.t.path, I.H, "#bbb", 2, [5, 4]);
  if (I.controls) for (const [k, p] of Object.entries(I.controls)) polyline(ctx, p, I.H, CONTROL_COLOURS[k] || "#999", 1.5);
  polyline(ctx, I.path, I.H, "#1565c0", 3);
  for (const a of I.avoid) { const [u, v] = applyH(I.H, a.centre[0], a.centre[1]), r = a.radius * I.H[0][0];
    ctx.beginPath(); ctx.fillStyle = "rgba(239,108,0,.2)"; ctx.arc(u, v, Math.abs(r), 0, 7); ctx.fill(); }
  for (const [k, p] of Object.entries(I.t.icps)) { const [u, v] = applyH(I.H, p[0], p[1]);
    ctx.fillStyle = "#aaa"; ctx.fillRect(u - 3, v - 3, 6, 6); ctx.fillText(k, u + 5, v + 12); }
  const layer = $("imitate-handles"); if (layer.dataset.dragging) return;   // the handle being dragged stays
  layer.innerHTML = "";
  const dragTo = (p) => (x, y) => { const q = applyH(I.Hinv, x, y); p[0] = q[0]; p[1] = q[1]; request(); };
  for (const [name, p] of Object.entries(I.task)) {
    const [u, v] = applyH(I.H, p[0], p[1]);
    const shown = I.names[name] && I.names[name] !== name ? name + " = " + I.names[name] : name;
    handle(layer, "icp-" + name, "", shown, u, v, dragTo(p), draw, () => { delete I.task[name]; draw(); request(); });
  }
  // the task scene's point names (what an exported program calls them): rename here
  const names = $("imitate-names"); names.innerHTML = "";
  for (const name of Object.keys(I.task)) {
    const row = document.createElement("div"), label = document.createElement("span"), input = document.createElement("input");
    label.textContent = name + " \u2192 point "; input.value = I.names[name] || name; input.size = 10;
    input.dataset.testid = "name-icp-" + name; input.title = "the name the exported .hila program gives this point";
    input.addEventListener("change", () => { I.names[name] = input.value.trim(); draw(); });
    row.appendChild(label); row.appendChild(input); names.appendChild(row);
  }
  I.via.forEach((p, i) => { const [u, v] = applyH(I.H, p[0], p[1]);
    handle(layer, "via-" + (i + 1), "via", "via " + (i + 1), u, v, dragTo(p), draw, () => { I.via.splice(i, 1); draw(); request(); }); });
  I.avoid.forEach((a, i) => { const [u, v] = applyH(I.H, a.centre[0], a.centre[1]);
    const el = handle(layer, "avoid-" + (i + 1), "avoid", "avoid " + (i + 1), u, v, dragTo(a.centre), draw, () => { I.avoid.splice(i, 1); draw(); request(); });
    const r = Math.abs(a.radius * I.H[0][0]) * 2; el.style.width = r + "px"; el.style.height = r + "px"; });
  const un = $("unbound"); un.innerHTML = "";
  for (const k of Object.keys(I.t.icps).filter((k) => !(k in I.task))) {
    const b = document.createElement("button"); b.textContent = "+ " + k; b.dataset.testid = "add-icp-" + k;
    b.onclick = () => { I.task[k] = I.t.icps[k].slice(); draw(); request(); }; un.appendChild(b); }
}

function arm(which) {
  I.mode = I.mode === which ? null : which;
  $("add-via").classList.toggle("armed", I.mode === "via"); $("add-avoid").classList.toggle("armed", I.mode === "avoid");
}
function nearest(path, x, y) { let b = 0, bd = Infinity; path.forEach((p, i) => { const d = (p[0] - x) ** 2 + (p[1] - y) ** 2; if (d < bd) { bd = d; b = i; } }); return b; }
function place(e) {
  if (!I.t || !I.mode) return;
  const [x, y] = applyH(I.Hinv, e.offsetX, e.offsetY);
  const z = I.t.dim === 3 ? (I.path ? I.path[nearest(I.path, x, y)][2] : I.t.path[0][2]) : null;
  const p = z === null ? [x, y] : [x, y, z];
  if (I.mode === "via") I.via.push(p); else I.avoid.push({ centre: p, radius: (+$("avoid-radius").value || 10) / 1000 });
  arm(null); draw(); request();
}
async function exportScene() {
  try { const r = await post("/api/imitate/export", scene());
    $("export-text").value = r.hila + "\n# --- path (CSV) ---\n" + r.csv.split("\n").slice(0, 6).join("\n") + "\n# ...";
    const links = $("export-links"); links.innerHTML = "";
    for (const [text, name, type] of [[r.csv, "imitated.csv", "text/csv"], [r.hila, "scene.hila", "text/plain"]]) {
      const a = document.createElement("a"); a.href = URL.createObjectURL(new Blob([text], { type })); a.download = name;
      a.textContent = "download " + name + "  "; links.appendChild(a); }
  } catch (err) { $("export-text").value = "error: " + err.message; }
}
async function explain() {
  try { $("imitate-reason").textContent = (await post("/api/imitate/explain", scene())).lines.join("\n"); }
  catch (err) { $("imitate-reason").textContent = "error: " + err.message; }
}

export async function mount() {
  $("imitate-template").addEventListener("change", openTemplate);
  $("add-via").addEventListener("click", () => arm("via"));
  $("add-avoid").addEventListener("click", () => arm("avoid"));
  $("imitate-canvas").addEventListener("click", place);
  $("show-controls").addEventListener("change", request);
  $("export").addEventListener("click", exportScene);
  $("explain").addEventListener("click", explain);
}

export async function files(list) {
  fill($("imitate-template"), list.filter((f) => f.endsWith(".yaml") && !f.endsWith(".icps.yaml")).map((f) => [f, f]),
    '<option value="">choose…</option>');
}
