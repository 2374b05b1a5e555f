// Loads a Spine skeleton JSON (+ its .atlas) with the official runtime (spine-core's
// SkeletonJson and AtlasAttachmentLoader; no textures are needed to pose a skeleton, but every
// atlas page must be an image file found beside the atlas), applies the animation ANIMATION (by
// default the only one) at each given time and prints, as JSON on stdout, every bone's world
// position (origin and tip = its local (length, 0)), its local pose (`local`: x, y, rotation,
// scale x, as the animation set them) and the skin's world vertices at each time,
// and the animation's events (time, name, string) with the event names the skeleton defines.
// Usage: node spine_pose.mjs SKELETON.json SKELETON.atlas T1,T2,... [ANIMATION]
import { existsSync, readFileSync, statSync } from "node:fs";
import { dirname, isAbsolute, join } from "node:path";
import * as spine from "@esotericsoftware/spine-core";

const [skeletonPath, atlasPath, timesArg, animationName] = process.argv.slice(2);
const atlas = new spine.TextureAtlas(readFileSync(atlasPath, "utf8"));
// The pages a renderer would load: relative to the atlas, present, PNG files.
const pages = atlas.pages.map((p) => {
  if (isAbsolute(p.name) || p.name.includes("..")) throw new Error(`atlas page ${p.name} is not inside the atlas's folder`);
  const file = join(dirname(atlasPath), p.name);
  if (!existsSync(file)) throw new Error(`atlas page ${p.name} not found beside ${atlasPath}`);
  const head = readFileSync(file).subarray(0, 8).toString("latin1");
  if (head !== "\x89PNG\r\n\x1a\n") throw new Error(`atlas page ${file} is not a PNG`);
  return { name: p.name, bytes: statSync(file).size };
});
const json = new spine.SkeletonJson(new spine.AtlasAttachmentLoader(atlas));
const data = json.readSkeletonData(readFileSync(skeletonPath, "utf8"));
const skeleton = new spine.Skeleton(data);
let animation;
if (animationName) {
  animation = data.findAnimation(animationName);
  if (animation === null) throw new Error(`no animation ${animationName}`);
} else {
  if (data.animations.length !== 1) throw new Error(`expected one animation, found ${data.animations.length}`);
  animation = data.animations[0];
}
const times = timesArg.split(",").map(Number);

const out = {
  version: data.version,
  fps: data.fps,
  images: data.imagesPath,
  pages,
  animations: data.animations.map((a) => a.name),
  animation: animation.name,
  duration: animation.duration,
  bones: data.bones.map((b) => ({ name: b.name, parent: b.parent ? b.parent.name : null, x: [], y: [], tipX: [], tipY: [], local: [] })),
  slots: [],
  vertices: [],
};
for (const t of times) {
  skeleton.setToSetupPose();
  animation.apply(skeleton, t, t, false, [], 1, spine.MixBlend.setup, spine.MixDirection.mixIn);
  skeleton.updateWorldTransform(spine.Physics.none);
  skeleton.bones.forEach((bone, i) => {
    const tip = bone.localToWorld(new spine.Vector2(bone.data.length, 0));
    out.bones[i].x.push(bone.worldX);
    out.bones[i].y.push(bone.worldY);
    out.bones[i].tipX.push(tip.x);
    out.bones[i].tipY.push(tip.y);
    out.bones[i].local.push([bone.x, bone.y, bone.rotation, bone.scaleX]);
  });
  const frame = [];
  for (const slot of skeleton.slots) {
    const a = slot.getAttachment();
    if (a instanceof spine.MeshAttachment) {
      const world = new Array(a.worldVerticesLength).fill(0);
      a.computeWorldVertices(slot, 0, a.worldVerticesLength, world, 0, 2);
      frame.push(world);
    }
  }
  out.vertices.push(frame);
}
for (const slot of skeleton.slots) {
  const a = slot.getAttachment();
  out.slots.push({
    name: slot.data.name,
    bone: slot.bone.data.name,
    attachment: a ? a.name : null,
    type: a ? a.constructor.name : null,
    weighted: a instanceof spine.VertexAttachment ? a.bones !== null : null,
    vertices: a instanceof spine.VertexAttachment ? a.worldVerticesLength / 2 : 0,
    triangles: a instanceof spine.MeshAttachment ? a.triangles.length / 3 : 0,
    region: a && a.region ? a.region.name : null,
  });
}
out.eventNames = data.events.map((e) => e.name);
out.events = animation.timelines
  .filter((t) => t instanceof spine.EventTimeline)
  .flatMap((t) => t.events.map((e) => ({ time: e.time, name: e.data.name, string: e.stringValue })));
process.stdout.write(JSON.stringify(out));
