"""The live view's page (served by cosim.bench.live.view.LiveServer on 127.0.0.1): a canvas drawn
from `/data.json` about 12 times a second (`?frames=N`: N frames, then a still), a check box
per signal, the latest values (with the sample they belong to) and the faults. Plain HTML and
JavaScript: nothing is fetched from anywhere but the bench tool."""

PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>bowden bench live</title>
<style>
body { font-family: sans-serif; margin: 12px; color: #222; background: #fff; }
h1 { font-size: 18px; margin: 0 0 6px 0; }
#message { font-size: 18px; color: #a00; margin: 6px 0; }
canvas { display: block; border: 1px solid #bbb; margin: 4px 0; }
#controls label { margin-right: 14px; }
table { border-collapse: collapse; margin-top: 6px; }
td, th { padding: 2px 10px; text-align: right; font-family: monospace; }
</style></head>
<body>
<h1 id="title">bowden bench live</h1>
<div id="message"></div>
<div id="controls"></div>
<canvas id="tension" width="960" height="300"></canvas>
<canvas id="current" width="960" height="160"></canvas>
<table id="latest"><tr><th>sample</th><td id="sample">-</td></tr></table>
<div id="faults">faults: -</div>
<div id="fps"></div>
<script>
"use strict";
const COLORS = {T_ref: "#000000", T_c: "#e69f00", T_in: "#0072b2", T_out: "#d55e00",
                current: "#009e73"};
const hidden = new Set();
let frames = 0, started = performance.now(), built = false;

// A trace's signal and channel: "T_out[1]" is T_out of channel 1 (several channels shown);
// a channel's traces share the signal's colour, each further channel dashed.
function base(s) { return s.split("[")[0]; }
let d0 = null;
function dash(s) {
  const m = s.match(/\\[(\\d+)\\]$/);
  return m && d0 !== null && Number(m[1]) !== d0 ? [6, 3] : [];
}

function setMessage(text) { document.getElementById("message").textContent = text; }

function buildControls(d) {
  if (built) return;
  built = true;
  const box = document.getElementById("controls");
  const table = document.getElementById("latest");
  for (const s of d.signals) {
    if (s.startsWith("faults")) continue;
    const label = document.createElement("label");
    const check = document.createElement("input");
    check.type = "checkbox"; check.checked = true; check.id = "show-" + s;
    check.onchange = () => { if (check.checked) hidden.delete(s); else hidden.add(s); };
    label.appendChild(check);
    label.appendChild(document.createTextNode(" " + s + " (" + d.units[s] + ")"));
    label.style.color = COLORS[base(s)];
    box.appendChild(label);
    const row = table.insertRow();
    row.innerHTML = "<th>" + s + " (" + d.units[s] + ")</th><td id='v-" + s + "'>-</td>";
  }
}

function panel(canvas, d, names, unit) {
  const g = canvas.getContext("2d"), W = canvas.width, H = canvas.height;
  const L = 56, R = 10, T = 8, B = 24;
  g.clearRect(0, 0, W, H);
  const shown = names.filter(s => !hidden.has(s) && d.series && d.series[s]);
  let lo = Infinity, hi = -Infinity;
  for (const s of shown) for (const v of d.series[s]) { if (v < lo) lo = v; if (v > hi) hi = v; }
  if (!isFinite(lo)) { lo = 0; hi = 1; }
  if (hi - lo < 1e-6) { hi += 0.5; lo -= 0.5; }
  const pad = 0.05 * (hi - lo); lo -= pad; hi += pad;
  const t1 = d.t_s ? d.t_s[d.t_s.length - 1] : 0, t0 = t1 - d.window_s;
  const X = t => L + (t - t0) / (t1 - t0 || 1) * (W - L - R);
  const Y = v => T + (hi - v) / (hi - lo) * (H - T - B);
  g.strokeStyle = "#888"; g.fillStyle = "#222"; g.font = "12px sans-serif"; g.lineWidth = 1;
  g.strokeRect(L, T, W - L - R, H - T - B);
  for (let k = 0; k <= 4; k++) {
    const v = lo + k * (hi - lo) / 4;
    g.fillText(v.toFixed(2), 4, Y(v) + 4);
    const t = t0 + k * d.window_s / 4;
    g.fillText(t.toFixed(1) + " s", X(t) - 14, H - 6);
  }
  g.fillText(unit, L + 4, T + 14);
  for (const s of shown) {
    g.strokeStyle = COLORS[base(s)]; g.lineWidth = 1.5; g.setLineDash(dash(s)); g.beginPath();
    d.series[s].forEach((v, i) => { const x = X(d.t_s[i]), y = Y(v);
      if (i) g.lineTo(x, y); else g.moveTo(x, y); });
    g.stroke();
  }
  g.setLineDash([]);
}

function draw(d) {
  d0 = d.channels ? d.channels[0] : null;
  buildControls(d);
  document.getElementById("title").textContent =
    "bowden bench live: " + (d.label || "no run") + " (last " + d.window_s + " s)";
  setMessage(d.active ? "" : d.message);
  if (!d.samples) return;
  const tensions = d.signals.filter(s => d.units[s] === "N");
  panel(document.getElementById("tension"), d, tensions, "N");
  panel(document.getElementById("current"), d, d.signals.filter(s => d.units[s] === "A"), "A");
  document.getElementById("sample").textContent = d.latest.sample;
  document.getElementById("latest").dataset.sample = d.latest.sample;
  for (const s of d.signals) {
    const cell = document.getElementById("v-" + s);
    if (cell && s in d.latest.values) cell.textContent = d.latest.values[s].toFixed(6);
  }
  document.getElementById("faults").textContent = "faults now: " +
    (d.latest.faults.join(", ") || "none") + "; in the window: " +
    (d.faults_in_window.join(", ") || "none");
}

// ?frames=N: stop after N frames (a still of the page: screenshots, headless checks).
const maxFrames = Number(new URLSearchParams(location.search).get("frames")) || Infinity;

async function tick() {
  const t = performance.now();
  try {
    const r = await fetch("/data.json?points=1000", {cache: "no-store"});
    draw(await r.json());
  } catch (e) {
    setMessage("The bench tool has stopped: no run is active. Start one with " +
               "`bowden bench run --live web` (or `watch --live web`) and open its address.");
  }
  frames++;
  document.getElementById("fps").textContent =
    (frames * 1000 / (performance.now() - started)).toFixed(1) + " frames/s";
  if (frames < maxFrames) setTimeout(tick, Math.max(0, 80 - (performance.now() - t)));
}
tick();
</script>
</body></html>
"""
