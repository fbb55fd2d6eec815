// hila studio, page 1: Demonstrate -- draw a demonstration on a scene, place its ICPs, cut and save it.
import { $, api, post, applyH, inv3, fitH, handle, fill, refreshFiles, askingToOverwrite } from "/static/common.js";
import { html as cameraHtml, state as cameraState, mountCamera, showCamera } from "/static/camera.js";

export const html = `
  <p class="help">Draw a demonstration: move the pointer onto the picture, press and draw, lift, move away.
  Moves with the pen up are part of the path (reach, retract). Then switch to <b>Place ICPs</b>, click the
  points the task will move (they snap to the scene's marks and the path's ends), name the segments, and <b>Save</b>.</p>
  <div class="toolbar">
    <label>Scene <select id="scene" data-testid="scene-select"></select></label>
    <label class="file">Upload picture… <input type="file" id="upload-picture" accept="image/png,image/jpeg" data-testid="upload-picture"></label>
    <label>Open <select id="open-source" data-testid="open-source"><option value="">template / CSV / LASA…</option></select></label>
    <span class="sep"></span>
    <label><input type="radio" name="demo-mode" value="draw" checked data-testid="mode-draw"> Draw</label>
    <label><input type="radio" name="demo-mode" value="icp" data-testid="mode-icp"> Place ICPs</label>
    <label>ICP name <input id="icp-name" size="8" value="p1" data-testid="icp-name"></label>
    <button id="demo-finish" data-testid="demo-finish">Finish drawing</button>
    <button id="demo-clear" data-testid="demo-clear">Clear</button>
  </div>${cameraHtml}
  <div class="row"><div class="stage"><canvas id="demo-canvas" data-testid="demo-canvas" width="840" height="600"></canvas><div id="demo-handles" class="handles"></div></div>
  <div class="side"><b>ICPs</b> <span class="muted">(rename here; × removes; drag them on the picture)</span><div id="demo-icps" data-testid="demo-icps"></div></div></div>
  <div class="toolbar">
    <label>Segments <input id="seg-tags" size="22" value="reach,draw,retract" data-testid="segment-tags"></label>
    <label>contact <input id="seg-contact" size="10" value="draw" data-testid="segment-contact"></label>
    <label>cuts by <select id="seg-method" data-testid="segment-method"><option value="contact">pen down/up</option><option value="speed">speed dips</option><option value="kmeans">k-means</option><option value="changepoint">change points</option></select></label>
    <button id="propose" data-testid="propose-cuts">Propose cuts</button>
    <span class="muted">drag a cut on the speed plot to move it</span>
  </div>
  <canvas id="speed-plot" data-testid="speed-plot" width="840" height="140"></canvas>
  <div class="toolbar">
    <label>Template name <input id="template-name" data-testid="template-name" value="swipe" size="14"></label>
    <button id="save-template" class="primary" data-testid="save-template">Save template</button>
    <span id="picture-scene" data-testid="picture-scene"></span>
    <span id="save-status" data-testid="save-status" class="status"></span>
  </div>`;

// the page's state: the scene (H: plane -> pixels), the pointer samples, the learned path, its cuts, the ICPs
export const state = { samples: [], icps: {}, recording: false, done: false, scenes: [], pen: null, camera: cameraState };
const D = state;

const mode = () => document.querySelector('input[name="demo-mode"]:checked').value;
const tags = () => $("seg-tags").value.split(",").map((s) => s.trim()).filter(Boolean);
const contactTags = () => $("seg-contact").value.split(",").map((s) => s.trim()).filter(Boolean);

async function loadScene(name) {
  D.scene = await api("/api/scene?name=" + encodeURIComponent(name));
  D.H = D.scene.H; D.Hinv = inv3(D.H); D.source = null;
  const c = $("demo-canvas"); c.width = D.scene.width; c.height = D.scene.height;
  D.image = null;
  if (D.scene.image) { D.image = new Image(); D.image.onload = draw; D.image.src = D.scene.image; }
  clear();
  showCamera(name === "camera");
}
function clear() {
  D.samples = []; D.icps = {}; D.path = null; D.times = null; D.pen = null; D.cuts = []; D.speed = null; D.recording = false;
  D.done = false; D.saved = undefined; $("icp-name").value = "p1"; draw(); drawSpeed(); guide(); offerPictureScene();
}
// the line under Save: an error or a result until the next change, then what to do next
function say(text) { $("save-status").textContent = text; $("save-status").dataset.kind = text.startsWith("error") ? "error" : "result"; }
export function nextStep() {
  const n = Object.keys(D.icps).length;
  if (!D.path) return D.recording ? "drawing… (lift the pen and move off the picture, or click Finish drawing)" :
    "draw a demonstration: move in from the side, press and draw, lift, move out";
  const drawn = `${D.path.length} points at 20 Hz (${D.times[D.times.length - 1].toFixed(2)} s)`;
  if (!n) return drawn + "; now place the ICPs (Place ICPs, then click the picture)";
  return `${drawn}; ${n} ICP${n > 1 ? "s" : ""} placed (${Object.keys(D.icps).join(", ")}); name the segments and Save`;
}
function guide() { $("save-status").textContent = nextStep(); $("save-status").dataset.kind = "guide"; }
const planeAt = (u, v) => applyH(D.Hinv, u, v);

function draw() {
  const c = $("demo-canvas"), ctx = c.getContext("2d");
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  if (D.image && D.image.complete) ctx.drawImage(D.image, 0, 0, c.width, c.height);
  if (mode() === "icp")
    for (const f of D.scene ? D.scene.features : []) { const [u, v] = applyH(D.H, f.point[0], f.point[1]);
      ctx.strokeStyle = "#0a0"; ctx.strokeRect(u - 4, v - 4, 8, 8); }
  // the person's strokes: pen down solid (width from pressure), pen up dashed
  for (let i = 1; i < D.samples.length; i++) {
    const a = D.samples[i - 1], b = D.samples[i], [u0, v0] = applyH(D.H, a.x, a.y), [u1, v1] = applyH(D.H, b.x, b.y);
    ctx.beginPath(); ctx.setLineDash(b.down ? [] : [4, 4]); ctx.strokeStyle = b.down ? "#1a237e" : "#90a4ae";
    ctx.lineWidth = b.down ? 1.5 + 3 * (b.p || 0.5) : 1; ctx.moveTo(u0, v0); ctx.lineTo(u1, v1); ctx.stroke();
  }
  ctx.setLineDash([]);
  if (D.path && D.cuts) {   // the segments as hila will cut them, in colour
    const bounds = [0, ...D.cuts, D.path.length], colours = ["#e53935", "#43a047", "#1e88e5", "#8e24aa", "#fb8c00"];
    for (let k = 0; k + 1 < bounds.length; k++) {
      const seg = D.path.slice(bounds[k], bounds[k + 1] + 1);
      for (const p of seg) { const [u, v] = applyH(D.H, p[0], p[1]); ctx.fillStyle = colours[k % 5]; ctx.fillRect(u - 1.5, v - 1.5, 3, 3); }
    }
  }
  if (!D.samples.length && !D.path) {
    ctx.fillStyle = "rgba(0,0,0,.55)"; ctx.font = "15px sans-serif";
    ctx.fillText("move in from the side, press and draw, lift, move out", 12, c.height - 14);
  }
  const layer = $("demo-handles"); if (layer.dataset.dragging) return;   // the handle being dragged stays
  listIcps();
  layer.innerHTML = "";
  for (const [name, p] of Object.entries(D.icps)) {
    const [u, v] = applyH(D.H, p[0], p[1]);
    handle(layer, "demo-icp-" + name, "", name, u, v, (x, y) => { const q = planeAt(x, y); p[0] = q[0]; p[1] = q[1]; },
      draw, () => { delete D.icps[name]; draw(); guide(); });
  }
}
function listIcps() {   // rename (keeps the order) and remove
  const box = $("demo-icps"); box.innerHTML = "";
  for (const name of Object.keys(D.icps)) {
    const row = document.createElement("div"), input = document.createElement("input"), del = document.createElement("button");
    input.value = name; input.size = 10; input.dataset.testid = "rename-icp-" + name;
    input.addEventListener("change", () => { const to = input.value.trim();
      if (!to || to in D.icps) { input.value = name; return; }
      D.icps = Object.fromEntries(Object.entries(D.icps).map(([k, v]) => [k === name ? to : k, v])); draw(); });
    del.textContent = "×"; del.title = "remove " + name; del.dataset.testid = "remove-icp-" + name;
    del.onclick = () => { delete D.icps[name]; draw(); guide(); };
    const at = document.createElement("span"); at.className = "muted";
    at.textContent = " (" + D.icps[name].map((v) => v.toFixed(3)).join(", ") + ")";
    row.append(input, del, at); box.appendChild(row);
  }
}

function sample(e) {
  const [x, y] = planeAt(e.offsetX, e.offsetY);
  const down = e.pointerType === "touch" ? true : (e.buttons & 1) === 1;
  return { x, y, t: e.timeStamp, down, p: down ? (e.pressure || 0.5) : 0 };
}
function pointer(e) {
  if (mode() !== "draw" || D.done || !D.scene || D.scene.name === "camera") return;   // the camera draws there
  if (e.type === "pointerdown") try { $("demo-canvas").setPointerCapture(e.pointerId); } catch (err) { /* a synthesized pointer */ }
  if (!D.recording) { if (D.source) return; D.recording = true; D.samples = []; guide(); }
  const many = e.type === "pointermove" && e.getCoalescedEvents ? e.getCoalescedEvents() : [];
  for (const ev of many.length ? many : [e]) D.samples.push(sample(ev));
  if (e.type === "pointerdown" || e.type === "pointerup") D.samples[D.samples.length - 1].down = e.type === "pointerdown";
  draw();
}
async function finishDrawing() {
  if (!D.recording) return;
  D.recording = false; D.done = true;
  try {
    const r = await post("/api/demonstration", { samples: D.samples, z: D.scene.z, lift: D.scene.lift, k: tags().length || 1 });
    Object.assign(D, { path: r.path, times: r.times, pen: r.pen, cuts: r.cuts, speed: r.speed });
    $("seg-method").value = r.method; guide();
  } catch (err) { say("error: " + err.message); D.done = false; }
  draw(); drawSpeed();
}
function placeIcp(e) {
  if (mode() !== "icp" || !D.scene) return;
  const name = $("icp-name").value.trim();
  if (!name) { say("error: give the ICP a name first"); return; }
  let best = null, bestD = 14;     // snap to a scene's feature, or the path's start or end
  const offers = [...D.scene.features.map((f) => f.point)];
  if (D.path) offers.push(D.path[0], D.path[D.path.length - 1]);
  for (const p of offers) { const [u, v] = applyH(D.H, p[0], p[1]); const d = Math.hypot(u - e.offsetX, v - e.offsetY);
    if (d < bestD) { best = p; bestD = d; } }
  const [x, y] = planeAt(e.offsetX, e.offsetY);
  const dim = D.path ? D.path[0].length : (D.scene.z === null ? 2 : 3);
  D.icps[name] = best ? best.slice(0, dim) : (dim === 3 ? [x, y, D.scene.z ?? 0] : [x, y]);
  const m = name.match(/^(.*?)(\d+)$/); $("icp-name").value = m ? m[1] + (+m[2] + 1) : name + "2";
  draw(); guide();
}

async function openSource() {
  const v = $("open-source").value; if (!v) return;
  const i = v.indexOf(":"), t = await api(`/api/open?kind=${v.slice(0, i)}&name=${encodeURIComponent(v.slice(i + 1))}`);
  const c = $("demo-canvas");
  D.scene = { name: "open", width: c.width, height: c.height, z: null, features: [] };
  D.image = null; D.H = fitH([...t.path, ...Object.values(t.icps)], c.width, c.height); D.Hinv = inv3(D.H);
  D.samples = []; D.recording = false; D.done = true; D.source = v;
  D.path = t.path; D.times = t.times || t.path.map((_, i) => i * 0.05); D.icps = t.icps; D.pen = t.pen || null;
  if (t.segments.length) { $("seg-tags").value = t.segments.map((s) => s.tag).join(",");
    $("seg-contact").value = t.segments.filter((s) => s.contact).map((s) => s.tag).join(","); }
  $("template-name").value = t.name.replace(/[^A-Za-z0-9_]/g, "_");
  if (!D.pen && $("seg-method").value === "contact") $("seg-method").value = "speed";   // no pen recorded
  await propose(t.segments.length ? t.segments.slice(1).map((s) => s.start) : null); guide();
}
// a pen tracked by the Camera scene (camera.js): its path on the sheet seen from above, as a drawn one
async function useTrack(m) {
  D.scene = m.scene; D.H = D.scene.H; D.Hinv = inv3(D.H);
  const c = $("demo-canvas"); c.width = D.scene.width; c.height = D.scene.height;
  D.image = new Image(); D.image.onload = draw; D.image.src = D.scene.image;
  D.samples = []; D.recording = false; D.done = true; D.source = "camera";
  // the tracker saw the pen touch and leave the paper: recorded as a drawing's pen, cut there
  D.path = m.path; D.times = m.times; D.icps = m.icps; D.pen = m.pen; $("seg-method").value = "contact";
  await propose(null);
  say(`${m.path.length} points at 20 Hz (${m.times[m.times.length - 1].toFixed(2)} s)` +
    (m.cell ? `; ICPs: cell ${m.cell}'s corners and where the pen started` : "; ICPs: the sheet's corner markers") + "; name it and save");
}
async function propose(keep) {
  if (!D.path) return;
  if (!D.pen && $("seg-method").value === "contact") $("seg-method").value = "speed";   // no pen recorded
  try {
    const r = await post("/api/demonstration", { path: D.path, times: D.times, pen: D.pen, k: tags().length || 1, method: $("seg-method").value });
    D.speed = r.speed; D.proposed = r.cuts; D.cuts = keep || r.cuts;
  } catch (err) { say("error: " + err.message); }
  draw(); drawSpeed();
}

// the speed plot: x = sample index, cuts drawn red and dragged
export const SPEED_MARGIN = 4;
export const speedX = (i, T, width) => SPEED_MARGIN + (width - 2 * SPEED_MARGIN) * i / Math.max(T - 1, 1);
function drawSpeed() {
  const c = $("speed-plot"), ctx = c.getContext("2d");
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  ctx.fillStyle = "#555"; ctx.font = "11px sans-serif"; ctx.fillText("hand speed (the cuts hila proposes: drag them)", 6, 12);
  if (!D.speed) return;
  const T = D.speed.length, max = Math.max(...D.speed, 1e-9), X = (i) => speedX(i, T, c.width);
  ctx.strokeStyle = "#1565c0"; ctx.beginPath();
  D.speed.forEach((s, i) => { const y = c.height - 6 - (c.height - 24) * s / max; i ? ctx.lineTo(X(i), y) : ctx.moveTo(X(i), y); });
  ctx.stroke();
  const bounds = [0, ...D.cuts, T], tg = tags(), contact = contactTags();
  for (let k = 0; k + 1 < bounds.length; k++) {
    ctx.fillStyle = contact.includes(tg[k]) ? "rgba(46,125,50,.12)" : "rgba(0,0,0,0)";
    ctx.fillRect(X(bounds[k]), 16, X(bounds[k + 1]) - X(bounds[k]), c.height - 16);
    ctx.fillStyle = "#333"; ctx.fillText((tg[k] || "?") + (contact.includes(tg[k]) ? " (contact)" : ""), X(bounds[k]) + 4, 28);
  }
  ctx.strokeStyle = "#d32f2f"; ctx.lineWidth = 2;
  for (const cut of D.cuts) { ctx.beginPath(); ctx.moveTo(X(cut), 16); ctx.lineTo(X(cut), c.height); ctx.stroke(); }
  ctx.lineWidth = 1;
}
function dragCuts() {
  const c = $("speed-plot"); let which = -1;
  const idx = (e) => Math.round((e.offsetX - SPEED_MARGIN) / (c.width - 2 * SPEED_MARGIN) * (D.speed.length - 1));
  c.addEventListener("pointerdown", (e) => { if (!D.speed) return; const i = idx(e);
    let best = 1e9; D.cuts.forEach((cut, k) => { if (Math.abs(cut - i) < best) { best = Math.abs(cut - i); which = k; } });
    if (best > D.speed.length / 40 + 2) which = -1; else c.setPointerCapture(e.pointerId); });
  c.addEventListener("pointermove", (e) => { if (which < 0) return;
    const lo = which ? D.cuts[which - 1] + 1 : 1, hi = which + 1 < D.cuts.length ? D.cuts[which + 1] - 1 : D.speed.length - 1;
    D.cuts[which] = Math.max(lo, Math.min(hi, idx(e))); drawSpeed(); draw(); });
  c.addEventListener("pointerup", () => { which = -1; });
}

async function save() {
  if (!D.path) { say("error: draw a demonstration first"); return; }
  const tg = tags();
  if (D.cuts.length !== Math.max(tg.length - 1, 0)) await propose(null);
  try {
    const r = await askingToOverwrite((overwrite) => post("/api/save", { name: $("template-name").value.trim(), path: D.path,
      times: D.times, pen: D.pen, icps: D.icps, tags: tg, contact: contactTags(), method: $("seg-method").value, cuts: D.cuts,
      overwrite }));
    say(`saved ${r.template} (${r.segments.map((s) => s.tag + " " + s.start + "-" + s.stop).join(", ")}) = ${r.command}`);
    D.saved = r; refreshFiles(); offerPictureScene();
  } catch (err) { say("error: " + err.message); }
}

// a route saved on an uploaded picture: a button per world that takes the picture as its scene
// (studio/photoscene.py writes NAME_WORLD.yaml and the program NAME_WORLD.hila that runs it)
function offerPictureScene() {
  const box = $("picture-scene"), picture = D.scene && D.scene.picture;
  box.innerHTML = "";
  if (!picture || !D.saved) return;
  for (const world of picture.worlds || []) {
    const b = document.createElement("button");
    b.textContent = `Run it on this picture (${world} world)`; b.dataset.testid = "picture-scene-" + world;
    b.addEventListener("click", async () => {
      say(`learning the ${world} world's template on ${picture.file} (the robot looks at it)…`);
      try {
        const r = await askingToOverwrite((overwrite) => post("/api/picture-scene", { template: D.saved.template,
          image: picture.file, world, overwrite }));
        say(`wrote ${r.template} and ${r.program}; run it on page 3 (${Object.entries(r.settings).map(([k, v]) => k + " = " + v).join(", ")}) or: ${r.command}`);
        refreshFiles();
      } catch (err) { say("error: " + err.message); }
      $("save-status").scrollIntoView({ block: "nearest" });  // the answer in view, not below the fold
    });
    box.appendChild(b);
  }
}

async function upload(e) {
  const f = e.target.files[0]; if (!f) return;
  try { await askingToOverwrite((o) => api("/api/upload?path=" + encodeURIComponent(f.name) + (o ? "&overwrite=1" : ""), { method: "POST", body: f }));
    await refreshFiles(); $("scene").value = "upload:" + f.name; await loadScene("upload:" + f.name);
  } catch (err) { say("error: " + err.message); }
}

export async function mount() {
  const c = $("demo-canvas");
  ["pointermove", "pointerdown", "pointerup"].forEach((t) => c.addEventListener(t, pointer));
  c.addEventListener("pointerleave", () => { if (D.recording && D.samples.some((s) => s.down)) finishDrawing(); });
  c.addEventListener("click", placeIcp);
  $("demo-finish").addEventListener("click", finishDrawing);
  document.querySelectorAll('input[name="demo-mode"]').forEach((r) => r.addEventListener("change", draw));
  $("demo-clear").addEventListener("click", () => { D.source = null; clear(); });
  $("scene").addEventListener("change", () => loadScene($("scene").value));
  $("upload-picture").addEventListener("change", upload);
  $("open-source").addEventListener("change", openSource);
  $("propose").addEventListener("click", () => propose(null));
  dragCuts();
  ["seg-tags", "seg-contact", "seg-method"].forEach((id) => $(id).addEventListener("change", () => propose(null)));
  $("save-template").addEventListener("click", save);
  mountCamera(useTrack);
  D.scenes = await api("/api/scenes");
  fill($("scene"), D.scenes.map((s) => [s.name, s.label]));
  await loadScene("blank");
}

export async function files(list) {
  const yaml = list.filter((f) => f.endsWith(".yaml") && !f.endsWith(".icps.yaml"));
  let lasa = [];
  try { lasa = (await api("/api/lasa")).shapes; } catch (e) { /* optional */ }
  fill($("open-source"), [...yaml.map((f) => ["template:" + f, "template " + f]),
    ...list.filter((f) => f.endsWith(".csv")).map((f) => ["csv:" + f, "CSV " + f]),
    ...lasa.map((n) => ["lasa:" + n, "LASA " + n])], '<option value="">template / CSV / LASA…</option>');
  D.scenes = await api("/api/scenes");   // the pictures the folder holds itself, not what runs wrote
  fill($("scene"), D.scenes.map((s) => [s.name, s.label]));
}
