// incandescent view: the page. It holds the view (camera and controls), sends it as scene
// overrides over a websocket, and shows the frames the server renders (coarse while a control
// moves, refined when still). Every request carries the URL's token.
"use strict";

const token = new URLSearchParams(location.search).get("token") || "";
const $ = (id) => document.getElementById(id);
const viewer = (window.viewer = {
  camera: null, frame: 0, frames: 1, seq: 0, shownSeq: -1, shown: null, lastFinal: null,
  probe: null, error: null, hello: null, playing: null, finals: 0,
});

// --- vectors -----------------------------------------------------------------------------
const sub = (a, b) => a.map((v, i) => v - b[i]);
const add = (a, b) => a.map((v, i) => v + b[i]);
const scale = (a, s) => a.map((v) => v * s);
const norm = (a) => Math.hypot(...a);
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]];
const unit = (a) => scale(a, 1 / norm(a));

// --- the camera: orbit about the target (y up), pan, zoom -----------------------------------
function orbit(cam, dx, dy) {
  const o = sub(cam.eye, cam.target), r = norm(o);
  let az = Math.atan2(o[0], o[2]);
  let el = Math.asin(Math.max(-1, Math.min(1, o[1] / r)));
  az -= dx * 0.008;
  el = Math.max(-1.5, Math.min(1.5, el + dy * 0.008));
  const d = [Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az)];
  return { ...cam, eye: add(cam.target, scale(d, r)) };
}

function pan(cam, dx, dy, heightPx) {
  const forward = unit(sub(cam.target, cam.eye));
  const right = unit(cross(forward, cam.up || [0, 1, 0]));
  const up = cross(right, forward);
  const r = norm(sub(cam.eye, cam.target));
  const perPx = (2 * r * Math.tan((cam.fov_deg * Math.PI) / 360)) / heightPx;
  const shift = add(scale(right, -dx * perPx), scale(up, dy * perPx));
  return { ...cam, eye: add(cam.eye, shift), target: add(cam.target, shift) };
}

function zoom(cam, steps) {
  const o = scale(sub(cam.eye, cam.target), Math.exp(steps * 0.001));
  return { ...cam, eye: add(cam.target, o) };
}

// --- controls → scene overrides -------------------------------------------------------------
const num = (id) => ($(id).value === "" ? null : Number($(id).value));
let initial = {};

function put(table, dotted, value) {
  if (value === null || value === undefined || Number.isNaN(value)) return;
  const keys = dotted.split(".");
  let t = table;
  for (const k of keys.slice(0, -1)) t = t[k] = t[k] || {};
  t[keys[keys.length - 1]] = value;
}

function parseSpecies(text) {
  const out = {};
  for (const item of text.split(",").map((s) => s.trim()).filter(Boolean)) {
    const [name, value] = item.split("=");
    out[name.trim()] = value !== undefined && value.trim() !== "" && !isNaN(Number(value))
      ? Number(value) : (value || "").trim();
  }
  return Object.keys(out).length ? out : null;
}

function parseSun(text) {
  const v = text.split(",").map(Number);
  if (text.trim() === "") return null;
  return [{ type: "directional", direction: v.slice(0, 3), illuminance_lux: v[3] }];
}

function controls() {
  return {
    "display.exposure_ev": Number($("exposure").value),
    "display.auto_exposure": $("auto-exposure").checked,
    "display.tonemap": $("tonemap").value,
    "volume.preset": $("preset").value || null,
    "volume.temperature.offset": num("offset"),
    "volume.temperature.scale": num("scale"),
    "volume.temperature.cutoff_K": num("cutoff"),
    "volume.temperature.range": num("range-low") !== null && num("range-high") !== null
      ? [num("range-low"), num("range-high")] : null,
    "volume.absorption": num("absorption"),
    "volume.soot_alpha": num("soot-alpha"),
    "volume.species": parseSpecies($("species").value),
    "volume.albedo": num("albedo"),
    "volume.phase_g": num("phase-g"),
    "light": parseSun($("sun").value),
    "integrator.spp": num("spp"),
    "render.width": num("width"),
    "render.height": num("height"),
    "render.step_voxels": num("step"),
    "camera.fov_deg": num("fov"),
  };
}

// the overrides of the controls the user changed, and the camera once it moved
function overrides() {
  const out = {}, now = controls();
  for (const [key, value] of Object.entries(now)) {
    if (JSON.stringify(value) !== JSON.stringify(initial[key])) put(out, key, value);
  }
  if (viewer.camera && viewer.camera.moved) {
    put(out, "camera.eye", viewer.camera.eye);
    put(out, "camera.target", viewer.camera.target);
    put(out, "camera.fov_deg", num("fov"));
  }
  return out;
}

// --- the socket ------------------------------------------------------------------------------
const ws = new WebSocket(
  (location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws?token=" +
  encodeURIComponent(token));

function send(preview, refineAfterS) {
  if (ws.readyState !== WebSocket.OPEN) return;
  viewer.seq += 1;
  ws.send(JSON.stringify({ type: "view", overrides: overrides(), frame: viewer.frame,
                           preview, seq: viewer.seq, refine_after_s: refineAfterS }));
}
viewer.send = send;

ws.onclose = () => status("disconnected: the server stopped", true);
ws.onmessage = (event) => {
  const msg = JSON.parse(event.data);
  if (msg.type === "hello") hello(msg);
  else if (msg.type === "frame") showFrame(msg);
  else if (msg.type === "probe") showProbe(msg);
  else if (msg.type === "error") { viewer.error = msg.message; status(msg.message, true); }
};

function status(text, error) {
  $("status").textContent = text;
  $("status").className = error ? "error" : "";
}

function hello(msg) {
  viewer.hello = msg;
  viewer.frames = msg.frames;
  if (msg.frames > 1) {
    $("time").hidden = false;
    $("frame").max = msg.frames - 1;
    $("frame-name").textContent = msg.names[0];
  }
  showBase(msg.base || {});
  initial = controls();
  send(true, 0); // a coarse first image at once, refined right after it
}

// the controls show the view the command line set (its flags are the base of every view)
const CONTROL_KEYS = {
  exposure: "display.exposure_ev", tonemap: "display.tonemap", preset: "volume.preset",
  offset: "volume.temperature.offset", scale: "volume.temperature.scale",
  cutoff: "volume.temperature.cutoff_K", absorption: "volume.absorption",
  "soot-alpha": "volume.soot_alpha", albedo: "volume.albedo", "phase-g": "volume.phase_g",
  spp: "integrator.spp", width: "render.width", height: "render.height",
  step: "render.step_voxels", fov: "camera.fov_deg",
};

function showBase(base) {
  const at = (key) => key.split(".").reduce((t, k) => (t && k in t ? t[k] : undefined), base);
  for (const [id, key] of Object.entries(CONTROL_KEYS)) {
    const value = at(key);
    if (value !== undefined && typeof value !== "object") $(id).value = value;
  }
  if (at("display.auto_exposure") === false) $("auto-exposure").checked = false;
  const range = at("volume.temperature.range");
  if (range) { $("range-low").value = range[0]; $("range-high").value = range[1]; }
  const species = at("volume.species");
  if (species) $("species").value = Object.entries(species).map(([k, v]) => `${k}=${v}`).join(",");
  $("exposure-out").textContent = Number($("exposure").value).toFixed(1);
}

function showFrame(msg) {
  if (msg.seq < viewer.shownSeq) return; // an older view's frame: the newer one is coming
  viewer.shownSeq = msg.seq;
  viewer.shown = msg;
  $("view").src = "data:image/png;base64," + msg.png;
  $("view").className = msg.preview ? "preview" : "";
  if (msg.preview) {
    $("view").style.width = 2 * msg.width + "px";
  } else {
    $("view").style.width = msg.width + "px";
    final(msg);
  }
  const ms = msg.seconds ? (1000 * msg.seconds).toFixed(0) + " ms" : "";
  status(`${msg.width}×${msg.height} ${msg.preview ? "preview" : "final"} ${ms}` +
         (viewer.frames > 1 ? ` · frame ${msg.frame}` : ""));
}

function final(msg) {
  viewer.lastFinal = msg;
  viewer.finals += 1;
  viewer.error = null;
  if (!viewer.camera || !viewer.camera.moved) viewer.camera = { ...msg.camera, moved: false };
  for (const [id, value] of [["width", msg.width], ["height", msg.height],
                             ["fov", msg.camera.fov_deg]]) {
    if ($(id).value === "") {
      $(id).value = value;
      initial[{ width: "render.width", height: "render.height", fov: "camera.fov_deg" }[id]] =
        value;
    }
  }
  $("command").value = msg.command || "(a scene file over a sequence: save the scene file " +
                                      "and render it)";
  drawHistogram(msg.histogram);
}

function drawHistogram(h) {
  const canvas = $("histogram"), g = canvas.getContext("2d");
  g.clearRect(0, 0, canvas.width, canvas.height);
  if (!h || !h.counts.length) return;
  const top = Math.log1p(Math.max(...h.counts)), w = canvas.width / h.counts.length;
  g.fillStyle = "#f93";
  h.counts.forEach((c, i) => {
    const bar = (Math.log1p(c) / top) * (canvas.height - 14);
    g.fillRect(i * w, canvas.height - 14 - bar, Math.max(1, w - 1), bar);
  });
  g.fillStyle = "#aaa";
  g.font = "10px sans-serif";
  g.fillText(h.edges_K[0].toFixed(0) + " K", 2, canvas.height - 2);
  const hi = h.edges_K[h.edges_K.length - 1].toFixed(0) + " K";
  g.fillText(hi, canvas.width - g.measureText(hi).width - 2, canvas.height - 2);
}

function showProbe(msg) {
  viewer.probe = msg;
  const f = (v) => (v === undefined ? "—" : Number(v).toPrecision(5));
  const lines = [`pixel (${msg.column}, ${msg.row})`];
  if (msg.xyz) {
    lines.push(`radiance XYZ ${msg.xyz.map(f).join(", ")}`,
               `luminance ${f(msg.luminance_cd_m2)} cd/m²`,
               `linear RGB ${msg.rgb.map(f).join(", ")}`);
  } else {
    lines.push(`display RGB ${msg.display_rgb.map(f).join(", ")}`);
  }
  lines.push(`transmittance ${f(msg.transmittance)}`,
             `hottest along the ray ${f(msg.hottest_K)} K`);
  $("probe").textContent = lines.join("\n");
}

// --- mouse: orbit, pan, zoom, probe ----------------------------------------------------------
let drag = null;
const img = $("view");
img.addEventListener("contextmenu", (e) => e.preventDefault());
img.addEventListener("mousedown", (e) => {
  drag = { x: e.clientX, y: e.clientY, moved: false, pan: e.shiftKey || e.button === 2 };
  e.preventDefault();
});
window.addEventListener("mousemove", (e) => {
  if (!drag || !viewer.camera) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  if (!dx && !dy) return;
  drag.x = e.clientX;
  drag.y = e.clientY;
  drag.moved = true;
  const cam = drag.pan ? pan(viewer.camera, dx, dy, img.clientHeight || 1)
                       : orbit(viewer.camera, dx, dy);
  viewer.camera = { ...cam, moved: true };
  send(true);
});
window.addEventListener("mouseup", (e) => {
  if (!drag) return;
  const moved = drag.moved;
  drag = null;
  if (moved) send(false);
  else probeAt(e);
});
img.addEventListener("wheel", (e) => {
  if (!viewer.camera) return;
  e.preventDefault();
  viewer.camera = { ...zoom(viewer.camera, e.deltaY), moved: true };
  send(true);
}, { passive: false });

function probeAt(e) {
  const last = viewer.lastFinal, rect = img.getBoundingClientRect();
  if (!last || !rect.width) return;
  const column = Math.floor(((e.clientX - rect.left) / rect.width) * last.width);
  const row = Math.floor(((e.clientY - rect.top) / rect.height) * last.height);
  if (column < 0 || row < 0 || column >= last.width || row >= last.height) return;
  ws.send(JSON.stringify({ type: "probe", column, row }));
}
viewer.probeAt = (column, row) => ws.send(JSON.stringify({ type: "probe", column, row }));

// --- sliders: a preview while moving, final when let go; other controls on change -------------
for (const el of document.querySelectorAll("#controls input, #controls select")) {
  if (el.type === "range") el.addEventListener("input", () => send(true));
  el.addEventListener("change", () => send(false));
}
$("exposure").addEventListener("input", () => {
  $("exposure-out").textContent = Number($("exposure").value).toFixed(1);
});
$("frame").addEventListener("input", () => { setFrame(Number($("frame").value)); send(true); });
$("frame").addEventListener("change", () => send(false));

function setFrame(i) {
  viewer.frame = i;
  $("frame").value = i;
  if (viewer.hello) $("frame-name").textContent = viewer.hello.names[i];
}

$("play").addEventListener("click", () => {
  if (viewer.playing) {
    clearInterval(viewer.playing);
    viewer.playing = null;
    $("play").textContent = "▶";
    send(false);
    return;
  }
  $("play").textContent = "❚❚";
  viewer.playing = setInterval(() => {
    setFrame((viewer.frame + 1) % viewer.frames);
    send(true);
  }, 120);
});

// --- keep: files and the command -------------------------------------------------------------
const withToken = (path) => path + "?token=" + encodeURIComponent(token);
$("save-png").href = withToken("image.png");
$("save-exr").href = withToken("image.exr");
$("save-scene").href = withToken("scene.json");
$("copy").addEventListener("click", async () => {
  const text = $("command").value;
  try {
    await navigator.clipboard.writeText(text);
    status("command copied");
  } catch (error) {
    $("command").select();
    document.execCommand("copy");
  }
});
