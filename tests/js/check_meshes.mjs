// Reads every mesh, skeleton and point-cloud file of a built sylva dataset with readers sylva
// did not write, and fails (exit 1) on the first class of problem it finds:
//   - GLB (mesh.glb, watertight.glb): the Khronos glTF validator (npm gltf-validator) reports
//     0 errors, 0 warnings and no unused object (UNUSED_OBJECT, an info-level issue: so no
//     unused material) but the untextured TEXCOORD_0;
//   - OBJ + MTL (mesh.obj, watertight.obj): three.js's OBJLoader and MTLLoader; the OBJ names
//     the MTL recorded in the manifest (`mtllib`), every material a face uses is defined there,
//     every material defined is used, each Kd equals the base colour of the GLB's material of
//     the same name, and the OBJ's triangles equal the manifest's `mesh_triangles`;
//   - PLY (mesh.ply, watertight.ply, skeleton.ply, points.ply): the header carries the comment
//     "units: metres; up axis: +y", and three.js's PLYLoader reads the vertices (mesh.ply's
//     count equals the manifest's `mesh_vertices`, skeleton.ply's equals `nodes`).
//
// Usage: node tests/js/check_meshes.mjs DATASET_DIR   (tests/js/README.md)
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { MTLLoader } from 'three/addons/loaders/MTLLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';

const validator = createRequire(import.meta.url)('gltf-validator');

const root = process.argv[2];
if (!root) {
    console.error('usage: node check_meshes.mjs DATASET_DIR');
    process.exit(2);
}

const failures = [];
const fail = (file, what) => failures.push(`${file}: ${what}`);
const counts = { glb: 0, obj: 0, ply: 0 };

// The JSON chunk of a GLB (glTF 2.0 §4.4: 12-byte header, then chunk length, type, data).
function glbJson(bytes) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const length = view.getUint32(12, true);
    return JSON.parse(new TextDecoder().decode(bytes.subarray(20, 20 + length)));
}

async function checkGlb(rel) {
    const bytes = new Uint8Array(fs.readFileSync(path.join(root, rel)));
    const report = await validator.validateBytes(bytes, { uri: rel, maxIssues: 0 });
    const issues = report.issues;
    for (const m of issues.messages) {
        // Severity: 0 error, 1 warning, 2 info, 3 hint.
        // TEXCOORD_0 is "unused" only because no material has a texture: the bark and leaf
        // UVs are an output of their own (docs/outputs.md), kept for users who texture.
        const uvs = /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? '');
        if (m.severity <= 1 || (m.code === 'UNUSED_OBJECT' && !uvs)) {
            fail(rel, `validator ${['error', 'warning', 'info', 'hint'][m.severity]} ` +
                      `${m.code} at ${m.pointer ?? ''}: ${m.message}`);
        }
    }
    if (issues.numErrors !== 0) fail(rel, `${issues.numErrors} validator errors`);
    ++counts.glb;
    return glbJson(bytes);
}

function checkObj(rel, mtlRel, glb, triangles) {
    const objText = fs.readFileSync(path.join(root, rel), 'utf8');
    const group = new OBJLoader().parse(objText);
    const expectedLib = path.basename(mtlRel);
    if (JSON.stringify(group.materialLibraries) !== JSON.stringify([expectedLib])) {
        fail(rel, `mtllib ${JSON.stringify(group.materialLibraries)}, expected [${expectedLib}]`);
    }
    if (path.dirname(mtlRel) !== path.dirname(rel)) fail(rel, `${mtlRel} is not beside it`);
    const creator = new MTLLoader().parse(fs.readFileSync(path.join(root, mtlRel), 'utf8'), '');
    const defined = creator.materialsInfo;  // name -> {kd: [r, g, b], ...} as written
    const used = new Set();
    let tris = 0;
    group.traverse((o) => {
        if (!o.isMesh) return;
        tris += o.geometry.getAttribute('position').count / 3;
        for (const m of [].concat(o.material)) used.add(m.name);
    });
    for (const name of used) {
        if (!(name in defined)) fail(rel, `material "${name}" is used but not defined in ${mtlRel}`);
    }
    for (const name of Object.keys(defined)) {
        if (!used.has(name)) fail(mtlRel, `material "${name}" is defined but never used`);
        const g = (glb.materials ?? []).find((m) => m.name === name);
        if (!g) {
            fail(mtlRel, `material "${name}" is not in the GLB`);
            continue;
        }
        const kd = defined[name].kd;
        const base = g.pbrMetallicRoughness.baseColorFactor;
        if (!kd || kd.length !== 3 || kd.some((v, c) => v !== base[c])) {
            fail(mtlRel, `"${name}" Kd ${JSON.stringify(kd)}, the GLB's base colour ${base}`);
        }
        // three.js builds the material it would draw with (Phong, colour from Kd).
        if (!creator.create(name).color) fail(mtlRel, `three.js made no colour for "${name}"`);
    }
    if (triangles !== undefined && tris !== triangles) {
        fail(rel, `${tris} triangles read, the manifest says ${triangles}`);
    }
    ++counts.obj;
}

function checkPly(rel, vertices) {
    const bytes = fs.readFileSync(path.join(root, rel));
    const end = bytes.indexOf('end_header\n');
    const header = bytes.subarray(0, end).toString('latin1').split('\n');
    if (!header.includes('comment units: metres; up axis: +y')) {
        fail(rel, `no "comment units: metres; up axis: +y" in the header ${JSON.stringify(header)}`);
    }
    const ab = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
    const geometry = new PLYLoader().parse(ab);
    const n = geometry.getAttribute('position').count;
    if (vertices !== undefined ? n !== vertices : n === 0) {
        fail(rel, `PLYLoader read ${n} vertices, expected ${vertices ?? 'some'}`);
    }
    ++counts.ply;
}

const records = fs.readFileSync(path.join(root, 'manifest.jsonl'), 'utf8')
    .split('\n').filter((l) => l.trim()).map((l) => JSON.parse(l));
for (const r of records) {
    const f = r.files;
    for (const stem of ['mesh', 'watertight']) {
        const glb = f[`${stem}_glb`] ? await checkGlb(f[`${stem}_glb`]) : null;
        if (f[`${stem}_obj`]) {
            if (!f[`${stem}_mtl`]) {
                fail(f[`${stem}_obj`], `the manifest has no ${stem}_mtl`);
            } else if (!glb) {
                fail(f[`${stem}_obj`], `no ${stem}_glb to compare the materials with`);
            } else {
                checkObj(f[`${stem}_obj`], f[`${stem}_mtl`], glb,
                         stem === 'mesh' ? r.stats.mesh_triangles : undefined);
            }
        }
        if (f[`${stem}_ply`]) {
            checkPly(f[`${stem}_ply`], stem === 'mesh' ? r.stats.mesh_vertices : undefined);
        }
    }
    if (f.skeleton_ply) checkPly(f.skeleton_ply, r.stats.nodes);
    if (f.points_ply) checkPly(f.points_ply);
}

if (counts.glb === 0 || counts.obj === 0 || counts.ply === 0) {
    fail(root, `nothing to check of some format: ${JSON.stringify(counts)}`);
}
if (failures.length) {
    console.error(failures.slice(0, 40).join('\n'));
    console.error(`check_meshes: ${failures.length} problems in ${records.length} instances`);
    process.exit(1);
}
console.log(`check_meshes: ${records.length} instances; ${counts.glb} GLB valid (0 errors, 0 ` +
            `warnings, no unused material), ${counts.obj} OBJ with every material in its MTL, ` +
            `${counts.ply} PLY with units and up axis`);
