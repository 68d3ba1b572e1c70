// Reads the compressed GLBs of a sylva dataset built with [outputs] mesh_compression =
// "meshopt" with readers sylva did not write, and compares each with the plain GLB of the same
// tree from the same spec built without it; fails (exit 1) on any difference beyond the stated
// quantisation:
//   - the Khronos glTF validator: 0 errors and 0 warnings; its infos only that it cannot look
//     inside EXT_meshopt_compression (UNSUPPORTED_EXTENSION; so buffer 0, the compressed bytes,
//     looks unused to it) and the untextured TEXCOORD_0 (as check_meshes.mjs allows);
//     KHR_mesh_quantization it does check (the positions' and normals' component types);
//   - three.js's GLTFLoader with three's MeshoptDecoder (its WebAssembly decoder): per node of
//     the same name, the positions through the node's transform lie within the stated error of
//     the plain file's (half the grid step: the node's scale / 2, a bound the file itself gives),
//     the normals within 1/127 per component, vertex colours within 1/510 and [0, 1] UVs
//     within 1/131070 (quantised), other UVs and the _ORDER / _COLOUR attributes equal, and the triangles the same in the same order (each possibly rotated,
//     its winding kept);
//   - the compressed file is smaller than the plain one; the sizes are printed.
//
// Usage: node tests/js/check_meshopt.mjs COMPRESSED_DATASET_DIR PLAIN_DATASET_DIR
import { createRequire } from 'node:module';
import {
    decodeImagesWithPng,
    exitIfFailed,
    pairedFiles,
    parseGlb,
    triangleKey,
} from './gltf_node.mjs';

const validator = createRequire(import.meta.url)('gltf-validator');

const [packedRoot, plainRoot] = process.argv.slice(2);
if (!packedRoot || !plainRoot) {
    console.error('usage: node check_meshopt.mjs COMPRESSED_DATASET_DIR PLAIN_DATASET_DIR');
    process.exit(2);
}

const failures = [];
const fail = (file, what) => failures.push(`${file}: ${what}`);
decodeImagesWithPng();

async function load(bytes, decoder) {
    const gltf = await parseGlb(bytes, decoder);
    const meshes = new Map();
    gltf.scene.traverse((o) => { if (o.isMesh) meshes.set(o.name, o); });
    return meshes;
}

// Triangle t of an index attribute, as triangleKey makes it.
function triangle(index, t) {
    return triangleKey([index.getX(3 * t), index.getX(3 * t + 1), index.getX(3 * t + 2)]);
}

let files = 0, bytesPlain = 0, bytesPacked = 0;
for (const { rel, packed, plain } of pairedFiles(packedRoot, plainRoot, (n) => n.endsWith('.glb'), fail)) {
    ++files;
    bytesPacked += packed.length;
    bytesPlain += plain.length;
    if (packed.length >= plain.length) fail(rel, `not smaller: ${packed.length} ≥ ${plain.length}`);

    const report = await validator.validateBytes(packed, { uri: rel, maxIssues: 0 });
    for (const m of report.issues.messages) {
        const allowed = m.severity >= 2 &&
            ((m.code === 'UNSUPPORTED_EXTENSION' && /EXT_meshopt_compression/.test(m.message)) ||
             (m.code === 'UNUSED_OBJECT' && m.pointer === '/buffers/0') ||
             (m.code === 'UNUSED_OBJECT' && /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? '')));
        if (m.severity <= 1 || (m.code === 'UNUSED_OBJECT' && !allowed) ||
            (m.code === 'UNSUPPORTED_EXTENSION' && !allowed)) {
            fail(rel, `validator ${['error', 'warning', 'info', 'hint'][m.severity]} ` +
                      `${m.code} at ${m.pointer ?? ''}: ${m.message}`);
        }
    }

    const a = await load(packed, true), b = await load(plain, false);
    if ([...a.keys()].join() !== [...b.keys()].join()) {
        fail(rel, `nodes ${[...a.keys()]} vs ${[...b.keys()]}`);
        continue;
    }
    for (const [name, mesh] of a) {
        const ref = b.get(name);
        const g = mesh.geometry, h = ref.geometry;
        const pos = g.getAttribute('position'), refPos = h.getAttribute('position');
        if (!(pos.array instanceof Int16Array)) fail(rel, `${name}: positions not SHORT`);
        if (pos.count !== refPos.count) {
            fail(rel, `${name}: ${pos.count} vs ${refPos.count} vertices`);
            continue;
        }
        const e = mesh.matrixWorld.elements;  // column-major
        const step = mesh.scale.x;
        if (!(step > 0) || mesh.scale.y !== step || mesh.scale.z !== step) {
            fail(rel, `${name}: not one uniform grid step`);
        }
        let worst = 0;
        for (let i = 0; i < pos.count; ++i) {
            const q = [pos.getX(i), pos.getY(i), pos.getZ(i)];
            for (let c = 0; c < 3; ++c) {
                const world = e[c] * q[0] + e[4 + c] * q[1] + e[8 + c] * q[2] + e[12 + c];
                worst = Math.max(worst, Math.abs(world - refPos.getComponent(i, c)));
            }
        }
        // Half a step, and float rounding of coordinates of tens of metres.
        if (worst > step / 2 + 1e-5) fail(rel, `${name}: a position ${worst} m off (step ${step})`);
        const n = g.getAttribute('normal'), refN = h.getAttribute('normal');
        if (!(n.array instanceof Int8Array) || !n.normalized) fail(rel, `${name}: normals not BYTE`);
        let worstN = 0;
        for (let i = 0; i < n.count; ++i) {
            for (let c = 0; c < 3; ++c) {
                worstN = Math.max(worstN, Math.abs(n.getComponent(i, c) - refN.getComponent(i, c)));
            }
        }
        if (worstN > 1 / 127 + 1e-6) fail(rel, `${name}: a normal ${worstN} off`);
        // Floats kept, or quantised: colours to 8 bits, [0, 1] UVs to 16 (getComponent
        // normalises them back).
        const tolerance = { uv: 0.5 / 65535 + 1e-7, color: 0.5 / 255 + 1e-7, _order: 0, _colour: 0 };
        for (const attr of ['uv', 'color', '_order', '_colour']) {
            const x = g.getAttribute(attr), y = h.getAttribute(attr);
            if (!x !== !y) {
                fail(rel, `${name}: ${attr} in one file only`);
                continue;
            }
            if (!x) continue;
            if (x.count !== y.count || x.itemSize !== y.itemSize) {
                fail(rel, `${name}: ${attr} has ${x.count}×${x.itemSize} values, ` +
                          `the plain file ${y.count}×${y.itemSize}`);
                continue;
            }
            let worstA = 0;
            for (let i = 0; i < x.count; ++i) {
                for (let c = 0; c < x.itemSize; ++c) {
                    worstA = Math.max(worstA, Math.abs(x.getComponent(i, c) - y.getComponent(i, c)));
                }
            }
            if (worstA > tolerance[attr]) fail(rel, `${name}: ${attr} ${worstA} off`);
        }
        const ti = g.getIndex(), tr = h.getIndex();
        if (ti.count !== tr.count) {
            fail(rel, `${name}: ${ti.count / 3} vs ${tr.count / 3} triangles`);
            continue;
        }
        for (let t = 0; t < ti.count / 3; ++t) {
            if (triangle(ti, t) !== triangle(tr, t)) {
                fail(rel, `${name}: triangle ${t} differs`);
                break;
            }
        }
        const matA = mesh.material, matB = ref.material;
        if (matA.name !== matB.name || !!matA.map !== !!matB.map ||
            matA.vertexColors !== matB.vertexColors) {
            fail(rel, `${name}: material ${matA.name} differs from the plain file's`);
        }
    }
}
if (files === 0) fail(packedRoot, 'no GLB');
exitIfFailed('check_meshopt', failures, files);
console.log(`check_meshopt: ${files} GLB files, ${bytesPacked} bytes compressed vs ` +
            `${bytesPlain} plain (${(bytesPacked / bytesPlain).toFixed(3)}×)`);
