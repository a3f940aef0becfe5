// Checks glTF files the way their users will open them:
//   1. the Khronos glTF-Validator (the reference implementation of the spec):
//      no errors and no warnings;
//   2. three.js's GLTFLoader: one mesh, whose morph targets (one per frame
//      after the first) all have the base mesh's vertex count, and one
//      animation; for a skinned mesh, its skeleton's bone count and clips.
//      A file with KHR_gaussian_splatting has one POINTS primitive instead: its
//      point count is reported; the validator (2.0.0-dev.3.10) predates the
//      extension and reports its colon-prefixed attribute semantics
//      (KHR_gaussian_splatting:SCALE, ...) as invalid names and the extension
//      as unsupported, which are not counted as problems; anything else is.
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
  const splatSemantic = (m) =>
    m.code === 'MESH_PRIMITIVE_INVALID_ATTRIBUTE' && /\/attributes\/KHR_gaussian_splatting:/.test(m.pointer ?? '');
  const counted = issues.messages.filter((m) => m.severity <= 1 && !splatSemantic(m));  // 0 error, 1 warning
  for (const m of counted) problems.push(`validator: ${m.code}: ${m.message} ${m.pointer ?? ''}`.trim());

  const loader = new GLTFLoader();
  const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const gltf = await new Promise((resolve, reject) => loader.parse(buffer, '', resolve, reject));
  const meshes = [], points = [];
  gltf.scene.traverse((object) => {
    if (object.isMesh) meshes.push(object);
    if (object.isPoints) points.push(object);
  });
  const splats = (gltf.parser.json.extensionsUsed ?? []).includes('KHR_gaussian_splatting');
  if (splats ? points.length !== 1 || meshes.length !== 0 : meshes.length !== 1)
    problems.push(`three.js: ${meshes.length} meshes and ${points.length} point sets, expected ${splats ? 'one point set' : '1 mesh'}`);
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
    errors: counted.filter((m) => m.severity === 0).length,
    warnings: counted.filter((m) => m.severity === 1).length,
    three: REVISION,
    vertices,
    triangles: geometry?.index ? geometry.index.count / 3 : 0,
    frames: targets.length + 1,
    duration_s: gltf.animations[0]?.duration ?? 0,
    colors: Boolean(geometry?.attributes.color),
    skinned: Boolean(meshes[0]?.isSkinnedMesh),
    bones: meshes[0]?.skeleton?.bones.length ?? 0,
    clips: gltf.animations.length,
    points: points[0]?.geometry.attributes.position.count ?? 0,
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
