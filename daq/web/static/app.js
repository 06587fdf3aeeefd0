// cartlab bench page: one EventSource, a canvas plot redrawn at most once per animation
// frame, and a few DOM updates. No framework, no build step.
// window.cartlab exposes counters that tests and tools/bench_web.py read.
"use strict";

const cartlab = window.cartlab = {
  bench: null, connected: false, state: null, status: null,
  eventsReceived: 0, sampleEvents: 0, samplesRaw: 0, pointsReceived: 0,
  framesDrawn: 0, pointsDrawn: 0, historyPoints: 0, historyLoadedMs: null, drawMs: 0, handlerMs: 0, lastT: null, lastAction: null, stale: null, stateMsg: null, runs: {}, stateHistory: [],
  startedMs: performance.now(),
};

const $ = (id) => document.getElementById(id);
const CAPACITY = 40000;          // points per channel kept (30 s at up to ~1.3 kHz)

// ---- trace buffer ------------------------------------------------------------------
const trace = cartlab.trace = { t: [], p1: [], p2: [], dirty: true };

function clearTrace() {
  trace.t = []; trace.p1 = []; trace.p2 = []; trace.dirty = true; cartlab.lastT = null;
}

function appendPoints(d) {
  // Points at or before the last one held are skipped: a batch flushed while a page opens
  // can reach it both in the snapshot's history and as the first samples event.
  const n = d.t_s.length;
  if (n === 0) return 0;
  if (cartlab.lastT !== null && d.t_s[0] < cartlab.lastT - 1.0) clearTrace(); // clock restarted
  let added = 0;
  for (let i = 0; i < n; i++) {
    if (cartlab.lastT !== null && d.t_s[i] <= cartlab.lastT) continue;
    trace.t.push(d.t_s[i]);
    trace.p1.push(d.pos1_m[i]);
    trace.p2.push(d.pos2_m ? d.pos2_m[i] : null);
    cartlab.lastT = d.t_s[i];
    added++;
  }
  if (trace.t.length > CAPACITY) {
    const cut = trace.t.length - CAPACITY;
    trace.t.splice(0, cut); trace.p1.splice(0, cut); trace.p2.splice(0, cut);
  }
  trace.dirty = true;
  return added;
}

function appendSamples(d) {
  cartlab.pointsReceived += appendPoints(d);
  cartlab.samplesRaw += d.n_raw;
  cartlab.sampleEvents += 1;
}

function loadHistory(h) {
  clearTrace();
  if (h) cartlab.historyPoints = appendPoints(h);
  cartlab.historyLoadedMs = performance.now();  // ms since the page's navigation began
}

// ---- plot ----------------------------------------------------------------------------
function niceStep(span, target) {
  const raw = span / target, mag = Math.pow(10, Math.floor(Math.log10(raw)));
  for (const m of [1, 2, 5, 10]) if (m * mag >= raw) return m * mag;
  return 10 * mag;
}

function draw() {
  requestAnimationFrame(draw);
  if (!trace.dirty) return;
  trace.dirty = false;
  const started = performance.now();
  const canvas = $("plot"), dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr)) { canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr); }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const left = 62, right = 12, top = 10, bottom = 36;
  const pw = w - left - right, ph = h - top - bottom;
  const windowS = Number($("window-select").value);
  const tEnd = cartlab.lastT === null ? 0 : cartlab.lastT, tStart = tEnd - windowS;
  let first = trace.t.length;
  while (first > 0 && trace.t[first - 1] >= tStart) first--;
  let lo = Infinity, hi = -Infinity;
  for (let i = first; i < trace.t.length; i++) {
    const a = trace.p1[i], b = trace.p2[i];
    if (a < lo) lo = a; if (a > hi) hi = a;
    if (b !== null) { if (b < lo) lo = b; if (b > hi) hi = b; }
  }
  if (!isFinite(lo)) { lo = -0.05; hi = 0.05; }
  const mid = (lo + hi) / 2, half = Math.max((hi - lo) / 2 * 1.1, 0.01);
  lo = mid - half; hi = mid + half;
  const x = (t) => left + (t - tStart) / windowS * pw;
  const y = (p) => top + (hi - p) / (hi - lo) * ph;

  ctx.font = "12px system-ui, sans-serif"; ctx.fillStyle = "#5b6575"; ctx.strokeStyle = "#e3e6eb"; ctx.lineWidth = 1;
  const ys = niceStep(hi - lo, 6);
  ctx.textAlign = "right"; ctx.textBaseline = "middle";
  for (let v = Math.ceil(lo / ys) * ys; v <= hi; v += ys) {
    ctx.beginPath(); ctx.moveTo(left, y(v)); ctx.lineTo(left + pw, y(v)); ctx.stroke();
    ctx.fillText(v.toFixed(ys < 0.01 ? 3 : 2), left - 6, y(v));
  }
  const xs = niceStep(windowS, 10);
  ctx.textAlign = "center"; ctx.textBaseline = "top";
  for (let v = 0; v <= windowS + 1e-9; v += xs) {
    const px = left + pw - v / windowS * pw;
    ctx.beginPath(); ctx.moveTo(px, top); ctx.lineTo(px, top + ph); ctx.stroke();
    ctx.fillText(v === 0 ? "0" : "−" + v.toFixed(xs < 1 ? 1 : 0), px, top + ph + 4);
  }
  ctx.fillText("time before latest sample (s)", left + pw / 2, top + ph + 19);
  ctx.save(); ctx.translate(14, top + ph / 2); ctx.rotate(-Math.PI / 2); ctx.textBaseline = "middle";
  ctx.fillText("position (m)", 0, 0); ctx.restore();
  ctx.strokeStyle = "#9aa3b1"; ctx.strokeRect(left, top, pw, ph);

  let drawn = 0;
  const line = (values, color, dash) => {
    ctx.strokeStyle = color; ctx.lineWidth = 2; ctx.setLineDash(dash); ctx.beginPath();
    let pen = false;
    for (let i = first; i < trace.t.length; i++) {
      const v = values[i];
      if (v === null) { pen = false; continue; }
      if (pen) ctx.lineTo(x(trace.t[i]), y(v)); else { ctx.moveTo(x(trace.t[i]), y(v)); pen = true; }
      drawn++;
    }
    ctx.stroke(); ctx.setLineDash([]);
  };
  ctx.save(); ctx.beginPath(); ctx.rect(left, top, pw, ph); ctx.clip();
  line(trace.p1, "#1f5fbf", []);
  line(trace.p2, "#d9631e", [7, 4]);
  ctx.restore();
  cartlab.framesDrawn += 1;
  cartlab.pointsDrawn += drawn;
  cartlab.drawMs += performance.now() - started;
}

// ---- state, status, problems -------------------------------------------------------
function showState(msg) {
  cartlab.state = msg ? msg.state : null;
  if (msg && cartlab.stateHistory[cartlab.stateHistory.length - 1] !== msg.state) cartlab.stateHistory.push(msg.state);
  cartlab.stateMsg = msg;
  renderState();
}

// A stale bench never shows its last state as if current: the box turns grey and says
// "stale", with the last state known and since when (the server dates the turn).
function renderState() {
  const msg = cartlab.stateMsg, stale = cartlab.stale;
  $("state").className = "state state-" + (stale ? "stale" : msg ? msg.state : "unknown");
  $("state-text").textContent = stale ? "stale" : msg ? msg.state : "—";
  const last = msg ? `last ${msg.state}${msg.run_id ? " · run " + msg.run_id : ""}` : "";
  $("state-run").textContent = stale ? `${stale.reason}${stale.since ? " since " + clock(stale.since) : ""}${last ? " · " + last : ""}`
    : msg && msg.run_id ? "run " + msg.run_id : "";
  renderLink();
}

function clock(unixS) {
  return new Date(unixS * 1000).toLocaleTimeString([], { hour12: false });
}

function renderLink() {
  const badge = $("link");
  if (!cartlab.connected) { badge.className = "link down"; badge.textContent = "page server gone: reconnecting…"; return; }
  if (cartlab.stale) {
    badge.className = "link down";
    badge.textContent = `stale: ${cartlab.stale.reason}` + (cartlab.stale.since ? ` since ${clock(cartlab.stale.since)}` : "");
    return;
  }
  badge.className = "link up"; badge.textContent = "live";
}

const fmt = (v, digits) => (v === null || v === undefined ? "—" : Number(v).toFixed(digits));

function showStatus(view) {
  if (!view) return;
  const s = view.status;
  cartlab.status = s;
  cartlab.stale = view.bench && view.stale ? { reason: view.stale, since: view.stale_since } : null;
  $("status").classList.toggle("stale", cartlab.stale !== null);
  const portText = s ? `${s.connected ? "connected" : "NOT CONNECTED"} · ${s.dialect} · ${s.port}` : "—";
  $("st-port").textContent = cartlab.stale && cartlab.stale.reason !== "port gone"
    ? `${cartlab.stale.reason} (last: ${portText})` : portText;
  $("st-port").title = s ? s.port : "";
  const pos = s && s.last_pos_m ? s.last_pos_m : [];
  $("st-pos1").textContent = pos.length > 0 ? fmt(pos[0], 4) + " m" : "—";
  $("st-pos2").textContent = pos.length > 1 ? fmt(pos[1], 4) + " m" : "—";
  $("st-zero").textContent = s ? s.zero_offsets_raw.map((v) => fmt(v, 0)).join(", ") : "—";
  $("st-lines").textContent = s ? `${s.counters.lines} / ${s.counters.bad_lines}` : "—";
  const list = $("problems");
  list.replaceChildren(...view.problems.map((p) => { const li = document.createElement("li"); li.textContent = p; return li; }));
  list.hidden = view.problems.length === 0;
  $("zero-btn").disabled = !view.alive; $("arm-btn").disabled = !view.alive;
  renderState();
}

function showBenches(benches) {
  const sel = $("bench-select");
  const alive = benches.filter((b) => b.alive);
  sel.replaceChildren(...benches.map((b) => {
    const o = document.createElement("option"); o.value = b.name;
    o.textContent = b.name + (b.alive ? "" : " (not running)"); o.selected = b.name === cartlab.bench; return o;
  }));
  $("bench-picker").hidden = alive.length <= 1 && benches.length <= 1;
  $("bench-name").textContent = cartlab.bench ? "· " + cartlab.bench : "· no daq found";
}

// ---- runs table ---------------------------------------------------------------------
function el(tag, text, cls) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) e.textContent = text;
  if (cls) e.className = cls;
  return e;
}

function link(href, text) { const a = el("a", text); a.href = href; return a; }

function fitCells(row) {
  const f = row.fit;
  if (!f || f.status === "withdrawn") return [el("td", row.status === "complete" || row.status === "recovered" ? "waiting for a fit…" : "", "fit-wait")];
  if (f.status === "fitting") return [el("td", `fitting (worker ${f.worker})…`, "fit-wait")];
  if (f.status === "failed") return [el("td", "fit failed: " + f.reason, "fit-failed")];
  const modes = f.pem ? f.pem.wn_rad_s.map((wn, i) => [wn, f.pem.zeta[i]])
    : f.simple.filter((s) => s.method === "rk4").map((s) => [s.wn_rad_s, s.zeta]);
  const fits = f.pem ? f.pem.fit_percent : f.simple.filter((s) => s.method === "rk4").map((s) => s.fit_percent);
  const tag = f.pem ? `PEM order ${f.pem.order}` : "simple (RK4)";
  const wn = el("td", modes.map((m) => fmt(m[0], 3)).join(" / "), "num");
  wn.append(el("div", tag, "sub"));
  const simple = f.simple.map((s) => `${s.method} cart ${s.output}: ωn ${fmt(s.wn_rad_s, 3)}, ζ ${fmt(s.zeta, 4)}, fit ${fmt(s.fit_percent, 1)} %`);
  wn.title = simple.join("\n");
  const d = f.diagnosis;
  const cause = el("td", d ? d.cause : "—");
  if (d) cause.title = d.explanation;
  const gain = el("td", d ? (d.gain_points >= 0 ? "+" : "") + fmt(d.gain_points, 2) + " pts" : "—", "num");
  if (d) gain.title = `fit ${fmt(d.baseline_fit_percent, 2)} % → ${fmt(d.extended_fit_percent, 2)} % with ${d.cause}`;
  return [wn, el("td", modes.map((m) => fmt(m[1], 4)).join(" / "), "num"),
    el("td", fits.map((v) => fmt(v, 1)).join(" / "), "num"), cause, gain];
}

function renderRuns() {
  const body = $("runs-body");
  const rows = Object.values(cartlab.runs).sort((a, b) => (a.run_id < b.run_id ? 1 : -1));
  if (rows.length === 0) {
    body.replaceChildren(el("tr", null, "empty")); body.firstChild.append(el("td", "no runs yet: pull a cart, zero, let go"));
    body.firstChild.firstChild.colSpan = 10; return;
  }
  body.replaceChildren(...rows.map((row) => {
    const tr = el("tr"); tr.dataset.run = row.run_id;
    const status = el("td", row.status || "—"); if (row.reason) status.title = row.reason;
    if (row.reason && row.status && row.status !== "complete") status.append(el("div", row.reason, "sub"));
    tr.append(el("td", row.run_id), status, el("td", fmt(row.release_time_s, 3), "num"),
      el("td", fmt(row.duration_s, 2), "num"));
    const cells = fitCells(row);
    if (cells.length === 1) cells[0].colSpan = 5;
    tr.append(...cells);
    const files = el("td", null, "files");
    const enc = encodeURIComponent(row.run_id);
    if (row.file) files.append(link(`/files/${enc}/mcap?bench=${encodeURIComponent(row.bench)}`, "MCAP"));
    const names = new Set(row.fit_files || []);
    if (row.fit && (row.fit.status === "ok" || row.fit.status === "failed")) for (const n of row.fit.figures) names.add(n);
    for (const n of [...names].sort()) files.append(link(`/files/${enc}/fit/${encodeURIComponent(n)}`, n === "report.json" ? "report" : n));
    tr.append(files);
    return tr;
  }));
}

// ---- buttons -------------------------------------------------------------------------
async function act(action) {
  const out = $("action-result");
  out.className = "action-result"; out.textContent = action + "…";
  try {
    const r = await fetch(`/api/bench/${encodeURIComponent(cartlab.bench)}/${action}`, { method: "POST", headers: { "X-Cartlab-Action": "1" } });
    const body = await r.json();
    cartlab.lastAction = { action, ok: body.ok, message: body.message, reply: body.reply || null };
    out.className = "action-result " + (body.ok ? "ok" : "err"); out.textContent = body.message;
  } catch (e) {
    cartlab.lastAction = { action, ok: false, message: String(e) };
    out.className = "action-result err"; out.textContent = `${action} failed: ${e}`;
  }
}

// ---- the event stream ----------------------------------------------------------------
let source = null;

function connect(bench) {
  if (source) source.close();
  clearTrace(); cartlab.runs = {}; renderRuns();
  const url = "/api/events" + (bench ? "?bench=" + encodeURIComponent(bench) : "");
  source = new EventSource(url);
  const on = (name, fn) => source.addEventListener(name, (ev) => {
    const started = performance.now();
    cartlab.eventsReceived++; fn(JSON.parse(ev.data));
    cartlab.handlerMs += performance.now() - started;
  });
  source.onopen = () => { cartlab.connected = true; renderLink(); };
  source.onerror = () => { cartlab.connected = false; renderLink(); };
  on("snapshot", (d) => {
    cartlab.bench = d.bench;
    if (d.bench) history.replaceState(null, "", "#bench=" + encodeURIComponent(d.bench));
    showBenches(d.benches); showState(d.state); showStatus(d.status); loadHistory(d.history);
    cartlab.runs = {}; for (const r of d.runs) cartlab.runs[r.run_id] = r; renderRuns();
  });
  on("samples", appendSamples);
  on("state", showState);
  on("status", showStatus);
  on("benches", (d) => { showBenches(d.benches); if (!cartlab.bench && d.benches.some((b) => b.alive)) connect(null); });
  on("run", (r) => { cartlab.runs[r.run_id] = r; renderRuns(); });
}

function rateMeter() {
  let last = { t: performance.now(), raw: 0, ev: 0, frames: 0 };
  setInterval(() => {
    const now = performance.now(), dt = (now - last.t) / 1000;
    const raw = (cartlab.samplesRaw - last.raw) / dt, ev = (cartlab.sampleEvents - last.ev) / dt;
    const fr = (cartlab.framesDrawn - last.frames) / dt;
    cartlab.rates = { samplesPerS: raw, updatesPerS: ev, framesPerS: fr };
    $("rate").textContent = `${raw.toFixed(0)} samples/s · ${ev.toFixed(1)} updates/s · ${fr.toFixed(0)} frames/s`;
    last = { t: now, raw: cartlab.samplesRaw, ev: cartlab.sampleEvents, frames: cartlab.framesDrawn };
  }, 1000);
}

$("zero-btn").addEventListener("click", () => act("zero"));
$("arm-btn").addEventListener("click", () => act("arm"));
$("bench-select").addEventListener("change", (e) => connect(e.target.value));
$("window-select").addEventListener("change", () => { trace.dirty = true; });
const fromHash = new URLSearchParams(location.hash.slice(1)).get("bench");
connect(fromHash);
rateMeter();
requestAnimationFrame(draw);
