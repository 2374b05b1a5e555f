// End-to-end test of the correction page in headless Chromium (Debian's /usr/bin/chromium,
// driven by playwright-core): render and track a tiny synth clip, give the run a segment file,
// start `mocap2d serve`, drag the head's rectangle, rotate the wrist's, save, and check that the
// segment file changed by the dragged amounts; then go to frame 12, step back and forward a frame
// by keys and buttons, drag the left knee, save a key and check keys.toml holds it. Then the
// seeding page of the bare clip (`serve clip.mp4 --skeleton joints.toml --seeds-out first.toml`):
// go to frame 20, step by keys, drag the head, save the seeds, check the file and that `track`
// reads it, and track from the page. Detect: disabled on the walk (not a person); on a person's
// run of the bundled frame, its proposal shows unsaved and saves as a key; on the seeding page
// of the bundled frame, it moves the joints onto the person, unsaved. Leaves screenshots.
//
//   node tests/browser/e2e.mjs            (MOCAP2D: the binary, default cargo's target/debug/mocap2d;
//                                          CHROMIUM: default /usr/bin/chromium;
//                                          SCREENSHOT: default target/browser/page.png)
import { chromium } from "playwright-core";
import { spawn, execFileSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";

const root = path.resolve(path.dirname(new URL(import.meta.url).pathname), "../..");
// The binary: MOCAP2D, else the debug build in cargo's target folder (CARGO_TARGET_DIR or
// .cargo/config may move it: ask cargo).
const targetDir = () =>
  JSON.parse(
    execFileSync("cargo", ["metadata", "--format-version", "1", "--no-deps"], {
      cwd: root,
      encoding: "utf8",
    }),
  ).target_directory;
const bin = path.resolve(root, process.env.MOCAP2D || path.join(targetDir(), "debug/mocap2d"));
const shot = path.resolve(root, process.env.SCREENSHOT || "target/browser/page.png");
let failures = 0;
const check = (ok, what) => {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failures++;
};

/** The joint table `name` of a seed-format file: x, y, w, h, angle. */
function joint(text, name) {
  const block = text.split("[[joint]]").find((b) => b.includes(`name = "${name}"`));
  const num = (k) => {
    const m = block.match(new RegExp(`^${k} = (-?[0-9.]+)$`, "m"));
    return m ? Number(m[1]) : 0;
  };
  return { x: num("x"), y: num("y"), w: num("w"), h: num("h"), angle: num("angle") };
}

/** Drags on `page` from (x, y) by (dx, dy) screen px, in two halves of 4 steps. */
// A drawn element's box; the page redraws after saves and resumes, so an element may be
// replaced between finding it and measuring it: try again for a few seconds.
async function settledBox(locator) {
  for (let i = 0; i < 50; i++) {
    await locator.waitFor({ state: "visible" });
    const b = await locator.boundingBox();
    if (b) return b;
    await new Promise((r) => setTimeout(r, 100));
  }
  throw new Error("element never settled on the page");
}

async function drag(page, x, y, dx, dy) {
  await page.mouse.move(x, y);
  await page.mouse.down();
  await page.mouse.move(x + dx / 2, y + dy / 2, { steps: 4 });
  await page.mouse.move(x + dx, y + dy, { steps: 4 });
  await page.mouse.up();
}

const work = fs.mkdtempSync(path.join(os.tmpdir(), "mocap2d-e2e-"));
const run = (...args) => execFileSync(bin, args, { cwd: work, stdio: ["ignore", "pipe", "pipe"] });
run("synth", "walk", "--out", ".", "--size", "320x240", "--frames", "30", "--seed", "5");
run("track", "clip.mp4", "--seeds", "joints.toml", "--out", "r.mocap", "-q");
// A segment file as `track --segment-len` writes them: the seed-file format, frame = first frame.
// `track` wrote segments/000.toml (the seed frame): the page edits that one.
const segFile = path.join(work, "r.mocap/segments/000.toml");

/** Whether `mocap2d track clip.mp4 --seeds SEEDS --out OUT` succeeds (its stderr printed if not). */
function tracks(seeds, out) {
  try {
    run("track", "clip.mp4", "--seeds", seeds, "--out", out, "-q");
    return true;
  } catch (e) {
    console.log(String(e.stderr));
    return false;
  }
}

/** Starts `mocap2d serve ARGS --port 0` in the work folder: the process and its address. */
async function serve(...args) {
  const proc = spawn(bin, ["serve", ...args, "--port", "0"], { cwd: work });
  const addr = await new Promise((resolve, reject) => {
    let err = "";
    proc.stderr.on("data", (d) => {
      err += d;
      const m = err.match(/http:\/\/127\.0\.0\.1:\d+\//);
      if (m) resolve(m[0]);
    });
    proc.on("exit", (c) => reject(new Error(`serve exited with ${c}: ${err}`)));
    setTimeout(() => reject(new Error(`serve did not start: ${err}`)), 20000);
  });
  return [proc, addr];
}
const [server, url] = await serve("r.mocap");
let seeder = null;
let seeder2 = null;
let detecter = null;

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
try {
  const page = await browser.newPage({ viewport: { width: 1000, height: 720 } });
  page.on("pageerror", (e) => check(false, `no script error (${e.message})`));
  await page.goto(url);
  const head = page.locator('g.joint[data-name="head"] rect.body');
  await head.waitFor();
  await page.waitForFunction(() => {
    const im = document.querySelector("#stage image");
    return im && im.getBBox().width > 0;
  });
  const before = joint(fs.readFileSync(segFile, "utf8"), "head");
  const scale = await page.evaluate(() => {
    const svg = document.querySelector("#stage");
    return svg.getBoundingClientRect().width / svg.viewBox.baseVal.width;
  });

  // Drag the head 40 px right and 24 px up on screen.
  const box = await head.boundingBox();
  const [cx, cy] = [Math.round(box.x + box.width / 2), Math.round(box.y + box.height / 2)];
  await drag(page, cx, cy, 40, -24);

  // Select the left wrist (handles show on the selected rectangle only) and turn it to point
  // straight down (+90°, clockwise on screen).
  const wb = await page.locator('g.joint[data-name="wrist_l"] rect.body').boundingBox();
  await page.mouse.click(wb.x + wb.width / 2, wb.y + wb.height / 2);
  const wrist = await page.evaluate(() => {
    const g = document.querySelector('g.joint[data-name="wrist_l"]');
    const r = g.querySelector("circle.rotate").getBoundingClientRect();
    const b = g.querySelector("rect.body").getBoundingClientRect();
    return { hx: r.x + r.width / 2, hy: r.y + r.height / 2, cx: b.x + b.width / 2, cy: b.y + b.height / 2 };
  });
  await page.mouse.move(wrist.hx, wrist.hy);
  await page.mouse.down();
  await page.mouse.move(wrist.cx, wrist.cy + 60, { steps: 6 });
  await page.mouse.up();

  await page.click("#save");
  await page.waitForFunction(() => /Saved|Not saved/.test(document.querySelector("#message").textContent));
  const msg = await page.textContent("#message");
  check(msg.startsWith("Saved segments/000.toml"), `save reported: ${msg}`);

  const text = fs.readFileSync(segFile, "utf8");
  const after = joint(text, "head");
  const [dx, dy] = [after.x - before.x, after.y - before.y];
  const tol = 0.51 / scale;
  check(Math.abs(dx - 40 / scale) <= tol && Math.abs(dy + 24 / scale) <= tol,
    `head moved by (${dx.toFixed(3)}, ${dy.toFixed(3)}) px; dragged (${(40 / scale).toFixed(3)}, ${(-24 / scale).toFixed(3)}) at scale ${scale.toFixed(3)}`);
  check(after.w === before.w && after.h === before.h, `head size kept (${after.w}x${after.h})`);
  const angle = joint(text, "wrist_l").angle;
  check(Math.abs(angle - Math.PI / 2) < 0.1, `wrist_l turned to ${angle} rad (want about ${(Math.PI / 2).toFixed(4)})`);
  check(fs.existsSync(path.join(work, "r.mocap/segments/history/000.001.toml")), "previous version kept in segments/history");
  // The file is still a seed file: the tool itself must accept it as seeds.
  check(tracks("r.mocap/segments/000.toml", "again.mocap"), "saved segment file is accepted by `mocap2d track --seeds`");

  await page.click("#resume");
  await page.waitForFunction(() => ["ok", "error"].includes(document.querySelector("#message").className), null, { timeout: 120000 });
  const resumeMsg = await page.textContent("#message");
  check(resumeMsg.includes("resumed from segment 000"), `resume answers: ${resumeMsg}`);

  // Select the head so the screenshot shows a selection, then capture the page. The page
  // redraws the segment after a resume: wait for the head to be drawn again.
  const hb = await settledBox(head);
  await page.mouse.click(hb.x + hb.width / 2, hb.y + hb.height / 2);
  fs.mkdirSync(path.dirname(shot), { recursive: true });
  await page.screenshot({ path: shot, fullPage: true });
  console.log(`screenshot: ${shot}`);

  // The frames worth keying, as the report names them: each a button that opens the frame.
  const worth = await page.$$eval("#worth button", (bs) => bs.map((b) => Number(b.textContent)));
  check(worth.length > 0 && !(await page.isHidden("#worth")), `frames worth keying listed: ${worth.join(", ")}`);
  if (worth.length > 0) {
    await page.click("#worth button");
    const opened = await page.waitForFunction((n) => new RegExp(`^frame ${n}\\b`)
      .test(document.querySelector("#ktitle").textContent), worth[0], { timeout: 10000 })
      .then(() => true, () => false);
    check(opened, `the first of them (frame ${worth[0]}) opens in the key editor`);
  }

  // A key on any frame: go to frame 12, drag the left knee, save the key.
  await page.fill("#frameno", "12");
  await page.click("#go");
  // Stepping a frame: ← and , go back, → and . forward, as ◀ ▶ do; not while typing in the
  // frame box.
  const onFrame = (n) => page.waitForFunction((n) => location.hash === `#f${n}`
    && new RegExp(`^frame ${n}\\b`).test(document.querySelector("#ktitle").textContent),
  n, { timeout: 10000 }).then(() => true, () => false);
  check(await onFrame(12), "Go opens frame 12");
  await page.evaluate(() => document.activeElement.blur());
  const seen = [];
  for (const [how, n] of [["ArrowLeft", 11], [",", 10], ["#prevframe", 9], ["ArrowRight", 10],
    [".", 11], ["#nextframe", 12]]) {
    if (how.startsWith("#")) await page.click(how); else await page.keyboard.press(how);
    seen.push((await onFrame(n)) ? n : `not ${n}`);
  }
  check(seen.join(", ") === "11, 10, 9, 10, 11, 12",
    `← , ◀ → . ▶ step back and forward a frame at a time: ${seen.join(", ")}`);
  await page.focus("#frameno");
  await page.keyboard.press("ArrowLeft");
  await page.waitForTimeout(300);
  check(await onFrame(12), "← in the frame box does not step");
  const knee = page.locator('#kstage circle.kpoint[data-name="knee_l"]');
  await knee.waitFor();
  await page.waitForFunction(() => {
    const im = document.querySelector("#kstage image");
    return im && im.getBBox().width > 0;
  });
  const k0 = { x: Number(await knee.getAttribute("cx")), y: Number(await knee.getAttribute("cy")) };
  const kscale = await page.evaluate(() => {
    const svg = document.querySelector("#kstage");
    return svg.getBoundingClientRect().width / svg.viewBox.baseVal.width;
  });
  const kb = await settledBox(knee);
  const [kx, ky] = [kb.x + kb.width / 2, kb.y + kb.height / 2];
  await drag(page, kx, ky, 30, 10);
  await page.click("#savekey");
  await page.waitForFunction(() => /Saved keys|Not saved/.test(document.querySelector("#message").textContent));
  const kmsg = await page.textContent("#message");
  check(kmsg.startsWith("Saved keys.toml (key on frame 12: knee_l)"), `key save reported: ${kmsg}`);
  const keys = fs.readFileSync(path.join(work, "r.mocap/keys.toml"), "utf8");
  const km = keys.match(/\[\[key\]\]\nframe = 12\nknee_l = \[(-?[0-9.e-]+), (-?[0-9.e-]+)\]\n/);
  check(km !== null && !/^(?!#)[a-z_]+ = \[/m.test(keys.replace(km ? km[0] : "", "")),
    `keys.toml holds the knee key only:\n${keys}`);
  if (km) {
    const [dx, dy] = [Number(km[1]) - k0.x, Number(km[2]) - k0.y];
    const tol = 0.51 / kscale;
    check(Math.abs(dx - 30 / kscale) <= tol && Math.abs(dy - 10 / kscale) <= tol,
      `knee keyed at (${dx.toFixed(3)}, ${dy.toFixed(3)}) px from its track; dragged (${(30 / kscale).toFixed(3)}, ${(10 / kscale).toFixed(3)})`);
  }
  // The page redraws the frame's keys and names the resume after the save answers.
  await page.waitForFunction(() => document.querySelector("#keynext").textContent.includes("--segment"),
    null, { timeout: 10000 }).catch(() => {});
  const ringed = await page.locator('#kstage circle.kring.keyed[data-name="knee_l"]').count();
  check(ringed === 1, "the keyed knee is drawn ringed");
  // Drawn where it was dropped (its key), not back on its tracked point: no resume yet.
  if (km) {
    const drawn = { x: Number(await knee.getAttribute("cx")), y: Number(await knee.getAttribute("cy")) };
    check(Math.abs(drawn.x - Number(km[1])) < 1e-3 && Math.abs(drawn.y - Number(km[2])) < 1e-3,
      `the saved key is drawn where it was dropped: (${drawn.x}, ${drawn.y}), key (${km[1]}, ${km[2]})`);
  }
  const next = await page.textContent("#keynext");
  check(next.includes("--segment 0"), `the page says what to resume: ${next}`);
  await page.screenshot({ path: shot.replace(/\.png$/, "-key.png"), fullPage: true });

  // The walk's joints are not a person's: Detect is disabled, its tooltip saying why.
  const det = await page.evaluate(() => ({ disabled: document.querySelector("#detect").disabled,
    title: document.querySelector("#detect").title }));
  check(det.disabled && det.title.includes("do not name a person's body"),
    `Detect disabled on the walk, saying why: ${JSON.stringify(det)}`);

  // The page's resume for that segment tracks with the key: the knee sits on it, as a seed.
  await page.click("#resumekey");
  await page.waitForFunction(() => ["ok", "error"].includes(document.querySelector("#message").className)
    && !/^Resuming/.test(document.querySelector("#message").textContent), null, { timeout: 120000 });
  const rmsg = await page.textContent("#message");
  check(rmsg.includes("resumed from segment 000"), `resume with the key answers: ${rmsg}`);
  const row = fs.readFileSync(path.join(work, "r.mocap/tracks.csv"), "utf8").split("\n")
    .map((l) => l.split(",")).find((c) => c[0] === "12" && c[1] === "knee_l");
  check(km && row && Math.abs(Number(row[2]) - Number(km[1])) < 1e-3
    && Math.abs(Number(row[3]) - Number(km[2])) < 1e-3 && row[6] === "seed",
    `after resume, knee_l on frame 12 is on its key as a seed: ${row}`);

  // Detect on a person's run (4 copies of the bundled frame, seeded by `mocap2d seed`): the
  // network's joints appear as moved but unsaved; one adjusted, Save key keys them all.
  fs.mkdirSync(path.join(work, "person"));
  for (let i = 1; i <= 4; i++) {
    fs.copyFileSync(path.join(root, "tests/it/data/pose-frame.png"), path.join(work, `person/000${i}.png`));
  }
  run("seed", "person", "--out", "person.toml");
  run("track", "person", "--seeds", "person.toml", "--out", "p.mocap", "-q");
  let personUrl;
  [detecter, personUrl] = await serve("p.mocap");
  const dp = await browser.newPage({ viewport: { width: 1000, height: 720 } });
  dp.on("pageerror", (e) => check(false, `no script error on the person's page (${e.message})`));
  await dp.goto(`${personUrl}#f2`);
  const nose = dp.locator('#kstage circle.kpoint[data-name="nose"]');
  await nose.waitFor();
  await dp.waitForFunction(() => !document.querySelector("#detect").disabled);
  await dp.click("#detect");
  const busy = await dp.textContent("#detect");
  await dp.waitForFunction(() => ["ok", "error"].includes(document.querySelector("#message").className)
    && !/^Detecting/.test(document.querySelector("#message").textContent), null, { timeout: 60000 });
  const dmsg = await dp.textContent("#message");
  check(dmsg.startsWith("Proposed 17 joints on frame 2"), `Detect answers (button read "${busy}"): ${dmsg}`);
  const proposed = await dp.locator("#kstage circle.kpoint.moved.proposed").count();
  check(proposed === 17 && !(await dp.isDisabled("#savekey")),
    `the proposal is drawn as 17 unsaved moved joints (${proposed}), Save key enabled`);
  check(!fs.existsSync(path.join(work, "p.mocap/keys.toml")), "Detect saved nothing");
  await dp.screenshot({ path: shot.replace(/\.png$/, "-detect.png"), fullPage: true });
  const nb = await settledBox(nose);
  await drag(dp, nb.x + nb.width / 2, nb.y + nb.height / 2, 12, 0);
  await dp.click("#savekey");
  await dp.waitForFunction(() => /Saved keys|Not saved/.test(document.querySelector("#message").textContent));
  const psaved = await dp.textContent("#message");
  const pkeys = fs.existsSync(path.join(work, "p.mocap/keys.toml"))
    ? fs.readFileSync(path.join(work, "p.mocap/keys.toml"), "utf8") : "";
  check(psaved.startsWith("Saved keys.toml (key on frame 2: left_hip") && /^frame = 2$/m.test(pkeys)
    && (pkeys.match(/^[a-z_]+ = \[/gm) || []).length === 17,
  `the adjusted proposal saves as frame 2's key of 17 joints: ${psaved}`);

  // The first seeds of the bare clip: the skeleton's rectangles over frame 20, the head dragged.
  let seedUrl;
  [seeder, seedUrl] = await serve("clip.mp4", "--skeleton", "joints.toml", "--seeds-out", "first.toml");
  const sp = await browser.newPage({ viewport: { width: 1000, height: 720 } });
  sp.on("pageerror", (e) => check(false, `no script error on the seeding page (${e.message})`));
  const asked = [];
  sp.on("dialog", (d) => { asked.push(d.message()); d.accept(); });
  await sp.goto(seedUrl);
  await sp.locator('g.joint[data-name="head"] rect.body').waitFor();
  await sp.fill("#frameno", "20");
  await sp.click("#go");
  await sp.waitForFunction(() => {
    const im = document.querySelector("#stage image");
    return im && im.getAttribute("href").endsWith("/20/frame.png") && im.getBBox().width > 0;
  });
  // , and . step the seeding page back and forward (its arrow keys nudge a rectangle).
  const seedOn = (n) => sp.waitForFunction((n) => {
    const im = document.querySelector("#stage image");
    return im && im.getAttribute("href").endsWith(`/${n}/frame.png`) && im.getBBox().width > 0
      && document.querySelector("#title").textContent === `frame ${n}`;
  }, n, { timeout: 10000 }).then(() => true, () => false);
  await sp.keyboard.press(",");
  check(await seedOn(19), ", steps the seeding page back to frame 19");
  await sp.keyboard.press(".");
  check(await seedOn(20), ". steps the seeding page forward to frame 20");
  const sscale = await sp.evaluate(() => {
    const svg = document.querySelector("#stage");
    return svg.getBoundingClientRect().width / svg.viewBox.baseVal.width;
  });
  const shead = sp.locator('g.joint[data-name="head"] rect.body');
  const sb = await settledBox(shead);
  const [sx, sy] = [Math.round(sb.x + sb.width / 2), Math.round(sb.y + sb.height / 2)];
  await drag(sp, sx, sy, 30, 12);
  const placedText = await sp.textContent("#placed");
  check(placedText.startsWith("1 of 14 joints placed"), `placed count: ${placedText}`);
  await sp.click("#save");
  await sp.waitForFunction(() => /Saved|Not saved/.test(document.querySelector("#message").textContent));
  const smsg = await sp.textContent("#message");
  check(smsg.startsWith("Saved first.toml (seeds on frame 20)"), `seed save reported: ${smsg}`);
  check(asked.length === 1 && asked[0].includes("Not placed yet"), `asked before saving unplaced joints: ${asked}`);
  const first = fs.readFileSync(path.join(work, "first.toml"), "utf8");
  const skel = fs.readFileSync(path.join(work, "joints.toml"), "utf8");
  const [h0, h1] = [joint(skel, "head"), joint(first, "head")];
  const stol = 0.51 / sscale;
  check(/^frame = 20$/m.test(first) && Math.abs(h1.x - h0.x - 30 / sscale) <= stol
    && Math.abs(h1.y - h0.y - 12 / sscale) <= stol && h1.w === h0.w,
    `first.toml: frame 20, head moved by (${(h1.x - h0.x).toFixed(3)}, ${(h1.y - h0.y).toFixed(3)}); dragged (${(30 / sscale).toFixed(3)}, ${(12 / sscale).toFixed(3)})`);
  const k1 = [joint(skel, "knee_l"), joint(first, "knee_l")];
  check(Math.abs(k1[0].x - k1[1].x) < 1e-3 && Math.abs(k1[0].y - k1[1].y) < 1e-3, "an unmoved joint is saved where it was");
  const cmd = await sp.textContent("#seedcmd");
  check(cmd.includes("mocap2d track clip.mp4 --seeds first.toml"), `the page says how to track: ${cmd}`);
  check(tracks("first.toml", "first.mocap"), "the saved seeds are accepted by `mocap2d track --seeds`");
  await sp.screenshot({ path: shot.replace(/\.png$/, "-seeds.png"), fullPage: true });
  await sp.click("#track");
  await sp.waitForFunction(() => ["ok", "error"].includes(document.querySelector("#message").className)
    && !/^Tracking/.test(document.querySelector("#message").textContent), null, { timeout: 120000 });
  const tmsg = await sp.textContent("#message");
  check(tmsg.startsWith("tracked 14 joints over 30 frames") && fs.existsSync(path.join(work, "clip.mocap/tracks.csv")),
    `Track on the page answers: ${tmsg}`);
  const sdet = await sp.evaluate(() => ({ disabled: document.querySelector("#seeddetect").disabled,
    title: document.querySelector("#seeddetect").title }));
  check(sdet.disabled && sdet.title.includes("do not name a person's body"),
    `Detect disabled on the walk's seeding page, saying why: ${JSON.stringify(sdet)}`);

  // The seeding page of the bundled frame, the person's skeleton (from `mocap2d seed`) piled in
  // its top-left corner: d moves the joints onto the person, where `seed` put them, unsaved.
  const pile = fs.readFileSync(path.join(work, "person.toml"), "utf8")
    .replace(/^x = .*$/gm, "x = 20").replace(/^y = .*$/gm, "y = 20");
  fs.writeFileSync(path.join(work, "pile.toml"), pile);
  let pseedUrl;
  [seeder2, pseedUrl] = await serve("person", "--skeleton", "pile.toml", "--seeds-out", "pfirst.toml");
  const pp = await browser.newPage({ viewport: { width: 1000, height: 720 } });
  pp.on("pageerror", (e) => check(false, `no script error on the person's seeding page (${e.message})`));
  await pp.goto(pseedUrl);
  await pp.locator('g.joint[data-name="nose"] rect.body').waitFor();
  await pp.waitForFunction(() => !document.querySelector("#seeddetect").disabled);
  await pp.keyboard.press("d");
  await pp.waitForFunction(() => ["ok", "error"].includes(document.querySelector("#message").className)
    && !/^Detecting/.test(document.querySelector("#message").textContent), null, { timeout: 60000 });
  const pmsg = await pp.textContent("#message");
  check(pmsg.startsWith("Proposed 17 joints on frame 0"), `Detect on the seeding page answers: ${pmsg}`);
  const pnose = await pp.evaluate(() => joints.find((j) => j.name === "nose"));
  const snose = joint(fs.readFileSync(path.join(work, "person.toml"), "utf8"), "nose");
  check(Math.abs(pnose.x - snose.x) < 0.01 && Math.abs(pnose.y - snose.y) < 0.01 && pnose.w === snose.w
    && pnose.placed && !(await pp.isDisabled("#save")),
    `d moved the nose onto the person as seed does: ${JSON.stringify(pnose)} vs ${JSON.stringify(snose)}`);
  check(!fs.existsSync(path.join(work, "pfirst.toml")), "Detect on the seeding page saved nothing");
  await pp.screenshot({ path: shot.replace(/\.png$/, "-seed-detect.png"), fullPage: true });
} finally {
  await browser.close();
  server.kill();
  if (seeder) seeder.kill();
  if (seeder2) seeder2.kill();
  if (detecter) detecter.kill();
  fs.rmSync(work, { recursive: true, force: true });
}
console.log(`browser: ${failures ? 0 : 1} passed, ${failures ? 1 : 0} failed`);
process.exit(failures ? 1 : 0);
