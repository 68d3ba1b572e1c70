// Reads the GLBs of a sylva dataset built with [outputs] leaf_instances = true (the leaves as
// GPU instances, EXT_mesh_gpu_instancing) with readers sylva did not write, and compares each
// with the plain GLB of the same tree from the same spec built without it; fails (exit 1) on
// any difference beyond the stated tolerance:
//   - the Khronos glTF validator: 0 errors and 0 warnings; its infos only that it cannot look
//     inside EXT_mesh_gpu_instancing or EXT_meshopt_compression (UNSUPPORTED_EXTENSION), so
//     that the instances' accessors (and buffer 0 of a compressed file) look unused to it, and
//     the untextured TEXCOORD_0 (as check_meshes.mjs allows);
//   - three.js's GLTFLoader (with its MeshoptDecoder for a compressed file) makes an
//     InstancedMesh per leaf group; drawn through each instance's matrix, every leaf's
//     vertices (found by the instance's _LEAF, the leaf's index in the tree) are the plain
//     file's vertices of that leaf, in the same order: positions within 2e-5 m (float
//     rounding), or 1 mm compressed (the filters' error: translations ≈ 0.25 mm on a 30 m
//     tree, rotations ≈ 0.03°); normals within 1e-4 (compressed 0.01); UVs equal (compressed
//     1/131070); vertex colours × the instance's colour (the leaf's lightness) equal the plain
//     file's COLOR_0 within 1e-5 (compressed 0.004); each leaf's triangles the plain leaf's;
//   - every leaf drawn exactly once; the wood the same vertex count; the file smaller (but
//     for a tree without leaves, a plot's the leaf area thinned bare).
//
// Usage: node tests/js/check_instances.mjs INSTANCED_DATASET_DIR PLAIN_DATASET_DIR
import { createRequire } from 'node:module';
import { Matrix3, Matrix4, Vector3 } from 'three';
import {
    decodeImagesWithPng,
    exitIfFailed,
    glbJson,
    pairedFiles,
    parseGlb,
    triangleKey,
} from './gltf_node.mjs';

const validator = createRequire(import.meta.url)('gltf-validator');

const [instRoot, plainRoot] = process.argv.slice(2);
if (!instRoot || !plainRoot) {
    console.error('usage: node check_instances.mjs INSTANCED_DATASET_DIR PLAIN_DATASET_DIR');
    process.exit(2);
}

const failures = [];
const fail = (file, what) => failures.push(`${file}: ${what}`);
decodeImagesWithPng();

async function load(bytes) {
    const meshes = [];
    (await parseGlb(bytes, true)).scene.traverse((o) => { if (o.isMesh) meshes.push(o); });
    return meshes;
}

let files = 0, leavesChecked = 0, bytesPlain = 0, bytesInst = 0;
for (const { rel, packed: inst, plain } of pairedFiles(instRoot, plainRoot, (n) => n === 'mesh.glb', fail)) {
    ++files;
    bytesInst += inst.length;
    bytesPlain += plain.length;
    const doc = glbJson(inst);
    const compressed = (doc.extensionsUsed ?? []).includes('EXT_meshopt_compression');
    // A tree without leaves (a plot's tree the leaf area thinned bare) has nothing to instance.
    const leafless = !(glbJson(plain).meshes ?? []).some((m) => m.name === 'leaves');
    if (!leafless && inst.length >= plain.length) {
        fail(rel, `not smaller: ${inst.length} ≥ ${plain.length}`);
    }
    if (!leafless && !(doc.extensionsRequired ?? []).includes('EXT_mesh_gpu_instancing')) {
        fail(rel, 'EXT_mesh_gpu_instancing not required');
    }
    const instanceAccessors = new Set();
    for (const node of doc.nodes ?? []) {
        const ext = node.extensions?.EXT_mesh_gpu_instancing;
        if (ext) for (const a of Object.values(ext.attributes)) instanceAccessors.add(a);
    }

    const report = await validator.validateBytes(inst, { uri: rel, maxIssues: 0 });
    for (const m of report.issues.messages) {
        const accessor = /^\/accessors\/(\d+)$/.exec(m.pointer ?? '');
        const allowed = m.severity >= 2 &&
            ((m.code === 'UNSUPPORTED_EXTENSION' &&
              /EXT_mesh_gpu_instancing|EXT_meshopt_compression/.test(m.message)) ||
             (m.code === 'UNUSED_OBJECT' && accessor && instanceAccessors.has(+accessor[1])) ||
             (m.code === 'UNUSED_OBJECT' && compressed && m.pointer === '/buffers/0') ||
             (m.code === 'UNUSED_OBJECT' && /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? '')));
        if (m.severity <= 1 || ((m.code === 'UNUSED_OBJECT' || m.code === 'UNSUPPORTED_EXTENSION') &&
                                !allowed)) {
            fail(rel, `validator ${['error', 'warning', 'info', 'hint'][m.severity]} ` +
                      `${m.code} at ${m.pointer ?? ''}: ${m.message}`);
        }
    }

    const a = await load(inst), b = await load(plain);
    const plainLeaves = b.find((m) => m.name === 'leaves');
    const plainWood = b.find((m) => m.name === 'wood');
    const wood = a.find((m) => m.name === 'wood' && !m.isInstancedMesh);
    if (!!wood !== !!plainWood ||
        (wood && wood.geometry.getAttribute('position').count !==
                 plainWood.geometry.getAttribute('position').count)) {
        fail(rel, 'the wood differs from the plain file\'s');
    }
    const groups = a.filter((m) => m.isInstancedMesh);
    if (!plainLeaves) {
        if (groups.length) fail(rel, 'instances where the plain file has no leaves');
        continue;
    }
    // Leaf index → (group, instance).
    const drawnBy = new Map();
    for (const g of groups) {
        const ids = g.geometry.getAttribute('_LEAF');
        if (!ids || ids.count !== g.count) {
            fail(rel, `${g.name}: no _LEAF per instance`);
            continue;
        }
        for (let i = 0; i < g.count; ++i) {
            const leaf = ids.getX(i);
            if (drawnBy.has(leaf)) fail(rel, `leaf ${leaf} drawn twice`);
            drawnBy.set(leaf, [g, i]);
        }
    }
    const leafCount = drawnBy.size;
    for (let k = 0; k < leafCount; ++k) {
        if (!drawnBy.has(k)) {
            fail(rel, `leaf ${k} of ${leafCount} not drawn`);
            break;
        }
    }
    const P = plainLeaves.geometry;
    const pPos = P.getAttribute('position'), pN = P.getAttribute('normal');
    const pUv = P.getAttribute('uv'), pCol = P.getAttribute('color'), pIdx = P.getIndex();
    const tolP = compressed ? 1e-3 : 2e-5, tolN = compressed ? 0.01 : 1e-4;
    const tolUv = compressed ? 0.5 / 65535 + 1e-7 : 0, tolC = compressed ? 0.004 : 1e-5;
    let worstP = 0, worstN = 0, worstUv = 0, worstC = 0;
    let v0 = 0, t0 = 0;
    const m = new Matrix4(), nm = new Matrix3(), p = new Vector3(), n = new Vector3();
    for (let leaf = 0; leaf < leafCount && failures.length < 40; ++leaf) {
        const [g, i] = drawnBy.get(leaf);
        const G = g.geometry;
        const gPos = G.getAttribute('position'), gN = G.getAttribute('normal');
        const gUv = G.getAttribute('uv'), gCol = G.getAttribute('color'), gIdx = G.getIndex();
        g.getMatrixAt(i, m);
        m.premultiply(g.matrixWorld);
        nm.getNormalMatrix(m);
        const count = gPos.count;
        if (v0 + count > pPos.count) {
            fail(rel, `the instances draw more leaf vertices than the plain file's ${pPos.count}`);
            break;
        }
        if (!!gCol !== !!pCol || !!g.instanceColor !== !!pCol) {
            fail(rel, 'vertex or instance colours in one file only');
        }
        const light = g.instanceColor ? g.instanceColor.getX(i) : 1;
        for (let v = 0; v < count; ++v) {
            p.fromBufferAttribute(gPos, v).applyMatrix4(m);
            n.fromBufferAttribute(gN, v).applyMatrix3(nm).normalize();
            for (let c = 0; c < 3; ++c) {
                worstP = Math.max(worstP, Math.abs(p.getComponent(c) - pPos.getComponent(v0 + v, c)));
                worstN = Math.max(worstN, Math.abs(n.getComponent(c) - pN.getComponent(v0 + v, c)));
                if (gCol) {
                    const colour = Math.min(1, gCol.getComponent(v, c) * light);
                    worstC = Math.max(worstC, Math.abs(colour - pCol.getComponent(v0 + v, c)));
                }
            }
            for (let c = 0; c < 2; ++c) {
                worstUv = Math.max(worstUv, Math.abs(gUv.getComponent(v, c) - pUv.getComponent(v0 + v, c)));
            }
        }
        const tris = gIdx.count / 3;
        for (let t = 0; t < tris; ++t) {
            const mine = triangleKey([0, 1, 2].map((c) => gIdx.getX(3 * t + c) + v0));
            const theirs = triangleKey([0, 1, 2].map((c) => pIdx.getX(3 * (t0 + t) + c)));
            if (mine !== theirs) {
                fail(rel, `leaf ${leaf}: triangle ${t} ${mine} vs the plain file's ${theirs}`);
                break;
            }
        }
        v0 += count;
        t0 += tris;
        ++leavesChecked;
    }
    if (v0 !== pPos.count) fail(rel, `the instances draw ${v0} leaf vertices, the plain file has ${pPos.count}`);
    if (worstP > tolP) fail(rel, `a leaf vertex ${worstP} m off (tolerance ${tolP})`);
    if (worstN > tolN) fail(rel, `a leaf normal ${worstN} off`);
    if (worstUv > tolUv) fail(rel, `a leaf UV ${worstUv} off`);
    if (worstC > tolC) fail(rel, `a leaf colour ${worstC} off`);
    console.log(`${rel}: ${groups.length} leaf group(s), ${leafCount} leaves; worst position ` +
                `${worstP.toExponential(2)} m, normal ${worstN.toExponential(2)}, colour ` +
                `${worstC.toExponential(2)}; ${inst.length} bytes vs ${plain.length}`);
}
if (files === 0) fail(instRoot, 'no mesh.glb');
exitIfFailed('check_instances', failures, files);
console.log(`check_instances: ${files} GLB files, ${leavesChecked} leaves, ${bytesInst} bytes ` +
            `instanced vs ${bytesPlain} plain (${(bytesInst / bytesPlain).toFixed(3)}×)`);
