// hila studio: the page.  Plain JavaScript, no dependencies, nothing fetched from elsewhere.
"use strict";
const S = (window.hilaStudio = { demo: {}, imit: {}, run: {} });
const $ = (id) => document.getElementById(id);

async function api(path, opts = {}) {
  const r = await fetch(path, Object.assign({ credentials: "same-origin" }, opts));
  const type = r.headers.get("content-type") || "";
  const body = type.includes("json") ? await r.json() : await r.text();
  if (!r.ok) throw new Error(body.error || body);
  return body;
}
const post = (path, doc) => api(path, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(doc) });
function wsURL(path) { return (location.protocol === "https:" ? "wss://" : "ws://") + location.host + path; }

// ---------------------------------------------------------------- geometry: plane (x, y) <-> pixels
function applyH(H, x, y) {
  const w = H[2][0] * x + H[2][1] * y + H[2][2];
  return [(H[0][0] * x + H[0][1] * y + H[0][2]) / w, (H[1][0] * x + H[1][1] * y + H[1][2]) / w];
}
function inv3(m) {
  const [a, b, c] = m[0], [d, e, f] = m[1], [g, h, i] = m[2];
  const A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g, det = a * A + b * B + c * C;
  return [[A / det, -(b * i - c * h) / det, (b * f - c * e) / det],
          [B / det, (a * i - c * g) / det, -(a * f - c * d) / det],
          [C / det, -(a * h - b * g) / det, (a * e - b * d) / det]];
}
function fitH(points, w, h, margin = 40) {   // a top view (x right, y up) of points, fitted into w x h
  let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
  for (const p of points) { x0 = Math.min(x0, p[0]); x1 = Math.max(x1, p[0]); y0 = Math.min(y0, p[1]); y1 = Math.max(y1, p[1]); }
  const s = Math.min((w - 2 * margin) / Math.max(x1 - x0, 1e-9), (h - 2 * margin) / Math.max(y1 - y0, 1e-9));
  const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
  return [[s, 0, w / 2 - s * cx], [0, -s, h / 2 + s * cy], [0, 0, 1]];
}
function polyline(ctx, pts, H, style, width = 2, dash = []) {
  if (!pts || pts.length < 2) return;
  ctx.save(); ctx.strokeStyle = style; ctx.lineWidth = width; ctx.setLineDash(dash); ctx.beginPath();
  pts.forEach((p, i) => { const [u, v] = applyH(H, p[0], p[1]); i ? ctx.lineTo(u, v) : ctx.moveTo(u, v); });
  ctx.stroke(); ctx.restore();
}

// draggable handles (absolutely placed divs over a canvas), each with a data-testid
function handle(layer, testid, cls, label, u, v, onDrag, onEnd, onDbl) {
  const el = document.createElement("div");
  el.className = "handle " + cls; el.dataset.testid = testid; el.setAttribute("data-testid", testid);
  el.style.left = u + "px"; el.style.top = v + "px";
  if (label) { const l = document.createElement("label"); l.textContent = label; el.appendChild(l); }
  el.addEventListener("pointerdown", (e) => {
    e.preventDefault(); e.stopPropagation(); el.setPointerCapture(e.pointerId); layer.dataset.dragging = "1";
    const box = layer.getBoundingClientRect();
    const move = (ev) => { const x = ev.clientX - box.left, y = ev.clientY - box.top;
      el.style.left = x + "px"; el.style.top = y + "px"; onDrag && onDrag(x, y); };
    const up = () => { el.removeEventListener("pointermove", move); el.removeEventListener("pointerup", up);
      delete layer.dataset.dragging; onEnd && onEnd(); };
    el.addEventListener("pointermove", move); el.addEventListener("pointerup", up);
  });
  if (onDbl) el.addEventListener("dblclick", (e) => { e.stopPropagation(); onDbl(); });
  layer.appendChild(el);
  return el;
}

// ---------------------------------------------------------------- tabs, files
document.querySelectorAll(".tab").forEach((b) => b.addEventListener("click", () => {
  document.querySelectorAll(".tab").forEach((t) => t.classList.toggle("active", t === b));
  document.querySelectorAll(".view").forEach((v) => v.classList.toggle("active", v.id === "view-" + b.dataset.view));
}));
async function refreshFiles() {
  const { folder, files } = await api("/api/files");
  $("folder").textContent = folder;
  S.files = files;
  const fill = (sel, items, first) => { const keep = sel.value; sel.innerHTML = first || "";
    for (const [value, text] of items) { const o = document.createElement("option"); o.value = value; o.textContent = text; sel.appendChild(o); }
    if ([...sel.options].some((o) => o.value === keep)) sel.value = keep; };
  const yaml = files.filter((f) => f.endsWith(".yaml") && !f.endsWith(".icps.yaml"));
  let lasa = [];
  try { lasa = (await api("/api/lasa")).shapes; } catch (e) { /* optional */ }
  fill($("open-source"), [...yaml.map((f) => ["template:" + f, "template " + f]),
    ...files.filter((f) => f.endsWith(".csv")).map((f) => ["csv:" + f, "CSV " + f]),
    ...lasa.map((n) => ["lasa:" + n, "LASA " + n])], '<option value="">template / CSV / LASA…</option>');
  fill($("scene"), [["blank", "blank sheet"], ["tictactoe", "tic-tac-toe (robot's eye)"],
    ...files.filter((f) => /\.(png|jpe?g)$/i.test(f)).map((f) => ["upload:" + f, "picture " + f])]);
  fill($("imitate-template"), yaml.map((f) => [f, f]), '<option value="">choose…</option>');
  fill($("program"), files.filter((f) => f.endsWith(".hila")).map((f) => [f, f]), '<option value="">choose…</option>');
  fill($("recording"), files.filter((f) => f.endsWith(".hilarec")).map((f) => [f, f]), '<option value="">choose…</option>');
}

// ================================================================ 1. Demonstrate
const D = S.demo;
D.samples = []; D.icps = {}; D.recording = false; D.done = false;
async function loadScene(name) {
  D.scene = await api("/api/scene?name=" + encodeURIComponent(name));
  D.H = D.scene.H; D.Hinv = inv3(D.H); D.source = null;
  const c = $("demo-canvas"); c.width = D.scene.width; c.height = D.scene.height;
  D.image = null;
  if (D.scene.image) { D.image = new Image(); D.image.onload = drawDemo; D.image.src = D.scene.image; }
  clearDemo();
}
function clearDemo() {
  D.samples = []; D.icps = {}; D.path = null; D.times = null; D.cuts = []; D.speed = null; D.recording = false; D.done = false;
  $("save-status").textContent = ""; $("icp-name").value = "p1"; drawDemo(); drawSpeed();
}
function planeAt(u, v) { return applyH(D.Hinv, u, v); }
function drawDemo() {
  const c = $("demo-canvas"), ctx = c.getContext("2d");
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  if (D.image && D.image.complete) ctx.drawImage(D.image, 0, 0, c.width, c.height);
  if (document.querySelector('input[name="demo-mode"]:checked').value === "icp")
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
      drawDemo, () => { delete D.icps[name]; drawDemo(); });
  }
}
function listIcps() {   // rename (keeps the order) and remove
  const box = $("demo-icps"); box.innerHTML = "";
  for (const name of Object.keys(D.icps)) {
    const row = document.createElement("div"), input = document.createElement("input"), del = document.createElement("button");
    input.value = name; input.size = 10; input.setAttribute("data-testid", "rename-icp-" + name);
    input.addEventListener("change", () => { const to = input.value.trim();
      if (!to || to in D.icps) { input.value = name; return; }
      D.icps = Object.fromEntries(Object.entries(D.icps).map(([k, v]) => [k === name ? to : k, v])); drawDemo(); });
    del.textContent = "×"; del.title = "remove " + name; del.setAttribute("data-testid", "remove-icp-" + name);
    del.onclick = () => { delete D.icps[name]; drawDemo(); };
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
function demoPointer(e) {
  if (document.querySelector('input[name="demo-mode"]:checked').value !== "draw" || D.done || !D.scene) return;
  if (e.type === "pointerdown") try { $("demo-canvas").setPointerCapture(e.pointerId); } catch (err) { /* a synthesized pointer */ }
  if (!D.recording) { if (D.source) return; D.recording = true; D.samples = []; }
  const many = e.type === "pointermove" && e.getCoalescedEvents ? e.getCoalescedEvents() : [];
  for (const ev of many.length ? many : [e]) D.samples.push(sample(ev));
  if (e.type === "pointerdown" || e.type === "pointerup") D.samples[D.samples.length - 1].down = e.type === "pointerdown";
  drawDemo();
}
["pointermove", "pointerdown", "pointerup"].forEach((t) => $("demo-canvas").addEventListener(t, demoPointer));
$("demo-canvas").addEventListener("pointerleave", () => { if (D.recording && D.samples.some((s) => s.down)) finishDrawing(); });
$("demo-finish").addEventListener("click", finishDrawing);
async function finishDrawing() {
  if (!D.recording) return;
  D.recording = false; D.done = true;
  try {
    const r = await post("/api/demonstration", { samples: D.samples, z: D.scene.z, k: tags().length || 1, method: $("seg-method").value });
    Object.assign(D, { path: r.path, times: r.times, cuts: r.cuts, speed: r.speed });
    $("save-status").textContent = `${r.path.length} points at 20 Hz (${r.times[r.times.length - 1].toFixed(2)} s); now place the ICPs`;
  } catch (err) { $("save-status").textContent = "error: " + err.message; D.done = false; }
  drawDemo(); drawSpeed();
}
$("demo-canvas").addEventListener("click", (e) => {
  if (document.querySelector('input[name="demo-mode"]:checked').value !== "icp" || !D.scene) return;
  const name = $("icp-name").value.trim();
  if (!name) { $("save-status").textContent = "give the ICP a name first"; return; }
  let best = null, bestD = 14;     // snap to a world feature, or the path's start or end
  const offers = [...D.scene.features.map((f) => f.point)];
  if (D.path) offers.push(D.path[0], D.path[D.path.length - 1]);
  for (const p of offers) { const [u, v] = applyH(D.H, p[0], p[1]); const d = Math.hypot(u - e.offsetX, v - e.offsetY);
    if (d < bestD) { best = p; bestD = d; } }
  const [x, y] = planeAt(e.offsetX, e.offsetY);
  const dim = D.path ? D.path[0].length : (D.scene.z === null ? 2 : 3);
  D.icps[name] = best ? best.slice(0, dim) : (dim === 3 ? [x, y, D.scene.z ?? 0] : [x, y]);
  const m = name.match(/^(.*?)(\d+)$/); $("icp-name").value = m ? m[1] + (+m[2] + 1) : name + "2";
  drawDemo();
});
document.querySelectorAll('input[name="demo-mode"]').forEach((r) => r.addEventListener("change", drawDemo));
$("demo-clear").addEventListener("click", () => { D.source = null; clearDemo(); });
$("scene").addEventListener("change", () => loadScene($("scene").value));
$("upload-picture").addEventListener("change", async (e) => {
  const f = e.target.files[0]; if (!f) return;
  try { await api("/api/upload?path=" + encodeURIComponent(f.name), { method: "POST", body: f });
    await refreshFiles(); $("scene").value = "upload:" + f.name; await loadScene("upload:" + f.name);
  } catch (err) { $("save-status").textContent = "error: " + err.message; }
});
$("open-source").addEventListener("change", async () => {
  const v = $("open-source").value; if (!v) return;
  const i = v.indexOf(":"), t = await api(`/api/open?kind=${v.slice(0, i)}&name=${encodeURIComponent(v.slice(i + 1))}`);
  const c = $("demo-canvas");
  D.scene = { name: "open", width: c.width, height: c.height, z: null, features: [] };
  D.image = null; D.H = fitH([...t.path, ...Object.values(t.icps)], c.width, c.height); D.Hinv = inv3(D.H);
  D.samples = []; D.recording = false; D.done = true; D.source = v;
  D.path = t.path; D.times = t.times || t.path.map((_, i) => i * 0.05); D.icps = t.icps;
  if (t.segments.length) { $("seg-tags").value = t.segments.map((s) => s.tag).join(",");
    $("seg-contact").value = t.segments.filter((s) => s.contact).map((s) => s.tag).join(","); }
  $("template-name").value = t.name.replace(/[^A-Za-z0-9_]/g, "_");
  await propose(t.segments.length ? t.segments.slice(1).map((s) => s.start) : null);
});
const tags = () => $("seg-tags").value.split(",").map((s) => s.trim()).filter(Boolean);
async function propose(keep) {
  if (!D.path) return;
  const r = await post("/api/demonstration", { path: D.path, times: D.times, k: tags().length || 1, method: $("seg-method").value });
  D.speed = r.speed; D.cuts = keep || r.cuts; drawDemo(); drawSpeed();
}
$("propose").addEventListener("click", () => propose(null));
function drawSpeed() {
  const c = $("speed-plot"), ctx = c.getContext("2d");
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  ctx.fillStyle = "#555"; ctx.font = "11px sans-serif"; ctx.fillText("hand speed (the cuts hila proposes: drag them)", 6, 12);
  if (!D.speed) return;
  const T = D.speed.length, max = Math.max(...D.speed, 1e-9), X = (i) => 4 + (c.width - 8) * i / Math.max(T - 1, 1);
  ctx.strokeStyle = "#1565c0"; ctx.beginPath();
  D.speed.forEach((s, i) => { const y = c.height - 6 - (c.height - 24) * s / max; i ? ctx.lineTo(X(i), y) : ctx.moveTo(X(i), y); });
  ctx.stroke();
  const bounds = [0, ...D.cuts, T], tg = tags(), contact = $("seg-contact").value.split(",").map((s) => s.trim());
  for (let k = 0; k + 1 < bounds.length; k++) {
    ctx.fillStyle = contact.includes(tg[k]) ? "rgba(46,125,50,.12)" : "rgba(0,0,0,0)";
    ctx.fillRect(X(bounds[k]), 16, X(bounds[k + 1]) - X(bounds[k]), c.height - 16);
    ctx.fillStyle = "#333"; ctx.fillText((tg[k] || "?") + (contact.includes(tg[k]) ? " (contact)" : ""), X(bounds[k]) + 4, 28);
  }
  ctx.strokeStyle = "#d32f2f"; ctx.lineWidth = 2;
  for (const cut of D.cuts) { ctx.beginPath(); ctx.moveTo(X(cut), 16); ctx.lineTo(X(cut), c.height); ctx.stroke(); }
  ctx.lineWidth = 1;
}
(function dragCuts() {
  const c = $("speed-plot"); let which = -1;
  const idx = (e) => Math.round((e.offsetX - 4) / (c.width - 8) * (D.speed.length - 1));
  c.addEventListener("pointerdown", (e) => { if (!D.speed) return; const i = idx(e);
    let best = 1e9; D.cuts.forEach((cut, k) => { if (Math.abs(cut - i) < best) { best = Math.abs(cut - i); which = k; } });
    if (best > D.speed.length / 40 + 2) which = -1; else c.setPointerCapture(e.pointerId); });
  c.addEventListener("pointermove", (e) => { if (which < 0) return;
    const lo = which ? D.cuts[which - 1] + 1 : 1, hi = which + 1 < D.cuts.length ? D.cuts[which + 1] - 1 : D.speed.length - 1;
    D.cuts[which] = Math.max(lo, Math.min(hi, idx(e))); drawSpeed(); drawDemo(); });
  c.addEventListener("pointerup", () => { which = -1; });
})();
["seg-tags", "seg-contact"].forEach((id) => $(id).addEventListener("change", () => propose(null)));
$("seg-method").addEventListener("change", () => propose(null));
$("save-template").addEventListener("click", async () => {
  if (!D.path) { $("save-status").textContent = "draw a demonstration first"; return; }
  const tg = tags();
  if (D.cuts.length !== Math.max(tg.length - 1, 0)) await propose(null);
  try {
    const r = await post("/api/save", { name: $("template-name").value.trim(), path: D.path, times: D.times, icps: D.icps,
      tags: tg, contact: $("seg-contact").value.split(",").map((s) => s.trim()).filter(Boolean),
      method: $("seg-method").value, cuts: D.cuts });
    $("save-status").textContent = `saved ${r.template} (${r.segments.map((s) => s.tag + " " + s.start + "-" + s.stop).join(", ")}) = ${r.command}`;
    S.saved = r; refreshFiles();
  } catch (err) { $("save-status").textContent = "error: " + err.message; }
});

// ================================================================ 2. Imitate
const I = S.imit;
I.seq = 0; I.shown = 0; I.via = []; I.avoid = []; I.task = {}; I.names = {}; I.mode = null;
function imitWS() {
  if (I.ws && I.ws.readyState <= 1) return I.ws;
  I.ws = new WebSocket(wsURL("/ws/imitate"));
  I.ws.onmessage = (m) => {
    const r = JSON.parse(m.data);
    if (r.seq < I.shown) return;
    I.shown = r.seq; I.serverMs = r.server_ms;
    if (r.error) { $("imitate-reason").textContent = "OSILA: " + r.error; I.path = null; }
    else { I.path = r.path; I.controls = r.controls || null; $("imitate-reason").textContent = r.reason.join("\n"); }
    drawImitate();
    const c = $("imitate-canvas"); c.dataset.seq = r.seq;
    if (I.onPath) I.onPath(r);
  };
  return I.ws;
}
function scene() { return { template: I.name, icps: I.task, names: I.names, via: I.via, avoid: I.avoid, controls: $("show-controls").checked }; }
function request() {
  const ws = imitWS(), doc = Object.assign(scene(), { seq: ++I.seq });
  if (ws.readyState === 1) ws.send(JSON.stringify(doc)); else ws.addEventListener("open", () => ws.send(JSON.stringify(doc)), { once: true });
}
$("imitate-template").addEventListener("change", async () => {
  I.name = $("imitate-template").value; if (!I.name) return;
  I.t = await api("/api/template?path=" + encodeURIComponent(I.name));
  I.task = JSON.parse(JSON.stringify(I.t.icps)); I.names = {}; I.via = []; I.avoid = []; I.path = null;
  const c = $("imitate-canvas");
  I.H = fitH([...I.t.path, ...Object.values(I.t.icps)], c.width, c.height, 90); I.Hinv = inv3(I.H);
  drawImitate(); request();
});
function drawImitate() {
  const c = $("imitate-canvas"), ctx = c.getContext("2d");
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  if (!I.t) return;
  ctx.fillStyle = "#777"; ctx.font = "12px sans-serif";
  ctx.fillText(I.t.dim === 3 ? "seen from above (x right, y up); heights are kept while you drag" : "x right, y up", 8, 16);
  polyline(ctx, I.t.path, I.H, "#bbb", 2, [5, 4]);
  if (I.controls) { const col = { tps: "#8e24aa", similarity: "#43a047", "dmp-aligned": "#ef6c00" };
    for (const [k, p] of Object.entries(I.controls)) polyline(ctx, p, I.H, col[k] || "#999", 1.5); }
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
    handle(layer, "icp-" + name, "", shown, u, v, dragTo(p), drawImitate, () => { delete I.task[name]; drawImitate(); request(); });
  }
  // the task scene's point names (what an exported program calls them): rename here
  const names = $("imitate-names"); names.innerHTML = "";
  for (const name of Object.keys(I.task)) {
    const row = document.createElement("div"), label = document.createElement("span"), input = document.createElement("input");
    label.textContent = name + " \u2192 point "; input.value = I.names[name] || name; input.size = 10;
    input.setAttribute("data-testid", "name-icp-" + name); input.title = "the name the exported .hila program gives this point";
    input.addEventListener("change", () => { I.names[name] = input.value.trim(); drawImitate(); });
    row.appendChild(label); row.appendChild(input); names.appendChild(row);
  }
  I.via.forEach((p, i) => { const [u, v] = applyH(I.H, p[0], p[1]);
    handle(layer, "via-" + (i + 1), "via", "via " + (i + 1), u, v, dragTo(p), drawImitate, () => { I.via.splice(i, 1); drawImitate(); request(); }); });
  I.avoid.forEach((a, i) => { const [u, v] = applyH(I.H, a.centre[0], a.centre[1]);
    const el = handle(layer, "avoid-" + (i + 1), "avoid", "avoid " + (i + 1), u, v, dragTo(a.centre), drawImitate, () => { I.avoid.splice(i, 1); drawImitate(); request(); });
    const r = Math.abs(a.radius * I.H[0][0]) * 2; el.style.width = r + "px"; el.style.height = r + "px"; });
  const un = $("unbound"); un.innerHTML = "";
  for (const k of Object.keys(I.t.icps).filter((k) => !(k in I.task))) {
    const b = document.createElement("button"); b.textContent = "+ " + k; b.dataset.testid = "add-icp-" + k;
    b.onclick = () => { I.task[k] = I.t.icps[k].slice(); drawImitate(); request(); }; un.appendChild(b); }
}
$("add-via").addEventListener("click", () => { I.mode = I.mode === "via" ? null : "via"; $("add-via").classList.toggle("armed", I.mode === "via"); $("add-avoid").classList.remove("armed"); });
$("add-avoid").addEventListener("click", () => { I.mode = I.mode === "avoid" ? null : "avoid"; $("add-avoid").classList.toggle("armed", I.mode === "avoid"); $("add-via").classList.remove("armed"); });
$("imitate-canvas").addEventListener("click", (e) => {
  if (!I.t || !I.mode) return;
  const [x, y] = applyH(I.Hinv, e.offsetX, e.offsetY);
  const z = I.t.dim === 3 ? (I.path ? I.path[nearest(I.path, x, y)][2] : I.t.path[0][2]) : null;
  const p = z === null ? [x, y] : [x, y, z];
  if (I.mode === "via") I.via.push(p); else I.avoid.push({ centre: p, radius: (+$("avoid-radius").value || 10) / 1000 });
  I.mode = null; $("add-via").classList.remove("armed"); $("add-avoid").classList.remove("armed");
  drawImitate(); request();
});
function nearest(path, x, y) { let b = 0, bd = Infinity; path.forEach((p, i) => { const d = (p[0] - x) ** 2 + (p[1] - y) ** 2; if (d < bd) { bd = d; b = i; } }); return b; }
$("show-controls").addEventListener("change", request);
$("export").addEventListener("click", async () => {
  try { const r = await post("/api/imitate/export", scene());
    $("export-text").value = r.hila + "\n# --- path (CSV) ---\n" + r.csv.split("\n").slice(0, 6).join("\n") + "\n# ...";
    const links = $("export-links"); links.innerHTML = "";
    for (const [text, name, type] of [[r.csv, "imitated.csv", "text/csv"], [r.hila, "scene.hila", "text/plain"]]) {
      const a = document.createElement("a"); a.href = URL.createObjectURL(new Blob([text], { type })); a.download = name;
      a.textContent = "download " + name + "  "; links.appendChild(a); }
  } catch (err) { $("export-text").value = "error: " + err.message; }
});
$("explain").addEventListener("click", async () => {
  try { $("imitate-reason").textContent = (await post("/api/imitate/explain", scene())).lines.join("\n"); }
  catch (err) { $("imitate-reason").textContent = "error: " + err.message; }
});

// ================================================================ 3. Run and watch
const R = S.run;
R.breaks = new Set();
function runWS() {
  if (R.ws && R.ws.readyState <= 1) return R.ws;
  R.ws = new WebSocket(wsURL("/ws/run"));
  R.ws.onmessage = (m) => onRun(JSON.parse(m.data));
  return R.ws;
}
function send(doc) { const ws = runWS(); if (ws.readyState === 1) ws.send(JSON.stringify(doc)); else ws.addEventListener("open", () => ws.send(JSON.stringify(doc)), { once: true }); }
function traceAdd(text) { const t = $("trace"); t.textContent += text; t.scrollTop = t.scrollHeight; }
function onRun(msg) {
  if (msg.type === "fsm") { R.graph = msg.graph; $("trace").textContent = ""; drawFSM(null);
    const s = $("scrub"); s.disabled = msg.length == null; s.max = msg.length || 0; s.value = 0; }
  else if (msg.type === "out") traceAdd(msg.text);
  else if (msg.type === "error") { traceAdd("error: " + msg.text + "\n"); $("run-status").textContent = "error: " + msg.text; }
  else if (msg.type === "state" || msg.type === "step") {
    R.state = msg;
    drawFSM(msg.current);
    $("run-status").textContent = msg.done ? `finished after ${msg.steps} steps` :
      (msg.waiting ? "your move: click a free cell" : `at ${msg.current} (step ${msg.steps})`);
    $("run-status").dataset.done = msg.done ? "1" : "0";
    drawBoard(msg.board, msg.waiting);
    if (msg.eye) { $("eye").src = "data:image/png;base64," + msg.eye; $("eye").hidden = false; }
    drawTop(msg.path);
    if (msg.robot) { $("robot").src = "data:image/png;base64," + msg.robot; $("robot-box").hidden = false; }
    if (msg.length != null) $("scrub-at").textContent = `step ${msg.steps} of ${msg.length}` + (msg.entry ? ": " + msg.entry : "");
  }
}
function layout(graph) {   // layers by distance from the start state
  const depth = { [graph.start]: 0 }, q = [graph.start], out = {};
  for (const [a, b] of graph.edges) (out[a] = out[a] || []).push(b);
  while (q.length) { const a = q.shift(); for (const b of out[a] || []) if (!(b in depth)) { depth[b] = depth[a] + 1; q.push(b); } }
  const rows = {}, pos = {};
  for (const n of graph.nodes) { const d = depth[n.name] ?? 0; (rows[d] = rows[d] || []).push(n.name); }
  const nRows = Object.keys(rows).length;
  for (const [d, names] of Object.entries(rows)) names.forEach((n, i) => { pos[n] = [60 + (i + 0.5) * 400 / names.length, 20 + (+d) * 300 / Math.max(nRows, 1)]; });
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
function drawBoard(board, waiting) {
  const el = $("board"); el.innerHTML = ""; el.classList.toggle("waiting", !!waiting);
  if (!board) return;
  board.forEach((mark, i) => { const b = document.createElement("button"); b.textContent = mark; b.dataset.testid = "cell-" + (i + 1);
    b.setAttribute("data-testid", "cell-" + (i + 1)); b.title = "cell " + (i + 1);
    b.disabled = !waiting || !!mark; b.onclick = () => { send({ cmd: "move", cell: i + 1 }); el.classList.remove("waiting"); };
    el.appendChild(b); });
}
function drawTop(path) {
  const c = $("top-view"), ctx = c.getContext("2d"); ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, c.width, c.height);
  ctx.fillStyle = "#777"; ctx.font = "11px sans-serif"; ctx.fillText("last path, from above", 4, 12);
  if (path && path.length > 1) polyline(ctx, path, fitH(path, c.width, c.height, 24), "#1565c0", 2);
}
$("program").addEventListener("change", async () => {
  const p = $("program").value; if (!p) return;
  $("program-editor").value = await api("/api/file?path=" + encodeURIComponent(p)); check();
});
let checkTimer = null;
$("program-editor").addEventListener("input", () => { clearTimeout(checkTimer); checkTimer = setTimeout(check, 250); });
async function check() {
  const r = await post("/api/check", { path: $("program").value || "untitled.hila", text: $("program-editor").value });
  $("opponent").disabled = !r.settings.includes("opponent");
  const ul = $("problems"); ul.innerHTML = "";
  if (!r.problems.length) { const li = document.createElement("li"); li.className = "ok"; li.textContent = "no problems"; ul.appendChild(li); }
  for (const p of r.problems) { const li = document.createElement("li"); li.className = p.severity;
    li.textContent = `${p.line + 1}:${p.character + 1}: ${p.severity}: ${p.message}`; ul.appendChild(li); }
}
$("program-save").addEventListener("click", async () => {
  const p = $("program").value || prompt("save as (e.g. mine.hila)"); if (!p) return;
  await api("/api/file?path=" + encodeURIComponent(p), { method: "PUT", body: $("program-editor").value });
  await refreshFiles(); $("program").value = p;
});
$("btn-start").addEventListener("click", () => { R.breaks.clear();
  send({ cmd: "start", path: $("program").value, backend: $("backend").value, robot: $("robot-choice").value, opponent: $("opponent").value }); });
for (const c of ["step", "run", "back", "reload", "stop"]) $("btn-" + c).addEventListener("click", () => send({ cmd: c }));
$("recording").addEventListener("change", () => { if ($("recording").value) send({ cmd: "open", path: $("recording").value }); });
$("azimuth").addEventListener("change", () => send({ cmd: "view", azimuth: +$("azimuth").value }));
$("scrub").addEventListener("input", () => send({ cmd: "scrub", n: +$("scrub").value }));

// ---------------------------------------------------------------- start
refreshFiles().then(() => loadScene("blank"));
