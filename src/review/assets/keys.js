// mocap2d correction page, keys on any frame: go to a frame, see its tracked joints as points,
// drag some, and save them as that frame's key in keys.toml (POST /api/keys). Uses `run`,
// `call`, `say` and `$` of app.js.
"use strict";

let kframe = null;   // GET /api/frames/N
let kjoints = [];    // its joints, moved ones with `moved: true`
let kdrag = null;    // { name, start, orig }
let lastSaved = null; // POST /api/keys answer, until another frame is opened

function kscale() {
  return fitScale(run.width, run.height, 190);
}

function kmoved() { return kjoints.filter((j) => j.moved); }

function setKeyButtons() {
  $("#savekey").disabled = kmoved().length === 0;
  $("#removekey").disabled = !kframe || kframe.keyed.length === 0;
  setDetectButton();
}

// The segment (as `resume --segment K` counts) holding frame f (from the server's answer),
// and its file in run.segments.
function segmentOf(f) {
  const k = kframe && kframe.frame === f ? kframe.segment : null;
  if (k == null) return null;
  const file = run.segments.find((s) => Number(s.id) === k);
  return { k, file };
}

async function openFrame(n) {
  if (!Number.isInteger(n) || n < 0) { say(`no frame ${n}`, "error"); return; }
  if (kmoved().length && !confirm("Discard the joints moved on this frame?")) return;
  if (typeof dirty !== "undefined" && dirty && !confirm("Discard the unsaved segment changes?")) return;
  if (typeof setDirty === "function") setDirty(false);
  const r = await call(`/api/frames/${n}`);
  if (!r.ok) { say(r.body ? r.body.error : `no frame ${n}`, "error"); return; }
  const same = kframe && kframe.frame === n;
  if (!same) lastSaved = null;
  kframe = r.body;
  // A keyed joint is drawn where its key puts it: a key saved but not yet tracked with (no
  // resume since) is elsewhere than the tracked point, which `tracked` keeps.
  kjoints = kframe.joints.map((j) => {
    const k = (kframe.keys || {})[j.name];
    if (!k) return { ...j, moved: false };
    return { ...j, x: k[0], y: k[1], tracked: { x: j.x, y: j.y }, moved: false };
  });
  const pending = kjoints.filter((j) => j.tracked && Math.hypot(j.x - j.tracked.x, j.y - j.tracked.y) > 0.5);
  $("#frameno").value = n;
  history.replaceState(null, "", `#f${n}`);
  $("#editor").hidden = true;
  $("#keyeditor").hidden = false;
  const seg = segmentOf(n);
  $("#ktitle").textContent = `frame ${n}` + (seg ? ` (segment ${seg.k})` : "") +
    (kframe.keyed.length ? `, keyed: ${kframe.keyed.join(", ")}` : "") +
    (pending.length ? "; not tracked with yet: resume (a dashed line joins the tracked point to its key)" : "");
  if (kframe.keys_error) say(`keys.toml: ${kframe.keys_error}`, "error");
  else if (!same) say("");
  buildKeyStage();
  showNext();
}

function buildKeyStage() {
  const svg = frameStage($("#kstage"), run.width, run.height, kscale(),
    `/api/frames/${kframe.frame}/frame.png`, "kbones");
  for (const j of kjoints) {
    const ring = document.createElementNS(SVG, "circle");
    ring.setAttribute("class", "kring");
    ring.dataset.name = j.name;
    svg.appendChild(ring);
    const c = document.createElementNS(SVG, "circle");
    c.setAttribute("class", "kpoint");
    c.dataset.name = j.name;
    c.setAttribute("fill", COLOURS[j.status] || "#ffffff");
    svg.appendChild(c);
    const t = document.createElementNS(SVG, "text");
    t.setAttribute("class", "name");
    t.dataset.name = j.name;
    t.textContent = j.name;
    svg.appendChild(t);
  }
  svg.onpointerdown = kdown;
  svg.onpointermove = kmove;
  svg.onpointerup = svg.onpointercancel = () => { kdrag = null; };
  kupdate();
}

function kupdate() {
  const svg = $("#kstage");
  const s = kscale();
  const parents = Object.fromEntries(run.joints.map((j) => [j.name, j.parent]));
  const at = Object.fromEntries(kjoints.map((j) => [j.name, j]));
  for (const j of kjoints) {
    const sel = `[data-name="${CSS.escape(j.name)}"]`;
    const c = svg.querySelector(`circle.kpoint${sel}`);
    c.setAttribute("cx", j.x); c.setAttribute("cy", j.y); c.setAttribute("r", 5 / s);
    c.classList.toggle("moved", j.moved);
    c.classList.toggle("proposed", j.moved && !!j.proposed);
    const ring = svg.querySelector(`circle.kring${sel}`);
    const keyed = j.moved || kframe.keyed.includes(j.name);
    ring.setAttribute("cx", j.x); ring.setAttribute("cy", j.y); ring.setAttribute("r", 9 / s);
    ring.style.display = keyed ? "" : "none";
    ring.classList.toggle("keyed", keyed);
    const t = svg.querySelector(`text.name${sel}`);
    t.style.fontSize = `${11 / s}px`;
    t.style.strokeWidth = `${3 / s}px`;
    t.setAttribute("x", j.x + 8 / s); t.setAttribute("y", j.y - 6 / s);
  }
  const bones = svg.querySelector("#kbones");
  bones.textContent = "";
  // From where tracking put a keyed joint to its key, when they differ.
  for (const j of kjoints) {
    if (!j.tracked || Math.hypot(j.x - j.tracked.x, j.y - j.tracked.y) <= 0.5) continue;
    const l = document.createElementNS(SVG, "line");
    l.setAttribute("class", "kpull");
    l.dataset.name = j.name;
    l.setAttribute("x1", j.tracked.x); l.setAttribute("y1", j.tracked.y);
    l.setAttribute("x2", j.x); l.setAttribute("y2", j.y);
    bones.appendChild(l);
  }
  for (const j of kjoints) {
    const p = parents[j.name] && at[parents[j.name]];
    if (!p) continue;
    const l = document.createElementNS(SVG, "line");
    l.setAttribute("class", "bone");
    l.setAttribute("x1", p.x); l.setAttribute("y1", p.y);
    l.setAttribute("x2", j.x); l.setAttribute("y2", j.y);
    bones.appendChild(l);
  }
  setKeyButtons();
}

// Pressing takes the joint nearest the pointer, within 10 screen px (overlapping points: the
// one whose centre is pressed).
function kdown(ev) {
  const p = framePoint(ev, $("#kstage"));
  const reach = 10 / kscale();
  let j = null, best = reach * reach;
  for (const k of kjoints) {
    const d = (k.x - p.x) ** 2 + (k.y - p.y) ** 2;
    if (d <= best) { best = d; j = k; }
  }
  if (!j) return;
  kdrag = { name: j.name, start: p, orig: { x: j.x, y: j.y } };
  $("#kstage").setPointerCapture(ev.pointerId);
  ev.preventDefault();
}

function kmove(ev) {
  if (!kdrag) return;
  const j = kjoints.find((k) => k.name === kdrag.name);
  const p = framePoint(ev, $("#kstage"));
  const clamp = (v, hi) => Math.min(hi - 0.5, Math.max(-0.5, v));
  j.x = clamp(kdrag.orig.x + (p.x - kdrag.start.x), run.width);
  j.y = clamp(kdrag.orig.y + (p.y - kdrag.start.y), run.height);
  j.moved = true;
  kupdate();
}

async function postKey(joints) {
  const n = kframe.frame;
  const r = await call("/api/keys", {
    method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ frame: n, joints }),
  });
  if (!r.ok) { say(`Not saved: ${r.body ? r.body.error : r.status}`, "error"); return; }
  lastSaved = r.body;
  for (const j of kjoints) j.moved = false;
  const what = r.body.keyed.length ? `key on frame ${n}: ${r.body.keyed.join(", ")}` : `no key on frame ${n}`;
  say(r.body.saved ? `Saved keys.toml (${what})` : `No change to save (${what}).`, "ok");
  await openFrame(n);
}

function saveKey() {
  const joints = Object.fromEntries(kmoved().map((j) => [j.name, [j.x, j.y]]));
  return postKey(joints);
}

function removeKey() {
  if (!confirm(`Remove the key on frame ${kframe.frame}?`)) return;
  return postKey({});
}

// Detect: the pose network's proposal for this frame (POST /api/frames/N/detect, which saves
// nothing), shown as joints moved but not saved; the user drags any that are off and saves them
// as any key. Disabled, saying why, on a run whose joints are not a person's.
// The seeding page's Detect (seeds.js) shares `detecting`, `showDetect` and `askDetect`.
let detecting = false;

// Shows Detect button `b`: disabled, with the reason `why` as its tooltip (else `title`), when
// the joints are not a person's, while the network runs (busy) or when `off`.
function showDetect(b, why, off, title) {
  b.disabled = Boolean(why) || detecting || off;
  b.title = why || title;
  b.textContent = detecting ? "Detecting…" : "Detect";
  b.classList.toggle("busy", detecting);
}

function setDetectButton() {
  showDetect($("#detect"), run && run.no_detect, !kframe,
    "propose this frame's joints from the pose network (d); nothing is saved until Save key");
}

// POST /api/frames/n/detect with `body`; a server that does not answer is an error answer.
async function askDetect(n, body) {
  try {
    return await call(`/api/frames/${n}/detect`, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
    });
  } catch (e) {
    return { ok: false, body: { error: `no answer from the server (${e.message})` } };
  }
}

async function detect() {
  if (!kframe || detecting) return;
  if (run && run.no_detect) { say(run.no_detect, "error"); return; }
  const n = kframe.frame;
  if (kmoved().length && !confirm("Replace the joints moved on this frame with the network's proposal?")) return;
  detecting = true;
  setDetectButton();
  say(`Detecting the person on frame ${n}…`);
  const r = await askDetect(n, {});
  detecting = false;
  setDetectButton();
  // The user went to another frame while the network ran: its answer is not for this one.
  if (!kframe || kframe.frame !== n) return;
  if (!r.ok) { say(`Detect: ${r.body ? r.body.error : r.status}`, "error"); return; }
  for (const p of r.body.joints) {
    const j = kjoints.find((k) => k.name === p.name);
    if (!j || p.from !== "network") continue;
    j.x = p.x; j.y = p.y;
    j.moved = true;
    j.proposed = true;
  }
  kupdate();
  say(r.body.message, "ok");
}

// After a save: what to run for the key to take effect, and the page's resume for it.
function showNext() {
  const p = $("#keynext");
  const b = $("#resumekey");
  p.textContent = "";
  b.hidden = true;
  if (!lastSaved || !lastSaved.command) return;
  p.append("To track with this key, run ");
  const code = document.createElement("code");
  code.textContent = lastSaved.command;
  p.append(code);
  // From the segment before the key's: the key pulls that segment's last frames too.
  const k = lastSaved.resume_from;
  const file = run.segments.find((s) => Number(s.id) === k);
  if (run.resume && file) {
    p.append(" or press the button.");
    b.textContent = `Resume segment ${file.id}`;
    b.dataset.id = file.id;
    b.hidden = false;
  }
}

async function resumeKeyed() {
  const id = $("#resumekey").dataset.id;
  say(`Resuming from segment ${id}…`);
  const r = await call(`/api/segments/${id}/resume`, {
    method: "POST", headers: { "Content-Type": "application/json" }, body: "{}",
  });
  if (!r.ok) { say(r.body ? r.body.error : `resume failed (${r.status})`, "error"); return; }
  lastSaved = null;
  await loadRun();
  await openFrame(kframe.frame);
  say(r.body.message, "ok");
}

$("#goframe").onsubmit = (ev) => { ev.preventDefault(); openFrame(Number($("#frameno").value)); };
$("#prevframe").onclick = () => openFrame(kframe.frame - 1);
$("#nextframe").onclick = () => openFrame(kframe.frame + 1);
// ← → and , . step a frame back and forward, as ◀ ▶ do, and d is Detect (not while typing in a
// field, nor with Ctrl, Alt or Cmd held, which are the browser's).
document.addEventListener("keydown", (ev) => {
  if (!kframe || $("#keyeditor").hidden || ev.target.tagName === "INPUT") return;
  if (ev.ctrlKey || ev.altKey || ev.metaKey) return;
  if (ev.key === "d" || ev.key === "D") { ev.preventDefault(); detect(); return; }
  const d = { ArrowLeft: -1, ",": -1, ArrowRight: 1, ".": 1 }[ev.key];
  if (!d || kframe.frame + d < 0) return;
  ev.preventDefault();
  openFrame(kframe.frame + d);
});
// The frames the report says are worth keying next (most worth first), each a button to it.
function renderWorth() {
  const box = $("#worth");
  const list = box.querySelector("span");
  list.textContent = "";
  for (const f of run.suggested || []) {
    const b = document.createElement("button");
    b.type = "button";
    b.textContent = f;
    b.title = `open frame ${f}`;
    b.onclick = () => openFrame(f);
    list.appendChild(b);
  }
  box.hidden = list.childElementCount === 0;
}
$("#savekey").onclick = saveKey;
$("#removekey").onclick = removeKey;
$("#detect").onclick = detect;
$("#resumekey").onclick = resumeKeyed;
window.addEventListener("beforeunload", (ev) => { if (kmoved().length) ev.preventDefault(); });
