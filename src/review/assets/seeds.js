// mocap2d seeding page (`serve CLIP --skeleton FILE --seeds-out SEEDS.toml`, docs/guide.md
// "serve"): the skeleton's rectangles over any frame of the clip, moved and resized with the
// segment editor of app.js (its stage, drag handles, arrow keys and table), saved as the clip's
// first seed file (POST /api/seeds) and tracked (POST /api/seeds/track). Uses `run`, `seg`,
// `joints`, `dirty`, `buildStage`, `setDirty`, `call`, `say` and `$` of app.js.
"use strict";

let seedSaved = null; // POST /api/seeds answer

function startSeeds() {
  document.body.classList.add("seeding");
  document.title = "mocap2d: place the first seeds";
  $("#seedfile").textContent = run.file;
  $("#save").textContent = "Save seeds";
  $("#save").onclick = saveSeeds;
  $("#track").onclick = trackSeeds;
  $("#goframe").onsubmit = (ev) => { ev.preventDefault(); seedFrame(Number($("#frameno").value)); };
  $("#seedprev").onclick = () => seedFrame(seg.frame - 1);
  $("#seednext").onclick = () => seedFrame(seg.frame + 1);
  // , . step a frame back and forward, as ◀ ▶ do (the arrow keys nudge the selected rectangle).
  document.addEventListener("keydown", (ev) => {
    if ($("#editor").hidden || ev.target.tagName === "INPUT") return;
    if (ev.ctrlKey || ev.altKey || ev.metaKey) return;
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
