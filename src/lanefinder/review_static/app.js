// lanefinder review: the page.  Plain JavaScript (no build step); plots by plotly.js, served from
// the plotly Python package.  Routes: #/ (fleet), #/video/<id>[/<frame>].
"use strict";

const $ = (id) => document.getElementById(id);
const state = {
  info: null, videos: [], sortKey: "video", sortDir: 1,
  video: null, frame: 0, playing: false, changes: {}, src: null, inspectSeq: 0,
};

async function api(path, options) {
  const r = await fetch(path, options);
  const body = await r.json().catch(() => ({}));
  if (!r.ok) throw new Error(body.detail || `${r.status} ${r.statusText}`);
  return body;
}

function fmt(v, digits) {
  if (v === null || v === undefined) return "";
  return typeof v === "number" ? v.toFixed(digits === undefined ? 2 : digits) : String(v);
}

// -- fleet view ------------------------------------------------------------------------------
function renderFleet() {
  const rows = [...state.videos].sort((a, b) => {
    const x = a[state.sortKey], y = b[state.sortKey];
    if (x === y) return 0;
    if (x === null || x === undefined) return 1;
    if (y === null || y === undefined) return -1;
    return (x < y ? -1 : 1) * state.sortDir;
  });
  const tbody = document.querySelector("#fleet tbody");
  tbody.innerHTML = "";
  for (const v of rows) {
    const tr = document.createElement("tr");
    tr.dataset.video = v.video;
    if (v.status === "failed") tr.className = "failed";
    const cells = [v.video, v.status, fmt(v.frames, 0), fmt(v.duration_s, 1), fmt(v.pct_lane, 1),
      fmt(v.pct_lost, 1), fmt(v.pct_both_lines, 1), fmt(v.mean_width_m, 2), fmt(v.events, 0), v.error || ""];
    cells.forEach((c, i) => {
      const td = document.createElement("td");
      td.textContent = c;
      if (i >= 2 && i <= 8) td.className = "num";
      if (i === 9) td.className = "error";
      tr.appendChild(td);
    });
    tr.addEventListener("click", () => {
      if (v.status !== "failed") location.hash = `#/video/${encodeURIComponent(v.video)}`;
    });
    tbody.appendChild(tr);
  }
  document.querySelectorAll("#fleet th").forEach((th) => {
    th.classList.toggle("sorted-asc", th.dataset.key === state.sortKey && state.sortDir > 0);
    th.classList.toggle("sorted-desc", th.dataset.key === state.sortKey && state.sortDir < 0);
  });
  $("fleet-count").textContent = `(${rows.length})`;
}

document.querySelectorAll("#fleet th").forEach((th) => th.addEventListener("click", () => {
  state.sortDir = state.sortKey === th.dataset.key ? -state.sortDir : 1;
  state.sortKey = th.dataset.key;
  renderFleet();
}));

// -- video view ------------------------------------------------------------------------------
async function openVideo(id, frame) {
  if (!state.video || state.video.video !== id) {
    $("video-title").textContent = id;
    state.video = await api(`/api/videos/${encodeURIComponent(id)}`);
    state.rowOf = new Map(state.video.series.frame.map((f, i) => [f, i]));  // frame -> telemetry row
    state.src = null;
    $("slider").max = state.video.frames - 1;
    renderEvents();
    renderPlots();
  }
  seek(frame || 0);
}

function timeOf(frame) { return frame / state.video.fps; }

function seek(frame) {
  const v = state.video;
  frame = Math.max(0, Math.min(v.frames - 1, Math.round(frame)));
  state.frame = frame;
  $("slider").value = frame;
  if (v.source) $("frame").src = `/api/videos/${encodeURIComponent(v.video)}/frames/${frame}.jpg`;
  else $("frame").alt = "the source video is not readable here: the plots and events still are";
  $("frame-label").textContent = `frame ${frame} / ${v.frames - 1}, ${timeOf(frame).toFixed(2)} s`;
  $("run-label").textContent = runSays(frame);
  $("frame").dataset.frame = frame;
  if (window.Plotly && $("plots").data) {
    Plotly.relayout("plots", { "shapes[0].x0": timeOf(frame), "shapes[0].x1": timeOf(frame) });
  }
  if (!state.playing && v.source) scheduleInspect();
}

function renderEvents() {
  const ul = $("events");
  ul.innerHTML = "";
  const events = state.video.events;
  if (!events.length) {
    const li = document.createElement("li");
    li.textContent = "no events";
    ul.appendChild(li);
  }
  for (const e of events) {
    const li = document.createElement("li");
    li.className = e.kind === "lost" ? "lost" : "";
    li.dataset.frame = e.start_frame;
    const extra = e.ttlc_s !== null && e.ttlc_s !== undefined ? `, TTLC ${fmt(e.ttlc_s)} s` : "";
    li.textContent = `${fmt(e.start_s)}-${fmt(e.end_s)} s  ${e.kind}${extra}`;
    li.addEventListener("click", () => seek(e.start_frame));
    ul.appendChild(li);
  }
}

function renderPlots() {
  const s = state.video.series;
  const t = s.time_s;
  const traces = [
    { x: t, y: s.offset_m, name: "offset m", yaxis: "y" },
    { x: t, y: s.radius_m, name: "radius m", yaxis: "y2" },
    { x: t, y: s.width_m, name: "width m", yaxis: "y3" },
    { x: t, y: s.left_conf, name: "left conf", yaxis: "y4" },
    { x: t, y: s.right_conf, name: "right conf", yaxis: "y4" },
  ].map((tr) => ({ ...tr, type: "scattergl", mode: "lines", line: { width: 1.5 } }));
  const layout = {
    margin: { l: 60, r: 10, t: 10, b: 30 }, showlegend: true, legend: { orientation: "h" },
    grid: { rows: 4, columns: 1, subplots: [["xy"], ["xy2"], ["xy3"], ["xy4"]], roworder: "top to bottom" },
    xaxis: { title: { text: "time s" } },
    yaxis: { title: { text: "offset m" } }, yaxis2: { title: { text: "radius m" }, type: "log" },
    yaxis3: { title: { text: "width m" } }, yaxis4: { title: { text: "confidence" }, range: [0, 1.05] },
    shapes: [{ type: "line", xref: "x", yref: "paper", x0: 0, x1: 0, y0: 0, y1: 1,
      line: { color: "#d00", width: 2 } }],
  };
  Plotly.newPlot("plots", traces, layout, { displayModeBar: false, responsive: true });
}

// A click anywhere on the plot area seeks to that time (set once: the plot is redrawn per video).
$("plots").addEventListener("click", (ev) => {
  const xa = $("plots")._fullLayout && $("plots")._fullLayout.xaxis;
  if (!xa || !state.video) return;
  const box = $("plots").getBoundingClientRect();
  const px = ev.clientX - box.left - xa._offset;
  if (px < 0 || px > xa._length) return;
  seek(Math.round(xa.p2l(px) * state.video.fps));
});

$("slider").addEventListener("input", () => seek(Number($("slider").value)));
$("back").addEventListener("click", () => seek(state.frame - 1));
$("fwd").addEventListener("click", () => seek(state.frame + 1));
$("play").addEventListener("click", () => setPlaying(!state.playing));
document.addEventListener("keydown", (ev) => {
  if (!state.video || $("video-view").hidden || ev.target.tagName === "INPUT") return;
  if (ev.key === "ArrowRight") seek(state.frame + 1);
  else if (ev.key === "ArrowLeft") seek(state.frame - 1);
  else if (ev.key === " ") { setPlaying(!state.playing); ev.preventDefault(); }
});

function setPlaying(on) {
  state.playing = on;
  $("play").innerHTML = on ? "&#10074;&#10074;" : "&#9654;";
  if (on) playNext(); else scheduleInspect();
}

function playNext() {
  if (!state.playing) return;
  if (state.frame >= state.video.frames - 1) { setPlaying(false); return; }
  const started = performance.now();
  const img = $("frame");
  const loaded = () => {
    img.removeEventListener("error", failed);
    const wait = Math.max(0, 1000 / state.video.fps - (performance.now() - started));
    setTimeout(playNext, wait);
  };
  const failed = () => {
    img.removeEventListener("load", loaded);
    setPlaying(false);
    setStatus(`frame ${state.frame} could not be shown`, true);
  };
  img.addEventListener("load", loaded, { once: true });
  img.addEventListener("error", failed, { once: true });
  seek(state.frame + 1);
}

// -- inspector ------------------------------------------------------------------------------
function buildForm() {
  const form = $("form");
  form.innerHTML = "";
  let fieldset = null, section = null;
  for (const f of state.info.form) {
    const sec = f.key.split(".")[0];
    if (sec !== section) {
      section = sec;
      fieldset = document.createElement("fieldset");
      const legend = document.createElement("legend");
      legend.textContent = sec;
      fieldset.appendChild(legend);
      form.appendChild(fieldset);
    }
    const label = document.createElement("label");
    label.title = f.help || f.key;
    const name = document.createElement("span");
    name.textContent = f.key.split(".").slice(1).join(".");
    let input;
    if (f.type === "choice") {
      input = document.createElement("select");
      for (const c of f.choices) {
        const o = document.createElement("option");
        o.value = c; o.textContent = c; o.selected = c === f.value;
        input.appendChild(o);
      }
    } else {
      input = document.createElement("input");
      if (f.type === "boolean") { input.type = "checkbox"; input.checked = f.value; }
      else {
        input.type = "number";
        input.value = f.value;
        input.step = f.type === "integer" ? "1" : "any";
        if (f.min !== null) input.min = f.min;
        if (f.max !== null) input.max = f.max;
      }
    }
    input.name = f.key;
    input.dataset.type = f.type;
    input.addEventListener("change", () => {
      const t = input.dataset.type;
      // a choice goes back as the choice itself (a kernel size is a number, not its text)
      state.changes[f.key] = t === "boolean" ? input.checked
        : t === "choice" ? (f.choices.find((c) => String(c) === input.value) ?? input.value) : Number(input.value);
      inspect();
    });
    label.appendChild(name);
    label.appendChild(input);
    fieldset.appendChild(label);
  }
}

let inspectTimer = null;
function scheduleInspect() {
  clearTimeout(inspectTimer);
  inspectTimer = setTimeout(inspect, 150);
}

// What the tracked run said at a frame: its state and the checks that refused something there.
function runSays(frame) {
  const s = state.video.series, i = state.rowOf.get(frame);
  if (i === undefined) return "the run: no telemetry row";
  const checks = s.checks[i];  // null: telemetry written before the checks column
  const why = checks === null ? "; checks not recorded" : checks ? `; checks: ${checks.split(",").join(", ")}` : "";
  return `the run: ${s.state[i]}${why}`;
}

function body() {
  return JSON.stringify({ config: state.changes, src: state.src, reference_size: state.src ? state.srcSize : null,
    video: state.video ? state.video.video : null });
}

async function inspect() {
  if (!state.video) return;
  const seq = ++state.inspectSeq;
  const t0 = performance.now();
  try {
    const r = await api(`/api/videos/${encodeURIComponent(state.video.video)}/frames/${state.frame}/inspect`,
      { method: "POST", headers: { "Content-Type": "application/json" }, body: body() });
    if (seq !== state.inspectSeq) return;  // a newer request is on its way
    for (const [name, data] of Object.entries(r.images)) {
      const img = $(`stage-${name}`);
      if (img) img.src = data;
    }
    const res = r.result;
    $("result").textContent = `${res.state}: offset ${fmt(res.offset_m)} m, width ${fmt(res.width_m)} m, ` +
      `radius ${fmt(res.radius_m, 0)} m, confidence ${fmt(res.left_conf)} / ${fmt(res.right_conf)}` +
      (res.checks.length ? `; checks: ${res.checks.join(", ")}` : "");
    setStatus(`frame ${state.frame} re-rendered in ${r.ms} ms on the server ` +
      `(${Math.round(performance.now() - t0)} ms with the page)`);
    $("status").dataset.ms = r.ms;
    $("status").dataset.seq = seq;
    drawTrapezoid(r.src, r.reference_size);
  } catch (err) {
    if (seq === state.inspectSeq) setStatus(err.message, true);
  }
}

function setStatus(text, error) {
  $("status").textContent = text;
  $("status").className = error ? "error" : "";
}

function drawTrapezoid(src, size) {
  const svg = $("trapezoid");
  if (svg.dataset.dragging === "1") return;
  svg.setAttribute("viewBox", `0 0 ${size[0]} ${size[1]}`);
  svg.innerHTML = "";
  const ns = "http://www.w3.org/2000/svg";
  const poly = document.createElementNS(ns, "polygon");
  poly.setAttribute("points", src.map((p) => p.join(",")).join(" "));
  svg.appendChild(poly);
  src.forEach((p, i) => {
    const c = document.createElementNS(ns, "circle");
    c.setAttribute("cx", p[0]); c.setAttribute("cy", p[1]); c.setAttribute("r", 10);
    c.dataset.index = i;
    c.id = `corner-${i}`;
    c.addEventListener("pointerdown", (ev) => startDrag(ev, c, src.map((q) => [...q]), size));
    svg.appendChild(c);
  });
}

function startDrag(ev, circle, pts, size) {
  const svg = $("trapezoid");
  svg.dataset.dragging = "1";
  circle.setPointerCapture(ev.pointerId);
  const i = Number(circle.dataset.index);
  const toSvg = (e) => {
    const p = svg.createSVGPoint();
    p.x = e.clientX; p.y = e.clientY;
    return p.matrixTransform(svg.getScreenCTM().inverse());
  };
  const move = (e) => {
    const p = toSvg(e);
    pts[i] = [Math.round(p.x * 10) / 10, Math.round(p.y * 10) / 10];
    circle.setAttribute("cx", pts[i][0]); circle.setAttribute("cy", pts[i][1]);
    svg.querySelector("polygon").setAttribute("points", pts.map((q) => q.join(",")).join(" "));
  };
  const up = () => {
    circle.removeEventListener("pointermove", move);
    svg.dataset.dragging = "0";
    state.src = pts;
    state.srcSize = size;
    inspect();
  };
  circle.addEventListener("pointermove", move);
  circle.addEventListener("pointerup", up, { once: true });
}

$("save").addEventListener("click", async () => {
  try {
    const r = await api("/api/config/save", { method: "POST", headers: { "Content-Type": "application/json" },
      body: body() });
    setStatus(`saved ${r.path}: use it with -c`);
    $("status").dataset.saved = r.path;
  } catch (err) { setStatus(err.message, true); }
});
$("reset").addEventListener("click", () => {
  state.changes = {};
  state.src = null;
  buildForm();
  inspect();
});

// -- routing ---------------------------------------------------------------------------------
async function route() {
  const m = location.hash.match(/^#\/video\/([^/]+)(?:\/(\d+))?/);
  setPlaying(false);
  try {
    if (m) {
      $("fleet-view").hidden = true;
      $("video-view").hidden = false;
      await openVideo(decodeURIComponent(m[1]), Number(m[2] || 0));
    } else if (state.info.mode === "video" && state.videos.length === 1) {
      location.replace(`#/video/${encodeURIComponent(state.videos[0].video)}`);
    } else {
      $("video-view").hidden = true;
      $("fleet-view").hidden = false;
      renderFleet();
    }
  } catch (err) {
    setStatus(err.message, true);
  }
}

(async function start() {
  state.info = await api("/api/info");
  state.videos = await api("/api/videos");
  $("where").textContent = `${state.info.root} (${state.info.mode}, ${state.info.videos} videos)`;
  buildForm();
  window.addEventListener("hashchange", route);
  await route();
  document.body.dataset.ready = "1";
})();
