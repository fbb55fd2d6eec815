// hila studio, page 1's Camera scene: a pen on the printed sheet before the webcam.
// The browser gives the camera (getUserMedia; only this page sees it); its frames go, downscaled
// and as JPEG, to the studio's own server over /ws/camera -- nowhere else. The server tracks them
// (the same tracker as `hila learn VIDEO --sheet`) and answers what each shows, drawn here over the
// live image. Record / Stop; at Stop the server finishes the recording and the path comes back as a
// demonstration for the Demonstrate page (cuts, tags, ICPs, save). An uploaded video does the same.
import { $, api, socket } from "/static/common.js";

export const html = `
  <div id="camera-panel" class="camera" data-testid="camera-panel" hidden>
    <div class="toolbar">
      <button id="camera-start" data-testid="camera-start">Start camera</button>
      <button id="camera-record" data-testid="camera-record" disabled>Record</button>
      <button id="camera-stop" data-testid="camera-stop" disabled>Stop</button>
      <label>ball <select id="camera-ball" data-testid="camera-ball">
        <option>green</option><option>blue</option><option>red</option><option>yellow</option><option>cyan</option><option>magenta</option></select></label>
      <label>Ø mm <input id="camera-ball-mm" data-testid="camera-ball-mm" value="12" size="3"></label>
      <label>ICPs: cell <select id="camera-cell" data-testid="camera-cell"><option value="">the one drawn in</option>
        ${[1, 2, 3, 4, 5, 6, 7, 8, 9].map((n) => `<option>${n}</option>`).join("")}</select></label>
      <label class="file">Upload video… <input type="file" id="camera-upload" accept="video/*,.y4m" data-testid="camera-upload"></label>
    </div>
    <p class="help">Print the sheet (<code>hila sheet --out sheet.pdf --grid</code>, at 100 %), put a coloured ball on the
    pen's tip, and show the whole sheet to the camera. Press <b>Record</b> with the pen in the air, reach, draw, lift,
    move away, press <b>Stop</b>. The frames go to this studio only.</p>
    <canvas id="camera-canvas" data-testid="camera-canvas" width="640" height="480"></canvas>
    <div id="camera-status" data-testid="camera-status" class="status"></div>
    <div id="camera-track" data-testid="camera-track" class="muted"></div>
    <video id="camera-video" playsinline muted hidden></video>
  </div>`;

// the scene's state (window.hilaStudio.demo.camera): what the last frame showed, how many are recorded
export const state = { on: false, recording: false, frame: null, recorded: 0, sent: 0, answered: 0, track: null, error: null };
const C = state;
let ws = null, stream = null, timer = null, onTrack = null, inflight = 0, limits = { fps: 20, max_side: 640 };
const grab = document.createElement("canvas");

const status = (text) => { $("camera-status").textContent = text; };
const start = () => ({ op: "start", ball: $("camera-ball").value, ball_mm: +$("camera-ball-mm").value || 12 });

function answer(m) {
  inflight = Math.max(0, inflight - 1); C.answered++;
  if (m.op === "ready") { limits = m.limits; return; }
  if (m.op === "frame") { C.frame = m.frame; C.recorded = m.recorded; draw(); say(); return; }
  if (m.op === "track") { finished(m); return; }
  if (m.op === "refused") {
    C.error = m.error; status("refused: " + m.error);
    if (m.was === "stop") { C.recording = false; buttons(); }
  }
}
function finished(m) {   // the recording's account stays on its own line (the live status goes on)
  C.track = m; C.error = null; status("");
  $("camera-track").textContent = `recorded: ${m.summary} Still frames left out: ${m.still[0]} before, ${m.still[1]} after; ` +
    `longest gap between frames ${m.longest_gap_s.toFixed(2)} s.`;
  onTrack(m);
}
function say() {
  const f = C.frame; if (!f || C.error && !C.recording) return;
  const sheet = f.sheet ? `sheet: ${Object.keys(f.markers).length} of 4 markers${f.remembered.length ? ` (${f.remembered.length} remembered)` : ""}` : "no sheet (show its corner markers)";
  const ball = f.ball ? (f.tip ? `tip at (${f.tip[0].toFixed(1)}, ${f.tip[1].toFixed(1)}) mm` : "ball seen") : `no ${$("camera-ball").value} ball`;
  status(`${sheet}; ${ball}` + (C.recording ? `; recording: ${C.recorded} frames` + (C.sent - C.answered > 2 ? ` (the server is ${C.sent - C.answered} behind)` : "") : ""));
}

// the live image with what the server found in it: the markers seen (outlined, with their ids), the ball
function draw() {
  const c = $("camera-canvas"), ctx = c.getContext("2d"), v = $("camera-video");
  if (v.videoWidth) { if (c.width !== v.videoWidth) { c.width = v.videoWidth; c.height = v.videoHeight; } ctx.drawImage(v, 0, 0); }
  const f = C.frame; if (!f) return;
  const s = c.width / f.size[0];
  ctx.lineWidth = 2;
  for (const [id, corners] of Object.entries(f.markers)) {
    ctx.strokeStyle = "#00c853"; ctx.setLineDash([]); ctx.beginPath();
    corners.forEach(([u, w], i) => (i ? ctx.lineTo(u * s, w * s) : ctx.moveTo(u * s, w * s))); ctx.closePath(); ctx.stroke();
    ctx.fillStyle = "#00c853"; ctx.font = "12px sans-serif"; ctx.fillText(id, corners[0][0] * s, corners[0][1] * s - 4);
  }
  if (f.ball) {
    const [u, w] = f.ball.uv; ctx.strokeStyle = C.recording ? "#d50000" : "#ff6d00"; ctx.setLineDash([]);
    ctx.beginPath(); ctx.arc(u * s, w * s, Math.max(f.ball.radius * s, 3), 0, 2 * Math.PI); ctx.stroke();
    ctx.beginPath(); ctx.moveTo(u * s - 6, w * s); ctx.lineTo(u * s + 6, w * s); ctx.moveTo(u * s, w * s - 6); ctx.lineTo(u * s, w * s + 6); ctx.stroke();
  }
  if (C.recording) { ctx.fillStyle = "#d50000"; ctx.beginPath(); ctx.arc(16, 16, 7, 0, 2 * Math.PI); ctx.fill(); }
}

// one frame to the server: downscaled to limits.max_side, JPEG, stamped with the camera's own time
// of the frame (requestVideoFrameCallback's mediaTime: no duplicates, no timer jitter), at most
// limits.fps a second; the live view sends one at a time (no backlog), a recording every frame
let lastT = -Infinity;
function send(t) {
  const v = $("camera-video");
  if (!v.videoWidth || t < lastT + 1 / limits.fps - 0.002 || (!C.recording && inflight > 0)) { if (!C.recording) draw(); return; }
  lastT = t;
  const k = Math.min(1, limits.max_side / Math.max(v.videoWidth, v.videoHeight));
  grab.width = Math.round(v.videoWidth * k / 2) * 2; grab.height = Math.round(v.videoHeight * k / 2) * 2;
  grab.getContext("2d").drawImage(v, 0, 0, grab.width, grab.height);
  const jpeg = grab.toDataURL("image/jpeg", 0.9).split(",")[1];
  inflight++; C.sent++;
  ws.send({ op: "frame", t, jpeg, record: C.recording });
  draw();
}
function everyFrame(v) {
  if ("requestVideoFrameCallback" in v) {
    const next = (now, meta) => { if (!C.on) return; v.requestVideoFrameCallback(next); send(meta.mediaTime); };
    v.requestVideoFrameCallback(next);
  } else timer = setInterval(() => send(performance.now() / 1000), 1000 / 30);   // a browser without it
}

function buttons() {
  $("camera-record").disabled = !C.on || C.recording; $("camera-stop").disabled = !C.recording; $("camera-start").disabled = C.on;
}
async function startCamera() {
  try {
    stream = await navigator.mediaDevices.getUserMedia({ video: { width: { ideal: 640 }, height: { ideal: 480 } }, audio: false });
  } catch (err) { status("no camera: " + err.message + " (allow this page to use the camera, or upload a video)"); return; }
  const v = $("camera-video"); v.srcObject = stream; await v.play();
  ws = ws || socket("/ws/camera", answer);
  inflight = 1; lastT = -Infinity; ws.send(start());
  C.on = true; C.error = null; buttons(); status("camera on: show the whole sheet");
  everyFrame(v);
}
export function stopCamera() {
  if (timer) clearInterval(timer); timer = null;
  if (stream) stream.getTracks().forEach((t) => t.stop()); stream = null;
  C.on = false; C.recording = false; if ($("camera-record")) buttons();
}
function record() { C.recording = true; C.recorded = 0; C.track = null; C.error = null; buttons(); }
function stop() {
  C.recording = false; buttons(); status("tracking the recording …");
  inflight++; C.sent++; ws.send({ op: "stop", cell: $("camera-cell").value || null });
}
async function upload(e) {
  const f = e.target.files[0]; if (!f) return;
  status(`tracking ${f.name} …`);
  const q = new URLSearchParams({ name: f.name, ball: $("camera-ball").value, ball_mm: $("camera-ball-mm").value, cell: $("camera-cell").value });
  try { const m = await api("/api/camera/video?" + q, { method: "POST", body: f }); finished(m); }
  catch (err) { C.error = err.message; status("refused: " + err.message); }
  e.target.value = "";
}

// show or hide the panel (the Demonstrate page's scene menu); `use(track)` puts a finished track on the page
export function showCamera(on) { $("camera-panel").hidden = !on; if (!on) stopCamera(); }
export function mountCamera(use) {
  onTrack = use;
  $("camera-start").addEventListener("click", startCamera);
  $("camera-record").addEventListener("click", record);
  $("camera-stop").addEventListener("click", stop);
  $("camera-upload").addEventListener("change", upload);
}
