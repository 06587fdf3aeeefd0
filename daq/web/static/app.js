// cartlab bench page: one EventSource, a canvas plot redrawn at most once per animation
// frame, and a few DOM updates. No framework, no build step.
// window.cartlab exposes counters that tests and tools/bench_web.py read.
"use strict";

const cartlab = window.cartlab = {
  bench: null, connected: false, state: null, status: null,
  eventsReceived: 0, sampleEvents: 0, samplesRaw: 0, pointsReceived: 0,
  framesDrawn: 0, pointsDrawn: 0, historyPoints: 0, historyLoadedMs: null, drawMs: 0, handlerMs: 0, lastT: null, lastAction: null, stale: null, stateMsg: null, openRun: null, runs: {}, stateHistory: [],
  startedMs: performance.now(),
};

const $ = (id) => document.getElementById(id);
const CAPACITY = 40000;          // points per channel kept (30 s at up to ~1.3 kHz)

// ---- trace buffer ------------------------------------------------------------------
const trace = cartlab.trace = { t: [], p1: [], p2: [], dirty: false };

// One animation frame is asked for only when something must be drawn: an idle or paused
// page schedules no frames at all (a loop of empty frames still costs the browser CPU).
let frameAsked = false;
function redraw() {
  trace.dirty = true;
  if (!frameAsked) { frameAsked = true; requestAnimationFrame(draw); }
}

function clearTrace() {
  trace.t = []; trace.p1 = []; trace.p2 = []; redraw(); cartlab.lastT = null; cartlab.cursor = null;
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
  if (!view.paused) redraw();   // a paused plot is not redrawn: it stays as it was
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
  cartlab.sampleEventsBeforeHistory = cartlab.sampleEvents;
}

// ---- plot ----------------------------------------------------------------------------
function niceStep(span, target) {
  const raw = span / target, mag = Math.pow(10, Math.floor(Math.log10(raw)));
  for (const m of [1, 2, 5, 10]) if (m * mag >= raw) return m * mag;
  return 10 * mag;
}

// What the plot shows: the window ending at the latest sample (live), or frozen at the
// moment of Pause, or a zoomed stretch [t0, t1] (a zoom pauses). Device time in s.
const view = cartlab.view = { paused: false, frozenEnd: null, zoom: null, absolute: false, cursorX: null, geom: null };
const marks = cartlab.marks = [];   // detector state changes {state, t_s, run_id}

function addMark(msg) {
  if (!msg || !msg.t_ns) return;
  const t = msg.t_ns * 1e-9, last = marks[marks.length - 1];
  if (last && last.t_s === t && last.state === msg.state) return;
  marks.push({ state: msg.state, t_s: t, run_id: msg.run_id });
  if (marks.length > 64) marks.shift();
  if (!view.paused) redraw();
}

// Runs as spans: from a release to the next settled/idle/armed change (or still open).
function runSpans() {
  const spans = [];
  for (let i = 0; i < marks.length; i++) {
    if (marks[i].state !== "released") continue;
    const end = marks.slice(i + 1).find((m) => m.state !== "released");
    spans.push({ t0: marks[i].t_s, t1: end ? end.t_s : null, run_id: marks[i].run_id });
  }
  return spans;
}

function visibleRange() {
  if (view.zoom) return view.zoom;
  const windowS = Number($("window-select").value);
  const end = view.paused ? view.frozenEnd : cartlab.lastT;
  const tEnd = end === null ? 0 : end;
  return [tEnd - windowS, tEnd];
}

function firstAtOrAfter(t) {         // binary search in the sorted trace times
  let lo = 0, hi = trace.t.length;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (trace.t[mid] < t) lo = mid + 1; else hi = mid; }
  return lo;
}

function nearestSample(t) {
  const i = firstAtOrAfter(t);
  if (i >= trace.t.length) return trace.t.length - 1;
  if (i > 0 && t - trace.t[i - 1] < trace.t[i] - t) return i - 1;
  return i;
}

function draw() {
  frameAsked = false;
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
  const [tStart, tEnd] = visibleRange(), spanS = Math.max(tEnd - tStart, 1e-6);
  const first = firstAtOrAfter(tStart), stop = firstAtOrAfter(tEnd + 1e-9);
  let lo = Infinity, hi = -Infinity;
  for (let i = first; i < stop; i++) {
    const a = trace.p1[i], b = trace.p2[i];
    if (a < lo) lo = a; if (a > hi) hi = a;
    if (b !== null) { if (b < lo) lo = b; if (b > hi) hi = b; }
  }
  if (!isFinite(lo)) { lo = -0.05; hi = 0.05; }
  const mid = (lo + hi) / 2, half = Math.max((hi - lo) / 2 * 1.1, view.zoom ? 0.0005 : 0.01);
  lo = mid - half; hi = mid + half;
  const x = (t) => left + (t - tStart) / spanS * pw;
  const y = (p) => top + (hi - p) / (hi - lo) * ph;
  view.geom = { left, pw, tStart, spanS };

  ctx.font = "12px system-ui, sans-serif"; ctx.fillStyle = "#5b6575"; ctx.strokeStyle = "#e3e6eb"; ctx.lineWidth = 1;
  const ys = niceStep(hi - lo, 6);
  ctx.textAlign = "right"; ctx.textBaseline = "middle";
  for (let v = Math.ceil(lo / ys) * ys; v <= hi; v += ys) {
    ctx.beginPath(); ctx.moveTo(left, y(v)); ctx.lineTo(left + pw, y(v)); ctx.stroke();
    ctx.fillText(v.toFixed(ys < 0.001 ? 4 : ys < 0.01 ? 3 : 2), left - 6, y(v));
  }
  const xs = niceStep(spanS, 10), dig = xs < 0.1 ? 2 : xs < 1 ? 1 : 0;
  ctx.textAlign = "center"; ctx.textBaseline = "top";
  if (view.absolute) {                 // device time ticks
    for (let v = Math.ceil(tStart / xs) * xs; v <= tEnd + 1e-9; v += xs) {
      ctx.beginPath(); ctx.moveTo(x(v), top); ctx.lineTo(x(v), top + ph); ctx.stroke();
      ctx.fillText(v.toFixed(dig), x(v), top + ph + 4);
    }
    ctx.fillText("device time (s)", left + pw / 2, top + ph + 19);
  } else {                             // seconds before the right edge
    for (let v = 0; v <= spanS + 1e-9; v += xs) {
      const px = left + pw - v / spanS * pw;
      ctx.beginPath(); ctx.moveTo(px, top); ctx.lineTo(px, top + ph); ctx.stroke();
      ctx.fillText(v === 0 ? "0" : "−" + v.toFixed(dig), px, top + ph + 4);
    }
    ctx.fillText(view.paused ? "time before the right edge (s)" : "time before latest sample (s)", left + pw / 2, top + ph + 19);
  }
  ctx.save(); ctx.translate(14, top + ph / 2); ctx.rotate(-Math.PI / 2); ctx.textBaseline = "middle";
  ctx.fillText("position (m)", 0, 0); ctx.restore();
  ctx.strokeStyle = "#9aa3b1"; ctx.strokeRect(left, top, pw, ph);

  ctx.save(); ctx.beginPath(); ctx.rect(left, top, pw, ph); ctx.clip();
  for (const s of runSpans()) {        // run spans shaded, the release instant as a red line
    const x0 = x(s.t0), x1 = s.t1 === null ? left + pw : x(s.t1);
    ctx.fillStyle = "rgba(192, 57, 43, 0.08)"; ctx.fillRect(x0, top, Math.max(x1 - x0, 1), ph);
    ctx.strokeStyle = "#c0392b"; ctx.lineWidth = 1.5; ctx.beginPath(); ctx.moveTo(x0, top); ctx.lineTo(x0, top + ph); ctx.stroke();
    ctx.fillStyle = "#c0392b"; ctx.textAlign = "left"; ctx.fillText("release" + (s.run_id ? " · " + s.run_id : ""), Math.max(x0, left) + 4, top + 2);
  }
  let drawn = 0;
  const line = (values, color, dash) => {
    ctx.strokeStyle = color; ctx.lineWidth = 2; ctx.setLineDash(dash); ctx.beginPath();
    let pen = false;
    for (let i = first; i < stop; i++) {
      const v = values[i];
      if (v === null) { pen = false; continue; }
      if (pen) ctx.lineTo(x(trace.t[i]), y(v)); else { ctx.moveTo(x(trace.t[i]), y(v)); pen = true; }
      drawn++;
    }
    ctx.stroke(); ctx.setLineDash([]);
  };
  line(trace.p1, "#1f5fbf", []);
  line(trace.p2, "#d9631e", [7, 4]);
  if (view.drag) {
    ctx.fillStyle = "rgba(31, 95, 191, 0.12)";
    ctx.fillRect(Math.min(view.drag.x0, view.drag.x1), top, Math.abs(view.drag.x1 - view.drag.x0), ph);
  }
  if (cartlab.cursor) {
    const c = cartlab.cursor;
    ctx.strokeStyle = "#2a3444"; ctx.lineWidth = 1; ctx.setLineDash([3, 3]);
    ctx.beginPath(); ctx.moveTo(x(c.t), top); ctx.lineTo(x(c.t), top + ph); ctx.stroke(); ctx.setLineDash([]);
    for (const [v, color] of [[c.p1, "#1f5fbf"], [c.p2, "#d9631e"]]) {
      if (v === null) continue;
      ctx.fillStyle = color; ctx.beginPath(); ctx.arc(x(c.t), y(v), 4, 0, 2 * Math.PI); ctx.fill();
    }
  }
  ctx.restore();
  cartlab.framesDrawn += 1;
  cartlab.pointsDrawn += drawn;
  cartlab.drawMs += performance.now() - started;
}

// ---- reading the plot: pause, cursor, zoom, time axis --------------------------------
function setPaused(paused) {
  view.paused = paused;
  view.frozenEnd = paused ? cartlab.lastT : null;
  if (!paused) view.zoom = null;
  $("pause-btn").textContent = paused ? "Resume" : "Pause";
  $("pause-btn").classList.toggle("on", paused);
  $("zoom-reset").hidden = view.zoom === null;
  redraw();
}

function timeAtX(clientX) {
  const g = view.geom, rect = $("plot").getBoundingClientRect();
  if (!g) return null;
  return g.tStart + (clientX - rect.left - g.left) / g.pw * g.spanS;
}

function readCursor(clientX) {
  const t = timeAtX(clientX);
  if (t === null || trace.t.length === 0) return;
  const [t0, t1] = visibleRange();
  if (t < t0 || t > t1) { clearCursor(); return; }
  const i = nearestSample(t);
  const c = cartlab.cursor = { i, t: trace.t[i], p1: trace.p1[i], p2: trace.p2[i], clientX, tPointer: t };
  const shown = view.absolute ? `t ${c.t.toFixed(3)} s` : `t ${c.t.toFixed(3)} s (${(c.t - t1).toFixed(3)} s)`;
  $("cursor").textContent = `${shown} · cart 1 ${fmt(c.p1, 5)} m · cart 2 ${fmt(c.p2, 5)} m`;
  $("cursor").classList.add("on");
  redraw();
}

function clearCursor() {
  if (!cartlab.cursor) return;
  cartlab.cursor = null; $("cursor").classList.remove("on"); redraw();
  $("cursor").textContent = "move over the plot to read a sample; drag to zoom on a stretch";
}

function plotEvents() {
  const canvas = $("plot");
  canvas.addEventListener("mousedown", (e) => {
    const rect = canvas.getBoundingClientRect();
    view.drag = { x0: e.clientX - rect.left, x1: e.clientX - rect.left, t0: timeAtX(e.clientX) };
  });
  canvas.addEventListener("mousemove", (e) => {
    if (view.drag) { view.drag.x1 = e.clientX - canvas.getBoundingClientRect().left; redraw(); }
    readCursor(e.clientX);
  });
  canvas.addEventListener("mouseup", (e) => {
    const drag = view.drag; view.drag = null;
    if (!drag) return;
    const t1 = timeAtX(e.clientX);
    if (Math.abs(e.clientX - canvas.getBoundingClientRect().left - drag.x0) > 6 && drag.t0 !== null && t1 !== null) {
      if (!view.paused) setPaused(true);
      view.zoom = [Math.min(drag.t0, t1), Math.max(drag.t0, t1)];
      $("zoom-reset").hidden = false;
    }
    redraw();
  });
  canvas.addEventListener("mouseleave", () => { view.drag = null; clearCursor(); });
  canvas.addEventListener("dblclick", () => { view.zoom = null; $("zoom-reset").hidden = true; redraw(); });
  $("pause-btn").addEventListener("click", () => setPaused(!view.paused));
  $("zoom-reset").addEventListener("click", () => { view.zoom = null; $("zoom-reset").hidden = true; redraw(); });
  $("abs-time").addEventListener("change", (e) => { view.absolute = e.target.checked; redraw(); });
}

// ---- state, status, problems -------------------------------------------------------
function showState(msg) {
  cartlab.state = msg ? msg.state : null;
  if (msg && cartlab.stateHistory[cartlab.stateHistory.length - 1] !== msg.state) cartlab.stateHistory.push(msg.state);
  cartlab.stateMsg = msg;
  addMark(msg);
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
  if (row.fit_shown === false) return [el("td", "aborted run: not fitted" + (row.reason ? ` (${row.reason})` : ""), "fit-failed")];
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
  const headline = d && d.cause;        // null: nothing material (never an immaterial effect)
  const cause = el("td", d ? (headline || "none material") : "—", d && !headline ? "fit-wait" : undefined);
  if (d) cause.title = [d.explanation, ...(d.effects || []).map((e) =>
    `${e.effect}: +${fmt(e.gain_points, 2)} pts${e.material ? "" : " (immaterial)"}`)].join("\n");
  const gain = el("td", headline ? (d.gain_points >= 0 ? "+" : "") + fmt(d.gain_points, 2) + " pts" : "—", "num");
  if (headline) gain.title = `fit ${fmt(d.baseline_fit_percent, 2)} % → ${fmt(d.extended_fit_percent, 2)} % with ${d.cause}`;
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
    const tr = el("tr", null, row.run_id === cartlab.openRun ? "selected" : undefined); tr.dataset.run = row.run_id;
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
    if (names.has("report.json")) { files.append(link(`/files/${enc}/fit/report.json`, "report")); names.delete("report.json"); }
    if (names.size > 0) {             // the fit folder's other files, folded: raw names never widen the table
      const more = el("details"), list = el("div", null, "more-files");
      more.append(el("summary", `${names.size} file${names.size > 1 ? "s" : ""}`), list);
      for (const n of [...names].sort()) list.append(link(`/files/${enc}/fit/${encodeURIComponent(n)}`, n));
      files.append(more);
    }
    tr.append(files);
    const heads = [...document.querySelectorAll(".runs thead th")].map((th) => th.textContent);
    let col = 0;                      // each cell labelled by its column (phone layout)
    for (const td of tr.cells) { td.dataset.label = td.colSpan > 1 ? "fit" : heads[col] || ""; col += td.colSpan; }
    return tr;
  }));
}

// ---- the run view: one run's models, effects, transfer functions and files ------------
function poly(c) {                     // coefficients, highest power of s first
  const n = c.length - 1;
  return c.map((a, i) => { const p = n - i; return `${Number(a).toPrecision(5)}${p > 1 ? " s^" + p : p === 1 ? " s" : ""}`; }).join(" + ");
}

function showRun(runId) {
  cartlab.openRun = runId;
  const row = cartlab.runs[runId], box = $("run-view");
  if (!row) { box.hidden = true; return; }
  for (const tr of document.querySelectorAll("#runs-body tr[data-run]")) tr.classList.toggle("selected", tr.dataset.run === runId);
  box.hidden = false;
  const f = row.fit && row.fit.status === "ok" && row.fit_shown !== false ? row.fit : null;
  $("rv-title").textContent = `Run ${row.run_id} · ${row.status || "—"}` + (row.reason ? ` (${row.reason})` : "")
    + (row.fit && !f ? ` · ${row.fit_shown === false ? "not fitted" : row.fit.status + (row.fit.reason ? ": " + row.fit.reason : "")}` : "");
  const models = [];
  if (f) {
    for (const s of f.simple) models.push([s.method === "rk4" ? "physical, RK4" : "physical, " + s.method, s.output, s.fit_percent, s.wn_rad_s, s.zeta]);
    if (f.pem) f.pem.outputs.forEach((o, i) => models.push([`PEM order ${f.pem.order}`, o, f.pem.fit_percent[i],
      f.pem.wn_rad_s[Math.min(i, f.pem.wn_rad_s.length - 1)], f.pem.zeta[Math.min(i, f.pem.zeta.length - 1)]]));
    const d = f.diagnosis;
    if (d) models.push(["extended (linear + " + ((d.effects || []).map((e) => e.effect).join(" + ") || d.cause || "nothing") + ")", "all", d.extended_fit_percent, null, null]);
  }
  $("rv-models").replaceChildren(...models.map((m) => {
    const tr = el("tr"); tr.append(el("td", m[0]), el("td", String(m[1])), el("td", fmt(m[2], 2), "num"),
      el("td", fmt(m[3], 3), "num"), el("td", fmt(m[4], 4), "num")); return tr;
  }));
  const d = f && f.diagnosis;
  const effects = d ? (d.effects && d.effects.length ? d.effects : d.cause ? [{ effect: d.cause, gain_points: d.gain_points, material: true }] : []) : [];
  $("rv-effects").replaceChildren(...(effects.length ? effects.map((e) => el("li", `${e.effect}: +${fmt(e.gain_points, 2)} fit-% points${e.material ? "" : " (immaterial)"}`))
    : [el("li", f ? (d ? "none: the linear model explains the run" : "no diagnosis") : "—")]));
  const tfs = f ? [...f.simple.map((s) => [`${s.method} cart ${s.output}`, s.tf]), ...(f.pem ? f.pem.tfs.map((t) => [`PEM cart ${t.output}`, t]) : [])] : [];
  $("rv-tfs").replaceChildren(...tfs.map(([name, tf]) => el("li", `${name}: G(s) = (${poly(tf.num)}) / (${poly(tf.den)})`)));
  const files = $("rv-files"); files.replaceChildren();
  const enc = encodeURIComponent(row.run_id);
  if (row.file) files.append(link(`/files/${enc}/mcap?bench=${encodeURIComponent(row.bench)}`, "MCAP"));
  const names = new Set(row.fit_files || []);
  if (row.fit && row.fit.figures) for (const n of row.fit.figures) names.add(n);
  const label = (n) => n === "report.json" ? "report (JSON)" : n.endsWith(".ipynb") ? "notebook" : n.endsWith(".csv") ? "CSV"
    : n.endsWith(".mat") ? "MAT" : n.endsWith(".html") ? "report (HTML)" : n;
  for (const n of [...names].sort()) if (!n.endsWith(".png")) files.append(link(`/files/${enc}/fit/${encodeURIComponent(n)}`, label(n)));
  $("rv-figures").replaceChildren(...[...names].filter((n) => n.endsWith(".png")).sort().map((n) => {
    const img = el("img"); img.src = `/files/${enc}/fit/${encodeURIComponent(n)}`; img.alt = n; img.loading = "lazy"; return img;
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
  clearTrace(); cartlab.runs = {}; cartlab.openRun = null; $("run-view").hidden = true; renderRuns();
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
    marks.length = 0; for (const m of d.states || []) addMark(m);
    showBenches(d.benches); showState(d.state); showStatus(d.status); loadHistory(d.history);
    cartlab.runs = {}; for (const r of d.runs) cartlab.runs[r.run_id] = r; renderRuns();
  });
  on("samples", appendSamples);
  on("state", showState);
  on("status", showStatus);
  on("benches", (d) => { showBenches(d.benches); if (!cartlab.bench && d.benches.some((b) => b.alive)) connect(null); });
  on("run", (r) => { cartlab.runs[r.run_id] = r; renderRuns(); if (cartlab.openRun === r.run_id) showRun(r.run_id); });
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
$("runs-body").addEventListener("click", (e) => {
  const tr = e.target.closest("tr[data-run]");
  if (tr && !e.target.closest("a, summary")) showRun(tr.dataset.run);
});
$("rv-close").addEventListener("click", () => { cartlab.openRun = null; $("run-view").hidden = true; renderRuns(); });
$("arm-btn").addEventListener("click", () => act("arm"));
$("bench-select").addEventListener("change", (e) => connect(e.target.value));
$("window-select").addEventListener("change", () => { redraw(); });
window.addEventListener("resize", () => redraw());
const fromHash = new URLSearchParams(location.hash.slice(1)).get("bench");
connect(fromHash);
plotEvents();
rateMeter();
redraw();
