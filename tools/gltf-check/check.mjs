// Checks glTF files the way their users will open them:
//   1. the Khronos glTF-Validator (the reference implementation of the spec):
//      no errors and no warnings;
//   2. three.js's GLTFLoader: one mesh, whose morph targets (one per frame
//      after the first) all have the base mesh's vertex count, and one
//      animation; for a skinned mesh, its skeleton's bone count and clips.
// Usage: node check.mjs FILE.glb|FILE.gltf ...   (exit status 1 on any problem)
// Prints one JSON line per file, so tests and people can read the counts.
import fs from 'node:fs';
import validator from 'gltf-validator';
import { REVISION } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

// three.js reads a .gltf's embedded (data: URI) buffers with fetch and reports
// progress with the browser's ProgressEvent, which node does not have.
globalThis.ProgressEvent ??= class ProgressEvent extends Event {
  constructor(type, init = {}) {
    super(type);
    Object.assign(this, init);
  }
};

async function check(path) {
  const bytes = new Uint8Array(fs.readFileSync(path));
  const problems = [];

  const report = await validator.validateBytes(bytes, { uri: path });
  const issues = report.issues;
  for (const m of issues.messages.filter((m) => m.severity <= 1))  // 0 error, 1 warning
    problems.push(`validator: ${m.code}: ${m.message} ${m.pointer ?? ''}`.trim());

  const loader = new GLTFLoader();
  const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const gltf = await new Promise((resolve, reject) => loader.parse(buffer, '', resolve, reject));
  const meshes = [];
  gltf.scene.traverse((object) => { if (object.isMesh) meshes.push(object); });
  if (meshes.length !== 1) problems.push(`three.js: ${meshes.length} meshes, expected 1`);
  const geometry = meshes[0]?.geometry;
  const vertices = geometry?.attributes.position.count ?? 0;
  const targets = geometry?.morphAttributes.position ?? [];
  targets.forEach((target, t) => {
    if (target.count !== vertices)
      problems.push(`three.js: morph target ${t} has ${target.count} vertices, the mesh ${vertices}`);
  });
  if (targets.length > 0 && gltf.animations.length !== 1)
    problems.push(`three.js: ${gltf.animations.length} animations, expected 1`);

  console.log(JSON.stringify({
    file: path,
    validator: report.validatorVersion,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    three: REVISION,
    vertices,
    triangles: geometry?.index ? geometry.index.count / 3 : 0,
    frames: targets.length + 1,
    duration_s: gltf.animations[0]?.duration ?? 0,
    colors: Boolean(geometry?.attributes.color),
    skinned: Boolean(meshes[0]?.isSkinnedMesh),
    bones: meshes[0]?.skeleton?.bones.length ?? 0,
    clips: gltf.animations.length,
    problems,
  }));
  return problems.length === 0;
}

let ok = process.argv.length > 2;
for (const path of process.argv.slice(2)) {
  try {
    ok = (await check(path)) && ok;
  } catch (error) {
    console.log(JSON.stringify({ file: path, problems: [`could not be read: ${error.message ?? error}`] }));
    ok = false;
  }
}
process.exit(ok ? 0 : 1);
