// Reads the Draco-compressed GLBs of a sylva dataset built with [outputs] mesh_compression =
// "draco" with readers sylva did not write, and compares each with the plain GLB of the same
// tree from the same spec built without it; fails (exit 1) on any difference beyond the stated
// quantisation:
//   - the Khronos glTF validator: 0 errors and 0 warnings; its infos only that it cannot look
//     inside KHR_draco_mesh_compression, EXT_meshopt_compression or EXT_mesh_gpu_instancing
//     (UNSUPPORTED_EXTENSION; so the Draco views, the meshopt buffer and the instances'
//     accessors look unused to it) and the untextured TEXCOORD_0 (as check_meshes.mjs allows);
//   - the file's JSON: KHR_draco_mesh_compression used and required, every primitive of a mesh
//     not drawn as instances compressed by it, its accessors without a buffer view;
//   - glTF Transform (@gltf-transform/core's NodeIO with Google's Draco decoder, draco3dgltf,
//     and meshoptimizer's decoder) reads both files. Per mesh of the same node name, Draco's
//     vertices come in its own order (and may be split where the surface is not a manifold),
//     so each decoded vertex is matched to a plain vertex: its position within the grid's half
//     step (the plain positions' largest extent / 65535 / 2; the file states no grid, so the
//     test derives it), its normal within 1.1°, its UVs within 1/1024, _ORDER and _COLOUR equal;
//     every plain vertex some decoded vertex matches; then every decoded triangle is a plain
//     triangle of matched vertices with its winding, and the plain triangles none matched are
//     degenerate (Draco drops triangles without area). Meshes drawn as GPU instances (leaf
//     cards, through meshoptimizer) and the instances themselves are compared in order: card
//     positions within 1e-6 m, instance translations in the world within 1 mm, rotations within
//     0.001 a quaternion component (sign free), scales within 0.1 % of their largest component;
//   - the compressed file is smaller than the plain one; the sizes are printed;
//   - with --render OUT_DIR: three.js (GLTFLoader with its DRACOLoader and MeshoptDecoder, in
//     headless Chromium: render_glb.mjs) draws the first textured mesh.glb and its plain twin
//     from one camera, unlit and lit, 512² (the PNGs kept in OUT_DIR): the pictures' coverage
//     agrees (IoU ≥ kRenderIou) and, over the pixels both cover, the mean colour difference is
//     at most kRenderMeanDiff of 255 per channel.
//
// Usage: node tests/js/check_draco.mjs DRACO_DATASET_DIR PLAIN_DATASET_DIR [--render OUT_DIR]
import { createRequire } from 'node:module';
import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import draco3d from 'draco3dgltf';
import { MeshoptDecoder } from 'meshoptimizer';
import fs from 'node:fs';
import path from 'node:path';
import { exitIfFailed, glbJson, pairedFiles, triangleKey } from './gltf_node.mjs';
import { decodePng } from './png.mjs';
import { renderGlbViews } from './render_glb.mjs';

const validator = createRequire(import.meta.url)('gltf-validator');

const [dracoRoot, plainRoot, renderFlag, renderDir] = process.argv.slice(2);
if (!dracoRoot || !plainRoot || (renderFlag !== undefined && (renderFlag !== '--render' || !renderDir))) {
    console.error('usage: node check_draco.mjs DRACO_DATASET_DIR PLAIN_DATASET_DIR [--render OUT_DIR]');
    process.exit(2);
}
const kRenderIou = 0.995, kRenderMeanDiff = 1.0;
let rendered = null;  // the pair drawn with --render

const failures = [];
const fail = (file, what) => failures.push(`${file}: ${what}`);

await MeshoptDecoder.ready;
const io = new NodeIO().registerExtensions(ALL_EXTENSIONS).registerDependencies({
    'draco3d.decoder': await draco3d.createDecoderModule(),
    'meshopt.decoder': MeshoptDecoder,
});

// Node name → { node, mesh, instances } of a glTF Transform document.
function meshNodes(doc) {
    const out = new Map();
    for (const node of doc.getRoot().listNodes()) {
        const mesh = node.getMesh();
        if (mesh) out.set(node.getName(), { node, mesh, instances: node.getExtension('EXT_mesh_gpu_instancing') });
    }
    return out;
}

// A primitive's attributes as arrays of plain numbers per vertex (normalised integers as glTF
// Transform's getElement returns them, denormalised).
function attributes(prim) {
    const out = {};
    for (const s of prim.listSemantics()) {
        const a = prim.getAttribute(s);
        const rows = [];
        for (let i = 0; i < a.getCount(); ++i) rows.push(a.getElement(i, []));
        out[s] = rows;
    }
    return out;
}

// The bounds of the meshes' positions (each mesh in its own frame).
function bounds(meshes) {
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (const mesh of meshes) {
        for (const prim of mesh.listPrimitives()) {
            const p = prim.getAttribute('POSITION');
            const mn = p.getMinNormalized([]), mx = p.getMaxNormalized([]);
            for (let c = 0; c < 3; ++c) {
                lo[c] = Math.min(lo[c], mn[c]);
                hi[c] = Math.max(hi[c], mx[c]);
            }
        }
    }
    return { lo, hi };
}

function indices(prim) {
    const a = prim.getIndices();
    return a ? Array.from(a.getArray()) : null;
}

// Draco's 8-bit octahedral normals: half a cell's diagonal (√2/254) is at most ≈ 0.96° on the
// sphere (where an octahedron face is seen head-on, three times its in-plane step); 1.1° leaves
// room for the rounding of the decoded floats.
const kNormalDeg = 1.1;

const angleDeg = (a, b) => {
    const la = Math.hypot(...a), lb = Math.hypot(...b);
    const c = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (la * lb);
    return Math.acos(Math.max(-1, Math.min(1, c))) * 180 / Math.PI;
};

function compareDraco(rel, name, prim, ref, posTol) {
    const A = attributes(prim), B = attributes(ref);
    if (Object.keys(A).sort().join() !== Object.keys(B).sort().join()) {
        fail(rel, `${name}: attributes ${Object.keys(A)} vs ${Object.keys(B)}`);
        return;
    }
    const P = A.POSITION, Q = B.POSITION;
    // A hash grid of the plain positions, cells a little over the tolerance.
    const cell = Math.max(posTol * 2, 1e-6);
    const grid = new Map();
    const cellKey = (x, y, z) => `${x},${y},${z}`;
    Q.forEach((q, j) => {
        const k = cellKey(Math.floor(q[0] / cell), Math.floor(q[1] / cell), Math.floor(q[2] / cell));
        if (!grid.has(k)) grid.set(k, []);
        grid.get(k).push(j);
    });
    const matches = new Array(P.length);
    const matched = new Uint8Array(Q.length);
    let worstPos = 0, worstN = 0, worstUv = 0;
    for (let i = 0; i < P.length; ++i) {
        const p = P[i];
        const cx = Math.floor(p[0] / cell), cy = Math.floor(p[1] / cell), cz = Math.floor(p[2] / cell);
        const found = [];
        for (let dx = -1; dx <= 1; ++dx) for (let dy = -1; dy <= 1; ++dy) for (let dz = -1; dz <= 1; ++dz) {
            for (const j of grid.get(cellKey(cx + dx, cy + dy, cz + dz)) ?? []) {
                const q = Q[j];
                const d = Math.max(Math.abs(p[0] - q[0]), Math.abs(p[1] - q[1]), Math.abs(p[2] - q[2]));
                if (d > posTol) continue;
                if (A.NORMAL && angleDeg(A.NORMAL[i], B.NORMAL[j]) > kNormalDeg) continue;
                if (A.TEXCOORD_0 && Math.max(...A.TEXCOORD_0[i].map((u, c) => Math.abs(u - B.TEXCOORD_0[j][c]))) > 1 / 1024 + 1e-6) continue;
                let same = true;
                for (const s of ['_ORDER', '_COLOUR', 'COLOR_0']) {
                    if (!A[s]) continue;
                    const tol = s === 'COLOR_0' ? 0.5 / 255 + 1e-6 : 0;
                    same &&= A[s][i].every((v, c) => Math.abs(v - B[s][j][c]) <= tol);
                }
                if (!same) continue;
                found.push(j);
                worstPos = Math.max(worstPos, d);
                if (A.NORMAL) worstN = Math.max(worstN, angleDeg(A.NORMAL[i], B.NORMAL[j]));
                if (A.TEXCOORD_0) {
                    worstUv = Math.max(worstUv, ...A.TEXCOORD_0[i].map((u, c) => Math.abs(u - B.TEXCOORD_0[j][c])));
                }
            }
        }
        if (found.length === 0) {
            fail(rel, `${name}: decoded vertex ${i} (${p.map((x) => x.toFixed(4))}) matches no plain vertex`);
            return;
        }
        matches[i] = found;
        for (const j of found) matched[j] = 1;
    }
    const refIdx = indices(ref), idx = indices(prim);
    const used = new Uint8Array(Q.length);
    for (const j of refIdx) used[j] = 1;
    for (let j = 0; j < Q.length; ++j) {
        if (used[j] && !matched[j]) {
            fail(rel, `${name}: plain vertex ${j} has no decoded vertex`);
            return;
        }
    }
    const remaining = new Map();
    for (let t = 0; t < refIdx.length / 3; ++t) {
        const k = triangleKey([refIdx[3 * t], refIdx[3 * t + 1], refIdx[3 * t + 2]]);
        remaining.set(k, (remaining.get(k) ?? 0) + 1);
    }
    for (let t = 0; t < idx.length / 3; ++t) {
        const [a, b, c] = [idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]];
        let ok = false;
        for (const x of matches[a]) {
            for (const y of matches[b]) {
                for (const z of matches[c]) {
                    const k = triangleKey([x, y, z]);
                    if ((remaining.get(k) ?? 0) > 0) {
                        remaining.set(k, remaining.get(k) - 1);
                        ok = true;
                        break;
                    }
                }
                if (ok) break;
            }
            if (ok) break;
        }
        if (!ok) {
            fail(rel, `${name}: decoded triangle ${t} is no plain triangle (or its winding differs)`);
            return;
        }
    }
    for (const [k, n] of remaining) {
        if (n === 0) continue;
        const [a, b, c] = k.split(',').map(Number);
        const e1 = Q[b].map((v, i) => v - Q[a][i]), e2 = Q[c].map((v, i) => v - Q[a][i]);
        const cr = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        if (Math.hypot(...cr) > 1e-12) {
            fail(rel, `${name}: plain triangle ${k} (${n}×) is missing from the Draco file`);
            return;
        }
    }
    console.log(`  ${rel} ${name}: ${P.length} vertices (plain ${Q.length}), ${idx.length / 3} triangles; ` +
                `worst position ${worstPos.toExponential(2)} m (tolerance ${posTol.toExponential(2)}), ` +
                `normal ${worstN.toFixed(3)}°, uv ${worstUv.toExponential(2)}`);
}

function compareInOrder(rel, name, prim, ref) {
    const A = attributes(prim), B = attributes(ref);
    const tol = { POSITION: 1e-6, NORMAL: 1 / 127 + 1e-6, TEXCOORD_0: 0.5 / 65535 + 1e-7, _ORDER: 0, _COLOUR: 0, COLOR_0: 0.5 / 255 + 1e-6 };
    for (const s of Object.keys(B)) {
        if (!A[s] || A[s].length !== B[s].length) {
            fail(rel, `${name}: ${s} missing or of another length`);
            return;
        }
        let worst = 0;
        A[s].forEach((row, i) => row.forEach((v, c) => { worst = Math.max(worst, Math.abs(v - B[s][i][c])); }));
        if (worst > (tol[s] ?? 0)) fail(rel, `${name}: card ${s} ${worst} off`);
    }
    if (indices(prim).join() !== indices(ref).join()) {
        const a = indices(prim), b = indices(ref);
        for (let t = 0; t < b.length / 3; ++t) {
            const at = (x) => triangleKey([x[3 * t], x[3 * t + 1], x[3 * t + 2]]);
            if (at(a) !== at(b)) {
                fail(rel, `${name}: card triangle ${t} differs`);
                return;
            }
        }
    }
}

function compareInstances(rel, name, a, b, nodeA, nodeB) {
    const get = (ext, s) => {
        const acc = ext.getAttribute(s);
        const rows = [];
        for (let i = 0; acc && i < acc.getCount(); ++i) rows.push(acc.getElement(i, []));
        return rows;
    };
    const tA = get(a, 'TRANSLATION'), tB = get(b, 'TRANSLATION');
    if (tA.length !== tB.length || tA.length === 0) {
        fail(rel, `${name}: ${tA.length} vs ${tB.length} instances`);
        return;
    }
    const oA = nodeA.getTranslation(), oB = nodeB.getTranslation();
    let worstT = 0, worstR = 0, worstS = 0;
    const rA = get(a, 'ROTATION'), rB = get(b, 'ROTATION'), sA = get(a, 'SCALE'), sB = get(b, 'SCALE');
    for (let i = 0; i < tA.length; ++i) {
        for (let c = 0; c < 3; ++c) {
            worstT = Math.max(worstT, Math.abs(oA[c] + tA[i][c] - (oB[c] + tB[i][c])));
            // (meshoptimizer's filter shares one exponent per vector: relative to its largest)
            worstS = Math.max(worstS, Math.abs(sA[i][c] - sB[i][c]) / Math.max(1e-9, ...sB[i].map(Math.abs)));
        }
        const dot = rA[i].reduce((s, v, c) => s + v * rB[i][c], 0);
        const sign = dot < 0 ? -1 : 1;
        for (let c = 0; c < 4; ++c) worstR = Math.max(worstR, Math.abs(sign * rA[i][c] - rB[i][c]));
    }
    if (worstT > 1e-3) fail(rel, `${name}: an instance ${worstT} m off`);
    if (worstR > 1e-3) fail(rel, `${name}: an instance's rotation ${worstR} off`);
    if (worstS > 1e-3) fail(rel, `${name}: an instance's scale ${worstS} off`);
}

let files = 0, bytesPlain = 0, bytesDraco = 0;
// (A plot's scene.glb stays plain, with either codec: only its trees' files are compressed.)
const compressed = (n) => n.endsWith('.glb') && n !== 'scene.glb';
for (const { rel, packed, plain } of pairedFiles(dracoRoot, plainRoot, compressed, fail)) {
    ++files;
    bytesDraco += packed.length;
    bytesPlain += plain.length;
    if (packed.length >= plain.length) fail(rel, `not smaller: ${packed.length} ≥ ${plain.length}`);

    const json = glbJson(packed);
    for (const list of ['extensionsUsed', 'extensionsRequired']) {
        if (!(json[list] ?? []).includes('KHR_draco_mesh_compression')) {
            fail(rel, `KHR_draco_mesh_compression not in ${list}`);
        }
    }
    const instanced = new Set();
    const instanceAccessors = new Set();
    for (const node of json.nodes ?? []) {
        const inst = node.extensions?.EXT_mesh_gpu_instancing;
        if (!inst) continue;
        instanced.add(node.mesh);
        for (const a of Object.values(inst.attributes)) instanceAccessors.add(a);
    }
    const dracoViews = new Set();
    (json.meshes ?? []).forEach((mesh, m) => {
        for (const prim of mesh.primitives) {
            const ext = prim.extensions?.KHR_draco_mesh_compression;
            if (instanced.has(m)) {
                if (ext) fail(rel, `mesh ${m}: instanced, yet Draco-compressed`);
                continue;
            }
            if (!ext) {
                fail(rel, `mesh ${m}: a primitive without KHR_draco_mesh_compression`);
                continue;
            }
            dracoViews.add(ext.bufferView);
            for (const a of [...Object.values(prim.attributes), prim.indices]) {
                if (json.accessors[a].bufferView !== undefined) {
                    fail(rel, `mesh ${m}: accessor ${a} keeps a buffer view`);
                }
            }
        }
    });

    const report = await validator.validateBytes(packed, { uri: rel, maxIssues: 0 });
    for (const m of report.issues.messages) {
        const unsupported = m.code === 'UNSUPPORTED_EXTENSION' &&
            /KHR_draco_mesh_compression|EXT_meshopt_compression|EXT_mesh_gpu_instancing/.test(m.message);
        const viewIndex = /^\/bufferViews\/(\d+)$/.exec(m.pointer ?? '');
        const accessorIndex = /^\/accessors\/(\d+)$/.exec(m.pointer ?? '');
        const unused = m.code === 'UNUSED_OBJECT' &&
            ((viewIndex && dracoViews.has(Number(viewIndex[1]))) ||
             (accessorIndex && instanceAccessors.has(Number(accessorIndex[1]))) ||
             m.pointer === '/buffers/0' ||
             /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? ''));
        if (m.severity <= 1 || (m.code === 'UNSUPPORTED_EXTENSION' && !unsupported) ||
            (m.code === 'UNUSED_OBJECT' && !unused)) {
            fail(rel, `validator ${['error', 'warning', 'info', 'hint'][m.severity]} ` +
                      `${m.code} at ${m.pointer ?? ''}: ${m.message}`);
        }
    }

    if (renderDir && !rendered && rel.endsWith('mesh.glb') &&
        (json.images ?? []).length > 0) {
        rendered = { rel, packed, plain };
    }
    const docA = await io.readBinary(packed), docB = await io.readBinary(plain);
    // The grid: the plain file's positions (meshes not drawn as instances), 65535 steps over
    // their largest extent; half a step, and float rounding of coordinates of tens of metres.
    const nodesB = meshNodes(docB);
    const { lo, hi } = bounds([...nodesB.values()].filter((n) => !n.instances).map((n) => n.mesh));
    const range = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    const posTol = range / 65535 / 2 + 1e-5;
    const nodesA = meshNodes(docA);
    if ([...nodesA.keys()].join() !== [...nodesB.keys()].join()) {
        fail(rel, `nodes ${[...nodesA.keys()]} vs ${[...nodesB.keys()]}`);
        continue;
    }
    for (const [name, a] of nodesA) {
        const b = nodesB.get(name);
        const pa = a.mesh.listPrimitives(), pb = b.mesh.listPrimitives();
        if (pa.length !== pb.length) {
            fail(rel, `${name}: ${pa.length} vs ${pb.length} primitives`);
            continue;
        }
        for (let k = 0; k < pa.length; ++k) {
            if ((pa[k].getMaterial()?.getName() ?? '') !== (pb[k].getMaterial()?.getName() ?? '')) {
                fail(rel, `${name}: material differs from the plain file's`);
            }
            if (!!pa[k].getMaterial()?.getBaseColorTexture() !== !!pb[k].getMaterial()?.getBaseColorTexture()) {
                fail(rel, `${name}: texture differs from the plain file's`);
            }
            if (a.instances) compareInOrder(rel, name, pa[k], pb[k]);
            else compareDraco(rel, name, pa[k], pb[k], posTol);
        }
        if (!!a.instances !== !!b.instances) fail(rel, `${name}: instanced in one file only`);
        else if (a.instances) compareInstances(rel, name, a.instances, b.instances, a.node, b.node);
    }
}
// Both files drawn by three.js from one camera: on the plain file's bounding sphere's centre,
// from the side (+z), 2.4 radii away, fov 40°.
async function compareRendered({ rel, packed, plain }) {
    const { lo, hi } = bounds((await io.readBinary(plain)).getRoot().listMeshes());
    const centre = lo.map((v, c) => (v + hi[c]) / 2);
    const radius = Math.hypot(...hi.map((v, c) => v - lo[c])) / 2;
    const matrix = [1, 0, 0, centre[0], 0, 1, 0, centre[1], 0, 0, 1, centre[2] + 2.4 * radius,
                    0, 0, 0, 1];
    const camera = { matrix, fovDeg: 40, width: 512, height: 512 };
    const views = [
        { camera, unlit: true },
        { camera, light: { direction: [0.4, 1, 0.6], intensity: Math.PI }, ambient: 0.4 * Math.PI },
    ];
    fs.mkdirSync(renderDir, { recursive: true });
    const log = path.join(renderDir, 'chromium.stderr');
    const [a, b] = [await renderGlbViews(packed, views, { log }), await renderGlbViews(plain, views, { log })];
    const notes = [];
    views.forEach((v, k) => {
        const name = v.unlit ? 'unlit' : 'lit';
        fs.writeFileSync(path.join(renderDir, `draco_${name}.png`), a[k].png);
        fs.writeFileSync(path.join(renderDir, `plain_${name}.png`), b[k].png);
        const x = decodePng(a[k].png), y = decodePng(b[k].png);
        let both = 0, either = 0;
        const diff = [0, 0, 0];
        for (let i = 0; i < x.width * x.height; ++i) {
            const ca = x.data[i * x.channels + 3] > 0, cb = y.data[i * y.channels + 3] > 0;
            either += ca || cb;
            if (!(ca && cb)) continue;
            ++both;
            for (let c = 0; c < 3; ++c) {
                diff[c] += Math.abs(x.data[i * x.channels + c] - y.data[i * y.channels + c]);
            }
        }
        const iou = both / Math.max(1, either);
        const mean = diff.map((d) => d / Math.max(1, both));
        if (both < 1000) fail(rel, `${name}: only ${both} pixels drawn`);
        if (!(iou >= kRenderIou)) fail(rel, `${name}: coverage IoU ${iou.toFixed(4)} against the plain file's`);
        if (mean.some((m) => !(m <= kRenderMeanDiff))) {
            fail(rel, `${name}: mean colour difference ${mean.map((m) => m.toFixed(2))} of 255`);
        }
        notes.push(`${name}: ${both} pixels, IoU ${iou.toFixed(4)}, mean difference ` +
                   `${mean.map((m) => m.toFixed(3))} of 255`);
    });
    console.log(`  ${rel} drawn by three.js (${a[0].renderer}), Draco vs plain: ${notes.join('; ')}`);
}

if (renderDir) {
    if (rendered) await compareRendered(rendered);
    else fail(dracoRoot, 'no textured mesh.glb to draw');
}
if (files === 0) fail(dracoRoot, 'no GLB');
exitIfFailed('check_draco', failures, files);
console.log(`check_draco: ${files} GLB files, ${bytesDraco} bytes compressed vs ` +
            `${bytesPlain} plain (${(bytesDraco / bytesPlain).toFixed(3)}×)`);
