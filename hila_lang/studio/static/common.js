// hila studio: what the pages share -- requests, sockets, plane geometry, draggable handles, and
// start(), which builds the tabs from the server's page list and mounts each page's ES module.
// Plain JavaScript modules, no dependencies, nothing fetched from elsewhere.
//
// A page module exports: html (its view's markup), state (its own state, shown to tests and the
// console as window.hilaStudio[name]), mount(view) (wires its handlers) and files(list) (fills
// its menus from the folder's files).

export const $ = (id) => document.getElementById(id);

// this start's token, from the URL 'hila studio' printed (kept for the tab's reloads): sent as
// X-Hila-Token with every request, so the server knows the request comes from this page and not
// from another page on 127.0.0.1 that only has the cookie (docs/studio.md, security)
const TOKEN = new URLSearchParams(location.search).get("token") || sessionStorage.getItem("hilaToken") || "";
if (TOKEN) sessionStorage.setItem("hilaToken", TOKEN);

// fetch `path` as the page: the token header added, the answer's JSON (or text) returned; a
// failed answer throws an Error whose message is the server's reason and whose `status` and
// `exists` (a 409: the file exists, ask before overwriting) say more
export async function api(path, opts = {}) {
  const headers = Object.assign({}, opts.headers || {}, TOKEN ? { "X-Hila-Token": TOKEN } : {});
  const r = await fetch(path, Object.assign({ credentials: "same-origin" }, opts, { headers }));
  const type = r.headers.get("content-type") || "";
  const body = type.includes("json") ? await r.json() : await r.text();
  if (!r.ok) throw Object.assign(new Error(body.error || body), { status: r.status, exists: !!body.exists });
  return body;
}

// a save that may replace a file (the overwrite contract): sent first without overwrite; when the
// server answers 409 (the file exists) the person is asked, and only if they agree is it sent
// again with overwrite.  send(overwrite) makes the request; declined, it throws "not saved: ..."
export async function askingToOverwrite(send) {
  try { return await send(false); } catch (err) {
    if (err.status !== 409) throw err;
    if (!confirm(err.message.replace(/ \(send overwrite.*\)$/, "") + ".\nReplace it?")) throw new Error("not saved: " + err.message.split(" exists")[0] + " was kept");
    return await send(true);
  }
}

export const post = (path, doc) => api(path, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(doc) });

// a websocket to `path` (kept open, reopened when closed) whose JSON messages go to onMessage;
// send(doc) sends once it is open
export function socket(path, onMessage) {
  let ws = null;
  const open = () => {
    if (ws && ws.readyState <= 1) return ws;
    ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + path);
    ws.onmessage = (m) => onMessage(JSON.parse(m.data));
    return ws;
  };
  return {
    send(doc) {
      const w = open(), text = JSON.stringify(doc);
      if (w.readyState === 1) w.send(text); else w.addEventListener("open", () => w.send(text), { once: true });
    },
  };
}

// ---------------------------------------------------------------- geometry: plane (x, y) <-> pixels
// H is a 3x3 homography (rows), plane point (x, y, 1) -> pixel (u, v, w)
export function applyH(H, x, y) {
  const w = H[2][0] * x + H[2][1] * y + H[2][2];
  return [(H[0][0] * x + H[0][1] * y + H[0][2]) / w, (H[1][0] * x + H[1][1] * y + H[1][2]) / w];
}
export function inv3(m) {
  const [a, b, c] = m[0], [d, e, f] = m[1], [g, h, i] = m[2];
  const A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g, det = a * A + b * B + c * C;
  return [[A / det, -(b * i - c * h) / det, (b * f - c * e) / det],
          [B / det, (a * i - c * g) / det, -(a * f - c * d) / det],
          [C / det, -(a * h - b * g) / det, (a * e - b * d) / det]];
}
export function fitH(points, w, h, margin = 40) {   // a top view (x right, y up) of points, fitted into w x h
  let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
  for (const p of points) { x0 = Math.min(x0, p[0]); x1 = Math.max(x1, p[0]); y0 = Math.min(y0, p[1]); y1 = Math.max(y1, p[1]); }
  const s = Math.min((w - 2 * margin) / Math.max(x1 - x0, 1e-9), (h - 2 * margin) / Math.max(y1 - y0, 1e-9));
  const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
  return [[s, 0, w / 2 - s * cx], [0, -s, h / 2 + s * cy], [0, 0, 1]];
}
export function polyline(ctx, pts, H, style, width = 2, dash = []) {
  if (!pts || pts.length < 2) return;
  ctx.save(); ctx.strokeStyle = style; ctx.lineWidth = width; ctx.setLineDash(dash); ctx.beginPath();
  pts.forEach((p, i) => { const [u, v] = applyH(H, p[0], p[1]); i ? ctx.lineTo(u, v) : ctx.moveTo(u, v); });
  ctx.stroke(); ctx.restore();
}

// a draggable handle (an absolutely placed div over a canvas) with a data-testid
export function handle(layer, testid, cls, label, u, v, onDrag, onEnd, onDbl) {
  const el = document.createElement("div");
  el.className = "handle " + cls; el.dataset.testid = testid;
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

// fill a <select> with [value, text] items after an optional first option's markup, keeping its choice
export function fill(sel, items, first) {
  const keep = sel.value; sel.innerHTML = first || "";
  for (const [value, text] of items) { const o = document.createElement("option"); o.value = value; o.textContent = text; sel.appendChild(o); }
  if ([...sel.options].some((o) => o.value === keep)) sel.value = keep;
}

// ---------------------------------------------------------------- the pages
const pages = [];

// the folder's files, given to every page (after a page saves one, it calls this)
export async function refreshFiles() {
  const { folder, files } = await api("/api/files");
  $("folder").textContent = folder;
  for (const p of pages) await p.files(files);
}

export async function start() {
  window.hilaStudio = {};
  const nav = $("tabs"), main = $("views");
  for (const page of await api("/api/pages")) {
    const mod = await import("/static/" + page.script);
    const tab = document.createElement("button");
    tab.className = "tab"; tab.dataset.view = page.name; tab.dataset.testid = "tab-" + page.name; tab.textContent = page.title;
    const view = document.createElement("section");
    view.id = "view-" + page.name; view.className = "view"; view.innerHTML = mod.html;
    nav.appendChild(tab); main.appendChild(view);
    window.hilaStudio[page.name] = mod.state;
    pages.push(mod);
  }
  const show = (name) => {
    nav.querySelectorAll(".tab").forEach((t) => t.classList.toggle("active", t.dataset.view === name));
    main.querySelectorAll(".view").forEach((v) => v.classList.toggle("active", v.id === "view-" + name));
  };
  nav.querySelectorAll(".tab").forEach((t) => t.addEventListener("click", () => show(t.dataset.view)));
  show(nav.querySelector(".tab").dataset.view);
  for (const p of pages) await p.mount();
  await refreshFiles();
}
