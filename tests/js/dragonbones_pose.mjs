// Loads a DragonBones JSON with the DragonBones runtime's core (@cocos/dragonbones-js: the
// ObjectDataParser, BaseFactory, Armature and its animation, with no renderer: the factory below
// builds armatures and slots that display nothing), plays the first animation to each given time
// and prints, as JSON on the last line of stdout (the runtime prints a banner first), every bone's world position (origin and tip = its local
// (length, 0)) and its animation values (`local`: x, y, rotation in degrees, scale x) at each time. With TEX.json, the texture atlas is parsed too (its image must be a
// PNG beside it), every mesh display must find its texture in it, and each mesh's world vertices
// at each time are printed (weighted meshes deformed as the runtime's renderers do it). Last, the
// animation is played once through, frame by frame, and the frame events it fires are printed
// (name, time, strings).
// Usage: node dragonbones_pose.mjs SKE.json T1,T2,... [TEX.json]
import { existsSync, readFileSync } from "node:fs";
import { dirname, isAbsolute, join } from "node:path";
import * as db from "@cocos/dragonbones-js";

const [path, timesArg, texPath] = process.argv.slice(2);

// An event dispatcher that dispatches nothing.
class Events {
  hasDBEventListener() { return false; }
  dispatchDBEvent() {}
  addDBEventListener() {}
  removeDBEventListener() {}
}
// The armature's display: none, only the proxy interface.
class Proxy extends Events {
  dbInit(armature) { this.armature = armature; }
  dbClear() { this.armature = null; }
  dbUpdate() {}
  dispose() {}
  get animation() { return this.armature.animation; }
}
// A slot that draws nothing.
class NullSlot extends db.Slot {
  static toString() { return "[class NullSlot]"; }
  _onClear() { super._onClear(); }
  _initDisplay() {}
  _disposeDisplay() {}
  _onUpdateDisplay() {}
  _addDisplay() {}
  _replaceDisplay() {}
  _removeDisplay() {}
  _updateZOrder() {}
  _updateVisible() {}
  _updateBlendMode() {}
  _updateColor() {}
  _updateFrame() {}
  _updateMesh() {}
  _updateGlueMesh() {}
  _updateTransform() {}
  _identityTransform() {}
}
// Texture data without an image loaded.
class NullTexture extends db.TextureData {
  static toString() { return "[class NullTexture]"; }
}
// A texture atlas without images.
class NullAtlas extends db.TextureAtlasData {
  static toString() { return "[class NullAtlas]"; }
  createTexture() { return db.BaseObject.borrowObject(NullTexture); }
}
class NullFactory extends db.BaseFactory {
  constructor() {
    super(null);
    this._dragonBones = new db.DragonBones(new Events());
  }
  // parseDragonBonesData asks for one to hold atlases embedded in the data (there are none).
  _buildTextureAtlasData() { return db.BaseObject.borrowObject(NullAtlas); }
  _buildArmature(dataPackage) {
    const armature = db.BaseObject.borrowObject(db.Armature);
    const proxy = new Proxy();
    armature.init(dataPackage.armature, proxy, proxy, this._dragonBones);
    return armature;
  }
  _buildSlot(dataPackage, slotData, armature) {
    const slot = db.BaseObject.borrowObject(NullSlot);
    slot.init(slotData, armature, null, null);
    return slot;
  }
}

const raw = JSON.parse(readFileSync(path, "utf8"));
const factory = new NullFactory();
let texture = null;
if (texPath) {
  const rawTex = JSON.parse(readFileSync(texPath, "utf8"));
  const image = rawTex.imagePath;
  if (isAbsolute(image) || image.includes("..")) throw new Error(`imagePath ${image} is not inside the atlas's folder`);
  const file = join(dirname(texPath), image);
  if (!existsSync(file)) throw new Error(`imagePath ${image} not found beside ${texPath}`);
  if (readFileSync(file).subarray(0, 8).toString("latin1") !== "\x89PNG\r\n\x1a\n") throw new Error(`${file} is not a PNG`);
  // Under the name the skeleton data is parsed with below, as an engine loads a pair.
  const atlas = factory.parseTextureAtlasData(rawTex, null, "export");
  texture = { name: atlas.name, imagePath: atlas.imagePath, regions: Object.keys(atlas.textures) };
}
const data = factory.parseDragonBonesData(raw, "export");
if (data === null) throw new Error("the DragonBones parser rejected the file");
const armatureName = data.armatureNames[0];
const armature = factory.buildArmature(armatureName, "export");
if (armature === null) throw new Error(`cannot build armature ${armatureName}`);
const animationNames = armature.animation.animationNames;
if (animationNames.length !== 1) throw new Error(`expected one animation, found ${animationNames.length}`);
const name = animationNames[0];
const times = timesArg.split(",").map(Number);
const bones = armature.getBones();
// Mesh displays: each must have found its texture (when an atlas was given).
const meshes = [];
for (const slot of armature.getSlots()) {
  const displays = armature.armatureData.defaultSkin.getDisplays(slot.name) || [];
  for (const d of displays) {
    if (d.type !== 2 /* Mesh */) continue;
    if (texPath && d.texture === null) throw new Error(`mesh ${d.name} of slot ${slot.name}: texture ${d.path} not found in the atlas`);
    meshes.push({ slot: slot.name, name: d.name, texture: d.texture ? d.texture.name : null, data: d });
  }
}
// World vertices of a weighted mesh, as the renderers' Slot._updateMesh computes them.
function meshVertices(d) {
  const v = d.vertices;
  const data = v.data;
  const ints = data.intArray;
  const floats = data.floatArray;
  const count = ints[v.offset + 0];
  const weight = v.weight;
  if (weight === null) throw new Error(`mesh ${d.name} is not weighted`);
  const meshBones = weight.bones.map((b) => armature.getBone(b.name));
  const out = [];
  let iB = weight.offset + 2 + weight.bones.length;
  let iV = ints[weight.offset + 1];
  for (let i = 0; i < count; ++i) {
    const n = ints[iB++];
    let x = 0, y = 0;
    for (let j = 0; j < n; ++j) {
      const m = meshBones[ints[iB++]].globalTransformMatrix;
      const w = floats[iV++];
      const xL = floats[iV++];
      const yL = floats[iV++];
      x += (m.a * xL + m.c * yL + m.tx) * w;
      y += (m.b * xL + m.d * yL + m.ty) * w;
    }
    out.push(x, y);
  }
  return out;
}
// Poses every bone at each time, with the runtime's y axis down (DragonBones' own data axes, as
// upstream DragonBonesJS, Egret and Pixi run) or up (this Cocos fork's default, which flips y).
function pose(yDown) {
  db.DragonBones.yDown = yDown;
  const result = bones.map((b) => ({ name: b.name, parent: b.parent ? b.parent.name : null, x: [], y: [], tipX: [], tipY: [], local: [] }));
  const vertices = meshes.map(() => []);
  for (const t of times) {
    armature.animation.gotoAndStopByTime(name, t);
    armature.advanceTime(0);
    bones.forEach((bone, i) => {
      bone.invalidUpdate();
    });
    armature.advanceTime(0);
    bones.forEach((bone, i) => {
      const m = bone.globalTransformMatrix;
      const len = bone.boneData.length;
      result[i].x.push(m.tx);
      result[i].y.push(m.ty);
      result[i].tipX.push(m.a * len + m.tx);
      result[i].tipY.push(m.b * len + m.ty);
      // The animation's own values on the bone (relative to its setup): x, y, rotation in
      // degrees, scale x.
      const a = bone.animationPose;
      result[i].local.push([a.x, a.y, a.rotation * 180 / Math.PI, a.scaleX]);
    });
    meshes.forEach((mesh, k) => vertices[k].push(meshVertices(mesh.data)));
  }
  return { bones: result, vertices };
}
const out = {
  version: data.version,
  frameRate: data.frameRate,
  armature: armatureName,
  animation: name,
  duration: armature.animation.animations[name].duration,
  slots: armature.getSlots().map((s) => s.name),
  texture,
  meshes: meshes.map((m) => ({ slot: m.slot, name: m.name, texture: m.texture })),
  yDownDefault: db.DragonBones.yDown,
};
const down = pose(true);
const up = pose(false);
out.bonesYDown = down.bones;
out.bonesYUp = up.bones;
out.verticesYDown = down.vertices;
out.verticesYUp = up.vertices;
// Played once from the start, a frame at a time: the frame events the runtime fires.
const fired = [];
const dispatcher = armature.eventDispatcher;
dispatcher.hasDBEventListener = (type) => type === db.EventObject.FRAME_EVENT;
dispatcher.dispatchDBEvent = (type, e) => {
  if (type === db.EventObject.FRAME_EVENT) fired.push({ name: e.name, time: e.time, strings: e.data ? Array.from(e.data.strings) : [] });
};
// As an engine runs it: the armature on the world clock, whose advanceTime dispatches the events
// the animation buffered.
factory.clock.add(armature);
armature.animation.play(name, 1);
const steps = Math.ceil(out.duration * data.frameRate) + 2;
for (let i = 0; i < steps; i++) factory._dragonBones.advanceTime(1 / data.frameRate);
out.events = fired;
process.stdout.write("\n" + JSON.stringify(out) + "\n");
