// racer viewer: polls the JSON endpoints and draws with Chart.js (vendored, no build step).
"use strict";

const LIVE_POLL_MS = 500;
const PROGRESS_POLL_MS = 3000;
const HIDDEN_POLL_MS = 5000; // a hidden tab asks for no frames and polls rarely; it catches up when shown again
const WORLD_COLOURS = { base: "#60a5fa", carpet: "#f87171", concrete: "#cbd5e1", wood: "#f59e0b" };
const EXTRA_COLOURS = ["#a78bfa", "#34d399", "#f472b6", "#22d3ee"];
const ALL_COLOUR = "#f8fafc";
const OVERLAY_COLOURS = ["#e879f9", "#2dd4bf", "#fb923c", "#a3e635", "#38bdf8", "#fda4af"];
const RUNS_POLL_MS = 15000; // the server lists the store at most every 15 s

Chart.defaults.color = "#8ea0bd";
Chart.defaults.borderColor = "#1e2b47";
Chart.defaults.font.family = "system-ui, sans-serif";
Chart.defaults.animation = false; // redraw only what changed, cheaply: the rollout shares the CPU

const state = { run: null, live: null, progress: null, progressETag: null, progressSignature: null, workers: new Map(), charts: {},
                pids: new Map(), onScreen: new Set(), runs: [], overlays: new Map() };
window.racerViewer = state; // read by the browser tests

function $(id) { return document.getElementById(id); }
function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === "class") node.className = v; else if (k === "text") node.textContent = v; else node.setAttribute(k, v);
  }
  for (const child of children) node.append(child);
  return node;
}
// DOM writes only when the value changes: an unchanged page costs the browser no style, layout or paint work.
function setText(node, text) { if (node.textContent !== text) node.textContent = text; }
function setHTML(node, html) { if (node.shownHTML !== html) { node.shownHTML = html; node.innerHTML = html; } }
function setHidden(node, hidden) { if (node.hidden !== hidden) node.hidden = hidden; }

// Frames are asked for only for the worker panels on screen (scrolled away: the worker publishes nothing).
const panelObserver = new IntersectionObserver(entries => {
  for (const entry of entries) {
    const id = Number(entry.target.dataset.worker);
    if (entry.isIntersecting) state.onScreen.add(id); else state.onScreen.delete(id);
  }
});

function fmt(value, digits = 1, unit = "") {
  return value === null || value === undefined || Number.isNaN(value) ? "–" : `${Number(value).toFixed(digits)}${unit}`;
}
function worldColour(world, index) {
  return WORLD_COLOURS[world] || EXTRA_COLOURS[index % EXTRA_COLOURS.length];
}
async function getJSON(url) {
  const response = await fetch(url, { cache: "no-store" });
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.json();
}

// ---- track maps (Chart.js scatter charts with lines, equal scale on both axes) ----------------------------
function trackBounds(track) {
  const xs = track.outer.map(p => p[0]).concat(track.inner.map(p => p[0]));
  const ys = track.outer.map(p => p[1]).concat(track.inner.map(p => p[1]));
  const pad = 0.3;
  return { minX: Math.min(...xs) - pad, maxX: Math.max(...xs) + pad, minY: Math.min(...ys) - pad, maxY: Math.max(...ys) + pad };
}
function xy(points) { return points.map(p => ({ x: p[0], y: p[1] })); }

function trackChart(canvas, track, extraDatasets, fixedAspect) {
  const b = trackBounds(track);
  const line = (data, colour, width, dash) => ({
    data: xy(data), showLine: true, borderColor: colour, borderWidth: width, pointRadius: 0, borderDash: dash || [],
    fill: false, order: 10,
  });
  return new Chart(canvas, {
    type: "scatter",
    data: { datasets: [line(track.outer, "#94a3b8", 2), line(track.inner, "#94a3b8", 2),
                        line(track.center, "#475569", 1, [6, 6]), ...extraDatasets] },
    options: {
      responsive: true,
      maintainAspectRatio: true,
      aspectRatio: fixedAspect ? fixedAspect : (b.maxX - b.minX) / (b.maxY - b.minY),
      plugins: { legend: { display: false }, tooltip: { enabled: false } },
      scales: {
        x: { type: "linear", min: b.minX, max: b.maxX, display: false },
        y: { type: "linear", min: b.minY, max: b.maxY, display: false },
      },
      layout: { padding: 4 },
    },
  });
}

function fitEqualScale(chart, track) {
  // The top views have a fixed 4:3 box: widen one axis so a metre is as long in x as in y.
  const b = trackBounds(track);
  const w = b.maxX - b.minX, h = b.maxY - b.minY, box = 4 / 3;
  if (w / h > box) {
    const extra = (w / box - h) / 2; chart.options.scales.y.min = b.minY - extra; chart.options.scales.y.max = b.maxY + extra;
  } else {
    const extra = (h * box - w) / 2; chart.options.scales.x.min = b.minX - extra; chart.options.scales.x.max = b.maxX + extra;
  }
}

// ---- workers ----------------------------------------------------------------------------------------------
function workerCard(worker, index) {
  const img = el("img", { alt: `worker ${worker.id} camera` });
  img.hidden = true;
  const overlay = el("div", { class: "overlay", text: "waiting for the first frame…" });
  const tag = el("span", { class: "tag", text: "in-car" });
  const canvas = el("canvas");
  const topOverlay = el("div", { class: "overlay", text: "no track map" });
  const pill = el("span", { class: "pill", text: "…" });
  const restart = el("span", { class: "restart" });
  const stats = el("div", { class: "worker-stats", text: "–" });
  const world = el("span", { class: "world", text: worker.world });
  world.style.setProperty("--world", worldColour(worker.world, index));
  const card = el("div", { class: "worker unknown", "data-worker": String(worker.id), "data-up": "unknown" },
    el("div", { class: "worker-head" }, el("span", { class: "name", text: `worker ${worker.id}` }), world, restart, pill),
    el("div", { class: "views" }, el("div", { class: "incar" }, img, overlay, tag), el("div", { class: "topview" }, canvas, topOverlay)),
    stats);
  const view = { card, img, overlay, tag, canvas, topOverlay, pill, restart, stats, chart: null, frameId: null };
  if (state.run && state.run.track && state.run.track.outer) {
    topOverlay.hidden = true;
    view.chart = trackChart(canvas, state.run.track, [
      { data: [], showLine: true, borderColor: "rgba(245, 158, 11, 0.75)", borderWidth: 2, pointRadius: 0, order: 2 },
      { data: [], pointStyle: "triangle", pointRadius: 9, backgroundColor: "#f59e0b", borderColor: "#0f172a",
        borderWidth: 1.5, rotation: 0, order: 1 },
    ], 4 / 3);
    fitEqualScale(view.chart, state.run.track);
  }
  return view;
}

function ensureWorkers(list) {
  const container = $("workers");
  list.forEach((worker, index) => {
    if (!state.workers.has(worker.id)) {
      const view = workerCard(worker, index);
      state.workers.set(worker.id, view);
      container.append(view.card);
      panelObserver.observe(view.card);
    }
  });
}

function showFrame(view, frame) {
  if (!frame || frame.id === view.frameId) return; // nothing new: draw nothing (the page shares the CPU)
  view.frameId = frame.id;
  if (frame.has_image) {
    const url = frame.jpeg_base64 ? `data:image/jpeg;base64,${frame.jpeg_base64}` // came with the poll
      : `/api/workers/${view.card.dataset.worker}/frame.jpg?f=${encodeURIComponent(frame.id)}`;
    const next = new Image();
    next.onload = () => {
      view.img.src = next.src;
      view.img.hidden = false;
      view.img.dataset.frameId = frame.id;
      if (!view.card.classList.contains("down")) view.overlay.hidden = true;
    };
    next.src = url;
  }
  setText(view.tag, frame.phase === "evaluation" ? "in-car · evaluation" : "in-car");
  if (view.chart) {
    view.chart.data.datasets[3].data = xy(frame.trail);
    view.chart.data.datasets[4].data = [{ x: frame.x_m, y: frame.y_m }];
    view.chart.data.datasets[4].rotation = 90 - frame.heading_deg; // triangle points up at 0; headings are CCW from +x
    view.chart.update("none");
  }
}

function updateWorkers(live) {
  ensureWorkers(live.workers);
  for (const worker of live.workers) {
    const view = state.workers.get(worker.id);
    const up = worker.up && live.redis.ok;
    view.card.classList.toggle("down", !up && live.redis.ok);
    view.card.classList.toggle("unknown", !live.redis.ok);
    const upText = live.redis.ok ? String(up) : "unknown";
    if (view.card.dataset.up !== upText) view.card.dataset.up = upText;
    const finished = state.progress && state.progress.finished;
    if (!live.redis.ok) {
      setText(view.pill, "unknown");
    } else if (!up && finished) {
      view.card.classList.remove("down"); // training is over: workers exit, nothing is wrong
      setText(view.pill, "finished");
      setHidden(view.overlay, !view.img.hidden);
    } else if (up) {
      setText(view.pill, worker.state || "up");
      setText(view.overlay, "waiting for the first frame…");
      setHidden(view.overlay, !view.img.hidden);
    } else {
      setText(view.pill, "DOWN");
      setHidden(view.overlay, false);
      setText(view.overlay, worker.heartbeat_age_s === null
        ? "DOWN · no heartbeat" : `DOWN · last heartbeat ${Math.round(worker.heartbeat_age_s)} s ago`);
    }
    if (worker.pid) {
      const known = state.pids.get(worker.id);
      if (known && known.pid !== worker.pid) state.pids.set(worker.id, { pid: worker.pid, restartedAt: new Date() });
      else if (!known) state.pids.set(worker.id, { pid: worker.pid, restartedAt: null });
      const restartedAt = state.pids.get(worker.id).restartedAt;
      setText(view.restart, restartedAt ? `restarted ${restartedAt.toLocaleTimeString()}` : "");
    }
    const f = worker.frame;
    const parts = [];
    if (f) parts.push(`step <b>${f.step}</b>`, `progress <b>${fmt(f.progress, 0, "%")}</b>`, `reward <b>${fmt(f.episode_reward, 1)}</b>`);
    if (worker.steps_per_s) parts.push(`<b>${fmt(worker.steps_per_s, 0)}</b> steps/s`);
    if (worker.iteration !== null && worker.iteration !== undefined && worker.iteration >= 0) parts.push(`iteration <b>${worker.iteration}</b>`);
    setHTML(view.stats, parts.length ? parts.join(" · ") : (up ? "no frame yet" : "–"));
    if (up) showFrame(view, f);
  }
}

// ---- curves -----------------------------------------------------------------------------------------------
function lineChart(canvas, yTitle, yMax) {
  return new Chart(canvas, {
    type: "line",
    data: { labels: [], datasets: [] },
    options: {
      responsive: true,
      maintainAspectRatio: false,
      interaction: { mode: "index", intersect: false },
      plugins: { legend: { position: "bottom", labels: { boxWidth: 12, boxHeight: 2 } } },
      scales: {
        x: { title: { display: true, text: "iteration" }, ticks: { maxTicksLimit: 12 } },
        y: { title: { display: false, text: yTitle }, beginAtZero: true, suggestedMax: yMax },
      },
      elements: { point: { radius: 2 }, line: { tension: 0.25, borderWidth: 2 } },
    },
  });
}

function series(label, colour, values, extra = {}) {
  return { label, data: values, borderColor: colour, backgroundColor: colour, spanGaps: true, ...extra };
}

function updateCurves(progress) {
  const own = progress.iterations;
  const numbers = new Set(own.map(r => r.iteration));
  for (const o of state.overlays.values()) for (const r of o.iterations || []) numbers.add(r.iteration);
  const labels = [...numbers].sort((a, b) => a - b);
  const ownByIteration = new Map(own.map(r => [r.iteration, r]));
  const its = labels.map(n => ownByIteration.get(n) || { iteration: n, missing: true, worlds: {} });
  // Another run's curves over this one's: dashed, one colour per run, on the same iteration axis.
  const overlaid = (key, scale = 1) => [...state.overlays.entries()].filter(([, o]) => o.iterations).map(([name, o]) => {
    const byIteration = new Map(o.iterations.map(r => [r.iteration, r]));
    return series(name, o.colour, labels.map(n => { const r = byIteration.get(n);
      return r && r[key] !== null && r[key] !== undefined ? r[key] * scale : null; }),
      { borderDash: [6, 4], borderWidth: 2, pointRadius: 0 });
  });
  const value = (r, key, scale = 1) => (r.missing || r[key] === null || r[key] === undefined) ? null : r[key] * scale;
  const worlds = [...new Set(its.flatMap(r => Object.keys(r.worlds || {})))].sort();
  const perWorld = (key, scale = 1) => worlds.map((w, i) => series(w, worldColour(w, i),
    its.map(r => (r.worlds && r.worlds[w] && r.worlds[w][key] !== undefined) ? r.worlds[w][key] * scale : null),
    { borderWidth: 1.5, pointRadius: 1.5 }));
  const all = (label, values) => series(state.overlays.size ? `${state.run ? state.run.model : "this run"} (all workers)` : label,
    ALL_COLOUR, values, { borderWidth: 2.5 });
  const evalByIteration = new Map(progress.evaluations.map(e => [e.checkpoint_number, e]));
  const evalProgress = its.map(r => { const e = evalByIteration.get(r.iteration); return e ? e.mean_progress : null; });
  const evalLaps = its.map(r => { const e = evalByIteration.get(r.iteration); return e ? 100 * e.laps_completed / e.trials : null; });
  const evalStyle = { borderDash: [5, 4], borderWidth: 2, pointStyle: "rectRot", pointRadius: 4 };
  const sets = {
    reward: [all("all workers", its.map(r => value(r, "mean_reward"))), ...perWorld("mean_reward"), ...overlaid("mean_reward")],
    progress: [all("all workers", its.map(r => value(r, "mean_progress"))), ...perWorld("mean_progress"),
               series("evaluation", "#f59e0b", evalProgress, evalStyle), ...overlaid("mean_progress")],
    completion: [all("all workers", its.map(r => value(r, "completion_rate", 100))), ...perWorld("completion_rate", 100),
                 series("evaluation", "#f59e0b", evalLaps, evalStyle), ...overlaid("completion_rate", 100)],
    speed: [all("all workers", its.map(r => value(r, "experience_steps_per_s"))), ...perWorld("steps_per_s")],
  };
  for (const [name, datasets] of Object.entries(sets)) {
    const chart = state.charts[name];
    chart.data.labels = labels;
    chart.data.datasets = datasets;
    chart.update("none");
  }
  const speedKnown = own.some(r => r.experience_steps_per_s !== null && r.experience_steps_per_s !== undefined);
  $("chart-speed").closest("figure").hidden = own.length > 0 && !speedKnown; // runs racer did not train lack it
  $("curves").dataset.points = String(own.length);
  $("curves").dataset.overlays = [...state.overlays.keys()].filter(n => state.overlays.get(n).iterations).sort().join(",");
  updateSummary();
  $("curves-note").textContent = own.length ? `per iteration (${own.length})` : "per iteration: none finished yet";
}

// ---- how far the run is: the trainer's figures of its newest iteration (racer.shared.run_progress) ---------
function clock(seconds) {
  const whole = Math.max(0, Math.floor(seconds));
  const h = Math.floor(whole / 3600), m = Math.floor((whole % 3600) / 60), s = whole % 60;
  return h ? `${h}:${String(m).padStart(2, "0")}:${String(s).padStart(2, "0")}` : `${m}:${String(s).padStart(2, "0")}`;
}
// Between iterations the figures count on from the measurement, as `racer train`'s status line does (RunProgress.at).
function progressText(p, finished) {
  const passed = finished ? 0 : Math.max(0, Date.now() / 1000 - p.measured_at);
  const elapsed = p.elapsed_s + passed, remaining = Math.max(0, p.remaining_s - passed);
  const used = p.stops_by === "time" && p.max_minutes ? `${clock(elapsed)} of ${clock(60 * p.max_minutes)}`
    : `${p.episodes}/${p.max_episodes} episodes`;
  if (finished) return used;
  return remaining >= 1 ? `${used} · about ${clock(remaining)} left` : `${used} · stopping`;
}
function updateSummary() {
  const its = state.progress ? state.progress.iterations : [];
  const last = its[its.length - 1];
  if (!last) return;
  const parts = [`iteration ${last.iteration}`];
  if (last.env_steps_total !== null && last.env_steps_total !== undefined) parts.push(`${last.env_steps_total.toLocaleString()} steps`);
  let eta = "";
  if (last.progress) {
    eta = progressText(last.progress, state.progress.finished);
  } else if (last.elapsed_s !== null && last.elapsed_s !== undefined) {
    parts.push(`${clock(last.elapsed_s)} trained`);
  }
  setHTML($("summary"), parts.join(" · ") + (eta ? ` · <span class="eta" id="eta">${eta}</span>` : ""));
}
setInterval(() => { if (!document.hidden && state.progress && !state.progress.finished) updateSummary(); }, 1000);

// ---- the runs of the store, and overlays --------------------------------------------------------------------
function overlayColour(name) {
  const used = new Set([...state.overlays.values()].map(o => o.colour));
  return OVERLAY_COLOURS.find(c => !used.has(c)) || OVERLAY_COLOURS[state.overlays.size % OVERLAY_COLOURS.length];
}
async function loadOverlay(name) {
  const overlay = state.overlays.get(name);
  if (!overlay) return;
  try {
    const data = await getJSON(`/api/runs/curves?run=${encodeURIComponent(name)}`);
    if (state.overlays.get(name) !== overlay) return; // unticked meanwhile
    overlay.iterations = data.iterations;
    overlay.count = data.iterations.length;
  } catch (error) {
    setText($("footer"), `overlay ${name}: ${error.message}`);
    state.overlays.delete(name);
  }
  if (state.progress) updateCurves(state.progress);
  showRuns();
}
function toggleOverlay(name, on) {
  if (on && !state.overlays.has(name)) {
    state.overlays.set(name, { colour: overlayColour(name), iterations: null, count: -1 });
    loadOverlay(name);
  } else if (!on && state.overlays.delete(name)) {
    if (state.progress) updateCurves(state.progress);
    showRuns();
  }
}
function showRuns() {
  const body = $("runs").querySelector("tbody");
  const signature = JSON.stringify([state.runs, [...state.overlays.entries()].map(([n, o]) => [n, o.colour])]);
  if (body.dataset.signature === signature) return; // leave the checkboxes alone while nothing changed
  body.dataset.signature = signature;
  body.replaceChildren();
  if (!state.runs.length) {
    body.append(el("tr", { class: "empty" }, el("td", { colspan: "7", text: "No other run in this store." })));
    return;
  }
  for (const run of state.runs) {
    const overlay = state.overlays.get(run.name);
    const name = el("td", { class: "run-name", text: run.name });
    const box = el("td");
    if (run.current) {
      box.textContent = "shown";
    } else {
      const input = el("input", { type: "checkbox", "data-run": run.name, title: `lay ${run.name}'s curves over these` });
      input.checked = !!overlay;
      input.addEventListener("change", () => toggleOverlay(run.name, input.checked));
      box.append(input);
      if (overlay) {
        const swatch = el("span", { class: "swatch" });
        swatch.style.setProperty("--overlay", overlay.colour);
        box.append(swatch);
      }
    }
    const stateText = run.current ? (state.run && state.run.live && !run.finished ? "live" : (run.finished ? "finished" : "not finished"))
      : (run.finished ? "finished" : "not finished");
    const time = run.progress ? progressText(run.progress, true) : "–";
    body.append(el("tr", { class: run.current ? "current" : "", "data-run": run.name }, name, box,
      el("td", { text: stateText }), el("td", { text: String(run.iterations) }),
      el("td", { text: fmt(run.mean_reward, 1) }), el("td", { text: fmt(run.mean_progress, 1, " %") }),
      el("td", { text: time })));
  }
}

// ---- evaluations and the best lap -------------------------------------------------------------------------
function updateEvaluations(rows) {
  const body = $("evaluations").querySelector("tbody");
  body.replaceChildren();
  if (!rows.length) {
    body.append(el("tr", { class: "empty" }, el("td", { colspan: "5", text: "No evaluation yet." })));
    return;
  }
  for (const r of [...rows].reverse()) {
    body.append(el("tr", { class: r.is_best ? "best" : "" },
      el("td", { text: r.checkpoint }), el("td", { text: String(r.trials) }),
      el("td", { text: `${r.laps_completed}/${r.trials}` }), el("td", { text: fmt(r.mean_progress, 1, " %") }),
      el("td", { text: r.best_lap_time_s ? fmt(r.best_lap_time_s, 3, " s") : "–" })));
  }
}

function updateBestLap(best, bound) {
  const track = state.run && state.run.track;
  if (track && track.outer && !state.charts.bestLap) {
    state.charts.bestLap = trackChart($("chart-best-lap"), track, [
      { data: [], showLine: true, borderColor: "#f59e0b", borderWidth: 3, pointRadius: 0, order: 1 },
      { data: [], pointStyle: "circle", pointRadius: 6, backgroundColor: "#22c55e", order: 0 },
    ]);
  }
  if (!best) return;
  const where = best.phase === "evaluation" ? `evaluation ${best.run}` : `training iteration ${best.iteration}, worker ${best.worker}`;
  $("best-lap-caption").innerHTML = best.complete
    ? `<b>${fmt(best.lap_time_s, 3)} s</b> lap · ${where} · ${best.steps} steps` +
      (bound && bound.ratio ? ` · <b>${fmt(bound.ratio, 3)}</b> × the lap-time bound (${fmt(bound.line_lap_s, 3)} s flying lap, ${String(bound.line).replace(/[<>&]/g, c => `&#${c.charCodeAt(0)};`)})` : "")
    : `No complete lap in the simtraces yet. Furthest: <b>${fmt(best.progress, 1)} %</b> in ${fmt(best.time_s, 1)} s · ${where}`;
  $("best-lap-note").textContent = best.complete ? "fastest complete lap" : "furthest episode";
  const chart = state.charts.bestLap;
  if (chart) {
    chart.data.datasets[3].data = xy(best.path);
    chart.data.datasets[4].data = best.path.length ? [{ x: best.path[0][0], y: best.path[0][1] }] : [];
    chart.update("none");
  }
}

function updateEvaluationRuns(runs) {
  $("evaluation-runs-section").hidden = !runs.length;
  const container = $("evaluation-runs");
  const signature = JSON.stringify(runs);
  if (container.dataset.signature === signature) return; // keep playing videos untouched
  container.dataset.signature = signature;
  container.replaceChildren();
  for (const run of runs) {
    const rows = run.laps.map(l => el("tr", {}, el("td", { text: String(l.lap) }),
      el("td", { text: l.lap_time_s ? fmt(l.lap_time_s, 3, " s") : `(${fmt(l.elapsed_s, 3, " s")})` }),
      el("td", { text: fmt(l.progress_pct, 1, " %") }), el("td", { text: String(l.put_backs ?? "–") }),
      el("td", { text: l.label || "" })));
    const table = el("table", {}, el("thead", {}, el("tr", {}, ...["lap", "time", "progress", "resets", "status"].map(h => el("th", { text: h })))),
      el("tbody", {}, ...rows));
    const videos = el("div", { class: "videos" }, ...run.videos.map(v => el("div", {},
      el("video", { src: v.url, controls: "", preload: "metadata", muted: "" }), `camera-${v.view}`)));
    container.append(el("div", { class: "eval-run" },
      el("h3", { text: run.name }, el("small", { text: [run.mode, run.checkpoint,
        run.laps_completed !== null && run.laps_completed !== undefined ? `${run.laps_completed} laps completed` : null,
        run.best_lap_time_s ? `best ${fmt(run.best_lap_time_s, 3, " s")}` : null].filter(Boolean).join(" · ") })),
      table, videos));
  }
}

// ---- polling ----------------------------------------------------------------------------------------------
function setBanner(text) {
  setHidden($("banner"), !text);
  setText($("banner"), text || "");
}

// One timer per poll loop; a tab shown again polls at once instead of waiting out its hidden interval.
const polls = { live: { timer: null, busy: false, run: null }, progress: { timer: null, busy: false, run: null } };
function schedule(name, delayMs) {
  const poll = polls[name];
  clearTimeout(poll.timer);
  poll.timer = setTimeout(async () => {
    if (poll.busy) return;
    poll.busy = true;
    try { await poll.run(); } finally { poll.busy = false; }
  }, delayMs);
}
document.addEventListener("visibilitychange", () => {
  if (document.hidden) return;
  for (const name of Object.keys(polls)) if (polls[name].run && !polls[name].busy) schedule(name, 0);
});

async function pollLive() {
  try {
    const watched = document.hidden ? "watch=0" : `watch=1&workers=${[...state.onScreen].sort((a, b) => a - b).join(",")}`;
    const live = await getJSON(`/api/live?${watched}`);
    state.live = live;
    const badge = $("redis-badge");
    setHidden(badge, false);
    const badgeClass = `badge ${live.redis.ok ? "ok" : "bad"}`;
    if (badge.className !== badgeClass) badge.className = badgeClass;
    setText(badge, live.redis.ok ? "Redis ok" : "Redis unreachable");
    setBanner(live.redis.ok ? "" : `Redis is unreachable: workers' status and cameras are unknown; retrying. (${live.redis.error})`);
    updateWorkers(live);
  } catch (error) {
    setBanner(`The viewer server does not answer (${error.message}); retrying.`);
  }
  schedule("live", document.hidden ? HIDDEN_POLL_MS : LIVE_POLL_MS);
}
polls.live.run = pollLive;

async function pollProgress() {
  try {
    // the server answers 304 while the page has the newest version: nothing to parse or compare
    const response = await fetch("/api/progress", { cache: "no-store",
      headers: state.progressETag ? { "If-None-Match": state.progressETag } : {} });
    let progress = state.progress;
    if (response.status !== 304) {
      if (!response.ok) throw new Error(`/api/progress: HTTP ${response.status}`);
      progress = await response.json();
      state.progressETag = response.headers.get("ETag");
    }
    state.progress = progress;
    const signature = JSON.stringify([progress.iterations.length, progress.evaluations,
      progress.best_lap && [progress.best_lap.lap_time_s, progress.best_lap.progress, progress.best_lap.run,
                            progress.best_lap.iteration, progress.best_lap.episode], progress.best_lap_bound, !!(state.run && state.run.track && state.run.track.outer)]);
    if (signature !== state.progressSignature) { // redraw the charts only when something changed
      state.progressSignature = signature;
      updateCurves(progress);
      updateEvaluations(progress.evaluations);
      updateBestLap(progress.best_lap, progress.best_lap_bound);
    }
    updateEvaluationRuns(progress.evaluation_runs);
    if (progress.finished && $("mode-badge").className !== "badge done") {
      $("mode-badge").className = "badge done";
      $("mode-badge").textContent = "finished";
    }
    setText($("footer"), progress.note || "");
  } catch (error) {
    setText($("footer"), `progress: ${error.message}`);
  }
  schedule("progress", document.hidden ? HIDDEN_POLL_MS : PROGRESS_POLL_MS);
}
polls.progress.run = pollProgress;

async function pollRuns() {
  try {
    const data = await getJSON("/api/runs");
    state.runs = data.runs;
    for (const run of data.runs) { // a run still training: fetch its overlay again when it has more iterations
      const overlay = state.overlays.get(run.name);
      if (overlay && overlay.iterations && overlay.count !== run.iterations) loadOverlay(run.name);
    }
    showRuns();
  } catch (error) {
    setText($("footer"), `runs: ${error.message}`);
  }
  schedule("runs", document.hidden ? 4 * RUNS_POLL_MS : RUNS_POLL_MS);
}
polls.runs = { timer: null, busy: false, run: pollRuns };

async function loadRun() {
  const run = await getJSON("/api/run");
  const hadTrack = state.run && state.run.track && state.run.track.outer;
  state.run = run;
  $("model").textContent = run.model;
  document.title = `${run.model} · racer viewer`;
  $("mode-badge").className = `badge ${run.live ? "live" : "done"}`;
  $("mode-badge").textContent = run.live ? "live" : "from store";
  $("workers-section").hidden = !run.live;
  if (run.track && run.track.error) $("footer").textContent = run.track.error;
  if (!hadTrack && run.track && run.track.outer && state.workers.size) {
    // the params appeared after the cards were drawn: draw the cards again with the map
    for (const view of state.workers.values()) {
      if (view.chart) view.chart.destroy();
      panelObserver.unobserve(view.card);
      view.card.remove();
    }
    state.workers.clear();
    state.onScreen.clear();
  }
  if (run.live) ensureWorkers(run.workers);
  return run;
}

async function start() {
  state.charts.reward = lineChart($("chart-reward"), "reward");
  state.charts.progress = lineChart($("chart-progress"), "%", 100);
  state.charts.completion = lineChart($("chart-completion"), "%", 100);
  state.charts.speed = lineChart($("chart-speed"), "steps/s");
  let run = null;
  while (!run) {
    try { run = await loadRun(); } catch (error) { setBanner(`Cannot load the run (${error.message}); retrying.`); await new Promise(r => setTimeout(r, 2000)); }
  }
  setBanner("");
  if (run.live) {
    schedule("live", 0);
    // a training that just started has no params files yet: look again until the track map is known
    const retry = async () => { if (!(state.run.track && state.run.track.outer)) { try { await loadRun(); } catch (e) { /* next time */ } setTimeout(retry, 3000); } };
    setTimeout(retry, 3000);
  }
  schedule("progress", 0);
  schedule("runs", 0);
}

start();
