// mocap2d seeding page (`serve CLIP --skeleton FILE --seeds-out SEEDS.toml`, docs/guide.md
// "serve"): the skeleton's rectangles over any frame of the clip, moved and resized with the
// segment editor of app.js (its stage, drag handles, arrow keys and table), saved as the clip's
// first seed file (POST /api/seeds) and tracked (POST /api/seeds/track); Detect (d) proposes a
// person's joints from the pose network (POST /api/frames/N/detect). Uses `run`, `seg`,
// `joints`, `dirty`, `buildStage`, `update`, `setDirty`, `call`, `say` and `$` of app.js, and
// `detecting`, `showDetect` and `askDetect` of keys.js.
"use strict";

let seedSaved = null; // POST /api/seeds answer

function startSeeds() {
  document.body.classList.add("seeding");
  document.title = "mocap2d: place the first seeds";
  $("#seedfile").textContent = run.file;
  $("#save").textContent = "Save seeds";
  $("#save").onclick = saveSeeds;
  $("#track").onclick = trackSeeds;
  $("#seeddetect").onclick = seedDetect;
  $("#goframe").onsubmit = (ev) => { ev.preventDefault(); seedFrame(Number($("#frameno").value)); };
  $("#seedprev").onclick = () => seedFrame(seg.frame - 1);
  $("#seednext").onclick = () => seedFrame(seg.frame + 1);
  // , . step a frame back and forward, as ◀ ▶ do (the arrow keys nudge the selected rectangle),
  // and d is Detect.
  document.addEventListener("keydown", (ev) => {
    if ($("#editor").hidden || ev.target.tagName === "INPUT") return;
    if (ev.ctrlKey || ev.altKey || ev.metaKey) return;
    if (ev.key === "d" || ev.key === "D") { ev.preventDefault(); seedDetect(); return; }
    const d = { ",": -1, ".": 1 }[ev.key];
    if (!d) return;
    ev.preventDefault();
    seedFrame(seg.frame + d);
  });
  joints = run.joints.map((j) => ({ ...j, status: "seed", placed: run.saved }));
  if (run.saved) seedSaved = { command: run.command };
  seg = { id: null, frame: run.frame, width: run.width, height: run.height };
  $("#keyeditor").hidden = true;
  $("#editor").hidden = false;
  const want = location.hash.slice(1);
  seedFrame(/^f[0-9]+$/.test(want) ? Number(want.slice(1)) : run.frame);
  setDirty(!run.saved);
  setSeedDetect();
  showSeedNext();
}

// Shows frame n under the rectangles, which stay where they are.
function seedFrame(n) {
  const last = run.frames == null ? Infinity : run.frames - 1;
  if (!Number.isInteger(n) || n < 0 || n > last) {
    say(`no frame ${n}` + (last < Infinity ? `: the clip has frames 0 to ${last}` : ""), "error");
    return;
  }
  seg.frame = n;
  seg.png = `/api/frames/${n}/frame.png`;
  $("#frameno").value = n;
  history.replaceState(null, "", `#f${n}`);
  $("#title").textContent = `frame ${n}`;
  buildStage();
}

function setSeedDetect() {
  showDetect($("#seeddetect"), run.no_detect, false,
    "propose the joints on this frame from the pose network (d); nothing is saved until Save seeds");
}

// Detect: the network's proposal for the frame shown, around the joints placed so far (else the
// largest person), moves the joints it has landmarks for, with the rectangles `mocap2d seed`
// gives them, as unsaved edits; the others stay where they are.
async function seedDetect() {
  if (detecting) return;
  if (run.no_detect) { say(run.no_detect, "error"); return; }
  const n = seg.frame;
  if (dirty && joints.some((j) => j.placed) &&
      !confirm("Replace the joints placed so far with the network's proposal?")) return;
  detecting = true;
  setSeedDetect();
  say(`Detecting the person on frame ${n}…`);
  const placed = joints.filter((j) => j.placed).map(({ name, x, y }) => ({ name, x, y }));
  const r = await askDetect(n, { joints: placed });
  detecting = false;
  setSeedDetect();
  // The user went to another frame while the network ran: its answer is not for this one.
  if (seg.frame !== n) { say(`Detect's proposal for frame ${n} is dropped: another frame is shown.`); return; }
  if (!r.ok) { say(`Detect: ${r.body ? r.body.error : r.status}`, "error"); return; }
  for (const p of r.body.joints) {
    const j = joints.find((k) => k.name === p.name);
    if (!j || p.from !== "network") continue;
    Object.assign(j, { x: p.x, y: p.y, w: p.w, h: p.h, angle: p.angle, placed: true });
  }
  setDirty(true);
  update();
  say(r.body.message, "ok");
}

function showPlaced() {
  const left = joints.filter((j) => !j.placed).length;
  $("#placed").textContent = left ? `${joints.length - left} of ${joints.length} joints placed`
    : `all ${joints.length} joints placed`;
}

async function saveSeeds() {
  const left = joints.filter((j) => !j.placed).map((j) => j.name);
  if (left.length && !confirm(`Not placed yet: ${left.join(", ")}. Save them where they are?`)) return;
  const body = {
    frame: seg.frame,
    joints: joints.map(({ name, x, y, w, h, angle }) => ({ name, x, y, w, h, angle })),
  };
  const r = await call("/api/seeds", {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
  });
  if (!r.ok) { say(`Not saved: ${r.body ? r.body.error : r.status}`, "error"); return; }
  seedSaved = r.body;
  setDirty(false);
  say(r.body.saved ? `Saved ${r.body.file} (seeds on frame ${r.body.frame})` : "No change to save.", "ok");
  showSeedNext();
}

// After a save: the command that tracks from the seeds, and the page's button for it.
function showSeedNext() {
  const p = $("#seedcmd");
  p.textContent = "";
  $("#track").hidden = !(run.track && seedSaved);
  if (!seedSaved) return;
  p.append("To track the clip from these seeds, run ");
  const code = document.createElement("code");
  code.textContent = seedSaved.command;
  p.append(code);
  if (run.track) p.append(" or press Track.");
}

async function trackSeeds() {
  if (dirty && !confirm("Track from the seeds as saved (your changes since are not saved)?")) return;
  say("Tracking the clip from the saved seeds…");
  const r = await call("/api/seeds/track", {
    method: "POST", headers: { "Content-Type": "application/json" }, body: "{}",
  });
  if (!r.ok) { say(r.body ? r.body.error : `tracking failed (${r.status})`, "error"); return; }
  say(r.body.message, "ok");
}
