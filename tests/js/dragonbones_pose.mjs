// Loads a DragonBones JSON with the DragonBones runtime's core (@cocos/dragonbones-js: the
// ObjectDataParser, BaseFactory, Armature and its animation, with no renderer: the factory below
// builds armatures and slots that display nothing), plays the first animation to each given time
// and prints, as JSON on the last line of stdout (the runtime prints a banner first), every bone's world position (origin and tip = its local
// (length, 0)) at each time.
// Usage: node dragonbones_pose.mjs SKE.json T1,T2,...
import { readFileSync } from "node:fs";
import * as db from "@cocos/dragonbones-js";

const [path, timesArg] = process.argv.slice(2);

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
// A texture atlas without textures.
class NullAtlas extends db.TextureAtlasData {
  static toString() { return "[class NullAtlas]"; }
  createTexture() { throw new Error("no texture expected"); }
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
// Poses every bone at each time, with the runtime's y axis down (DragonBones' own data axes, as
// upstream DragonBonesJS, Egret and Pixi run) or up (this Cocos fork's default, which flips y).
function pose(yDown) {
  db.DragonBones.yDown = yDown;
  const result = bones.map((b) => ({ name: b.name, parent: b.parent ? b.parent.name : null, x: [], y: [], tipX: [], tipY: [] }));
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
    });
  }
  return result;
}
const out = {
  version: data.version,
  frameRate: data.frameRate,
  armature: armatureName,
  animation: name,
  duration: armature.animation.animations[name].duration,
  slots: armature.getSlots().map((s) => s.name),
  yDownDefault: db.DragonBones.yDown,
  bonesYDown: pose(true),
  bonesYUp: pose(false),
};
process.stdout.write("\n" + JSON.stringify(out) + "\n");
