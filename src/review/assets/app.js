// mocap2d correction page: lists the run's segments, shows one segment's first frame with its
// joint rectangles, lets them be moved, resized and rotated, and saves them back to the
// segment file. Keys on any frame are keys.js; the first seeds of a bare clip, seeds.js. No libraries: plain DOM and SVG, served by `mocap2d serve`.
"use strict";

const SVG = "http://www.w3.org/2000/svg";
const COLOURS = { seed: "#00dcff", ok: "#28dc3c", low: "#ffdc00", occluded: "#ff8c00", lost: "#f01e1e" };
const $ = (s) => document.querySelector(s);

let run = null;      // GET /api/run
let seg = null;      // GET /api/segments/ID
let joints = [];     // edited copy of seg.joints
let dirty = false;
let selected = null; // joint name
let drag = null;     // { mode, name, start: {x, y}, orig: {...} }

function say(text, kind) {
  const m = $("#message");
  m.textContent = text;
  m.className = kind || "";
}

async function call(path, options) {
  const r = await fetch(path, options);
  const type = r.headers.get("content-type") || "";
  const body = type.includes("json") ? await r.json() : null;
  return { ok: r.ok, status: r.status, body };
}

function setDirty(d) {
  dirty = d;
  $("#save").disabled = !d;
  $("#revert").disabled = !d;
}

async function loadRun() {
  const r = await call("/api/run");
  if (!r.ok) { say(r.body ? r.body.error : "cannot read the run", "error"); return; }
  run = r.body;
  if (typeof renderWorth === "function") renderWorth();
  const frames = run.frames == null ? "" : `, ${run.frames} frames`;
  $("#run").textContent = `${run.run}  (${run.width}×${run.height}${frames})`;
  renderList();
}

function renderList() {
  const ul = $("#segments");
  ul.textContent = "";
  $("#nosegments").hidden = run.segments.length + run.broken.length > 0;
  for (const s of run.segments) {
    const li = document.createElement("li");
    const b = document.createElement("button");
    b.dataset.id = s.id;
    b.className = (s.flagged ? "flagged" : "") + (seg && seg.id === s.id ? " current" : "");
    b.textContent = `${s.id}  frames ${s.frame}–${Math.max(s.frame, s.end - 1)}`;
    const f = document.createElement("span");
    f.className = "flags";
    f.textContent = s.flags + (s.flagged ? `, min score ${s.min_score.toFixed(2)}` : "");
    b.appendChild(f);
    b.onclick = () => openSegment(s.id);
    li.appendChild(b);
    ul.appendChild(li);
  }
  for (const s of run.broken) {
    const li = document.createElement("li");
    li.className = "broken";
    li.textContent = `${s.id}: ${s.error}`;
    ul.appendChild(li);
  }
}

async function openSegment(id) {
  if (dirty && !confirm("Discard the unsaved changes?")) return;
  const r = await call(`/api/segments/${id}`);
  if (!r.ok) { say(r.body.error, "error"); return; }
  seg = r.body;
  seg.png = `/api/segments/${id}/frame.png`;
  joints = seg.joints.map((j) => ({ ...j }));
  selected = null;
  setDirty(false);
  history.replaceState(null, "", `#${id}`);
  $("#keyeditor").hidden = true;
  $("#editor").hidden = false;
  $("#title").textContent = `segment ${seg.id}, frame ${seg.frame} (${seg.file})`;
  buildStage();
  renderList();
  say("");
}

// Display scale at which the frame fits beside the list (small frames enlarged up to 3×).
// The scale a frame of `width` × `height` is drawn at, leaving `margin` px of height for the
// page around it.
function fitScale(width, height, margin) {
  const room = Math.max(320, window.innerWidth - 300);
  const high = Math.max(240, window.innerHeight - margin);
  return Math.min(3, room / width, high / height);
}

function displayScale() {
  return fitScale(seg.width, seg.height, 160);
}

// Empties `svg` and lays a frame picture (`href`) in it at `scale`, with an empty group
// `bonesId` over it for the bones; returns the svg.
function frameStage(svg, width, height, scale, href, bonesId) {
  svg.textContent = "";
  svg.setAttribute("viewBox", `0 0 ${width} ${height}`);
  svg.setAttribute("width", Math.round(width * scale));
  svg.setAttribute("height", Math.round(height * scale));
  const img = document.createElementNS(SVG, "image");
  img.setAttribute("href", href);
  img.setAttribute("width", width);
  img.setAttribute("height", height);
  svg.appendChild(img);
  const bones = document.createElementNS(SVG, "g");
  bones.id = bonesId;
  svg.appendChild(bones);
  return svg;
}

function buildStage() {
  const svg = frameStage($("#stage"), seg.width, seg.height, displayScale(), seg.png, "bones");
  for (const j of joints) {
    const g = document.createElementNS(SVG, "g");
    g.classList.add("joint");
    g.dataset.name = j.name;
    const colour = COLOURS[j.status] || "#ffffff";
    const add = (tag, cls, role) => {
      const e = document.createElementNS(SVG, tag);
      e.setAttribute("class", cls);
      if (role) { e.dataset.role = role; e.dataset.name = j.name; }
      e.setAttribute("stroke", colour);
      g.appendChild(e);
      return e;
    };
    add("rect", "body", "move");
    add("line", "tick");
    add("line", "stick");
    add("rect", "resize", "resize");
    add("circle", "rotate", "rotate");
    svg.appendChild(g);
    const t = document.createElementNS(SVG, "text");
    t.setAttribute("class", "name");
    t.dataset.name = j.name;
    t.textContent = j.name;
    svg.appendChild(t);
  }
  svg.onpointerdown = pointerDown;
  svg.onpointermove = pointerMove;
  svg.onpointerup = svg.onpointercancel = pointerUp;
  update();
}

// Handle size in frame px for a constant size on screen.
function handle() { return 4 / displayScale(); }

function update() {
  const svg = $("#stage");
  const h = handle();
  for (const j of joints) {
    const g = svg.querySelector(`g.joint[data-name="${CSS.escape(j.name)}"]`);
    g.setAttribute("transform", `translate(${j.x} ${j.y}) rotate(${(j.angle * 180) / Math.PI})`);
    g.classList.toggle("selected", j.name === selected);
    g.classList.toggle("unplaced", j.placed === false);
    const [body, tick, stick, resize, rotate] = g.children;
    body.setAttribute("x", -j.w / 2); body.setAttribute("y", -j.h / 2);
    body.setAttribute("width", j.w); body.setAttribute("height", j.h);
    tick.setAttribute("x1", 0); tick.setAttribute("y1", 0);
    tick.setAttribute("x2", j.w / 2); tick.setAttribute("y2", 0);
    stick.setAttribute("x1", j.w / 2); stick.setAttribute("y1", 0);
    stick.setAttribute("x2", j.w / 2 + 4 * h); stick.setAttribute("y2", 0);
    resize.setAttribute("x", j.w / 2 - h); resize.setAttribute("y", j.h / 2 - h);
    resize.setAttribute("width", 2 * h); resize.setAttribute("height", 2 * h);
    rotate.setAttribute("cx", j.w / 2 + 4 * h); rotate.setAttribute("cy", 0);
    rotate.setAttribute("r", h);
    const t = svg.querySelector(`text.name[data-name="${CSS.escape(j.name)}"]`);
    t.style.fontSize = `${11 / displayScale()}px`;
    t.style.strokeWidth = `${3 / displayScale()}px`;
    t.setAttribute("x", j.x + Math.max(j.w, j.h) / 2 + 2 / displayScale());
    t.setAttribute("y", j.y - j.h / 2);
  }
  const bones = svg.querySelector("#bones");
  bones.textContent = "";
  const at = Object.fromEntries(joints.map((j) => [j.name, j]));
  for (const j of joints) {
    const p = j.parent && at[j.parent];
    if (!p) continue;
    const l = document.createElementNS(SVG, "line");
    l.setAttribute("class", "bone");
    l.setAttribute("x1", p.x); l.setAttribute("y1", p.y);
    l.setAttribute("x2", j.x); l.setAttribute("y2", j.y);
    bones.appendChild(l);
  }
  renderTable();
  if (run.mode === "seed") showPlaced();
}

function renderTable() {
  const tb = $("#joints tbody");
  tb.textContent = "";
  for (const j of joints) {
    const tr = document.createElement("tr");
    tr.dataset.name = j.name;
    if (j.name === selected) tr.className = "selected";
    const cells = [j.name, j.x.toFixed(3), j.y.toFixed(3), j.w, j.h,
      ((j.angle * 180) / Math.PI).toFixed(1), j.placed === false ? "to place" : j.status || "",
      j.score == null ? "" : j.score.toFixed(3)];
    for (const c of cells) {
      const td = document.createElement("td");
      td.textContent = c;
      tr.appendChild(td);
    }
    tr.onclick = () => { selected = j.name; update(); };
    tb.appendChild(tr);
  }
}

// The pointer's position in frame px on the picture `svg` (the segment editor's by default).
function framePoint(ev, svg = $("#stage")) {
  const p = svg.createSVGPoint();
  p.x = ev.clientX; p.y = ev.clientY;
  return p.matrixTransform(svg.getScreenCTM().inverse());
}

function pointerDown(ev) {
  const role = ev.target.dataset && ev.target.dataset.role;
  if (!role) return;
  const j = joints.find((k) => k.name === ev.target.dataset.name);
  selected = j.name;
  drag = { mode: role, name: j.name, start: framePoint(ev), orig: { ...j } };
  $("#stage").setPointerCapture(ev.pointerId);
  ev.preventDefault();
  update();
}

function pointerMove(ev) {
  if (!drag) return;
  const j = joints.find((k) => k.name === drag.name);
  const p = framePoint(ev);
  const o = drag.orig;
  if (drag.mode === "move") {
    j.x = o.x + (p.x - drag.start.x);
    j.y = o.y + (p.y - drag.start.y);
  } else if (drag.mode === "resize") {
    // The pointer in the rectangle's own axes sets the half sizes.
    const dx = p.x - o.x, dy = p.y - o.y;
    const c = Math.cos(-o.angle), s = Math.sin(-o.angle);
    const lx = c * dx - s * dy, ly = s * dx + c * dy;
    j.w = Math.max(5, Math.round(2 * Math.abs(lx)));
    j.h = Math.max(5, Math.round(2 * Math.abs(ly)));
  } else if (drag.mode === "rotate") {
    j.angle = Math.atan2(p.y - o.y, p.x - o.x);
  }
  j.placed = true;
  setDirty(true);
  update();
}

function pointerUp() { drag = null; }

document.addEventListener("keydown", (ev) => {
  if (!seg || !selected || ev.target.tagName === "INPUT" || $("#editor").hidden) return;
  const step = ev.shiftKey ? 10 : 1;
  const d = { ArrowLeft: [-step, 0], ArrowRight: [step, 0], ArrowUp: [0, -step], ArrowDown: [0, step] }[ev.key];
  if (!d) return;
  const j = joints.find((k) => k.name === selected);
  j.x += d[0]; j.y += d[1];
  j.placed = true;
  setDirty(true);
  update();
  ev.preventDefault();
});

async function save() {
  const body = { joints: joints.map(({ name, x, y, w, h, angle }) => ({ name, x, y, w, h, angle })) };
  const r = await call(`/api/segments/${seg.id}`, {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
  });
  if (!r.ok) { say(`Not saved: ${r.body ? r.body.error : r.status}`, "error"); return; }
  setDirty(false);
  say(r.body.saved ? `Saved ${r.body.file} (previous version: ${r.body.previous})` : "No change to save.", "ok");
  await loadRun();
}

async function resume() {
  if (dirty) { say("Save first: resume starts from the saved segment file.", "error"); return; }
  say(`Resuming from segment ${seg.id}…`);
  const r = await call(`/api/segments/${seg.id}/resume`, {
    method: "POST", headers: { "Content-Type": "application/json" }, body: "{}",
  });
  if (!r.ok) { say(r.body ? r.body.error : `resume failed (${r.status})`, "error"); return; }
  // Reopening the segment clears the message line: the resume's answer is said after it.
  await loadRun();
  await openSegment(seg.id);
  say(r.body.message, "ok");
}

$("#save").onclick = save;
$("#revert").onclick = () => { setDirty(false); openSegment(seg.id); };
$("#resume").onclick = resume;
window.addEventListener("beforeunload", (ev) => { if (dirty) ev.preventDefault(); });

// The page starts once every script has run (keys.js and seeds.js load after this one, and the
// run's description can arrive before they do).
window.addEventListener("DOMContentLoaded", () => loadRun().then(() => {
  if (run.mode === "seed") { startSeeds(); return; }
  const want = location.hash.slice(1);
  if (/^f[0-9]+$/.test(want)) { openFrame(Number(want.slice(1))); return; }
  const first = run.segments.find((s) => s.id === want) || run.segments.find((s) => s.flagged) || run.segments[0];
  if (first) openSegment(first.id);
}));
