// Reads a sylva plot's scene meshes with readers sylva did not write, and fails (exit 1) on the
// first class of problem it finds:
//   - scene.glb: the Khronos glTF validator reports 0 errors, 0 warnings and no unused object
//     but the untextured TEXCOORD_0 (as check_meshes.mjs);
//   - scene.glb through three.js's GLTFLoader: the scene's nodes are "terrain", "ground-cover"
//     and one per row of trees.csv named by its `name` ("tree-0007"), each with userData.tree_id
//     its id (0 for terrain and ground cover) and a wood and a leaf mesh;
//   - scene.ply through three.js's PLYLoader with tree_id and part mapped as custom attributes:
//     per tree id, the vertex count equals the GLB node's (wood + leaves; terrain + ground cover
//     for 0), and the ids are exactly {0} and the plot's.
//
// Usage: node tests/js/check_plot.mjs PLOT_DIR   (the directory holding scene.glb and trees.csv)
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';

const validator = createRequire(import.meta.url)('gltf-validator');

const dir = process.argv[2];
if (!dir) {
    console.error('usage: node check_plot.mjs PLOT_DIR');
    process.exit(2);
}
const failures = [];
const fail = (what) => failures.push(what);

const rows = fs.readFileSync(path.join(dir, 'trees.csv'), 'utf8').trim().split('\n').slice(1)
    .map((l) => l.split(','));
const trees = new Map(rows.map((r) => [Number(r[0]), r[1]]));
if (trees.size < 2) fail(`trees.csv: ${trees.size} trees`);

const glbBytes = new Uint8Array(fs.readFileSync(path.join(dir, 'scene.glb')));
const report = await validator.validateBytes(glbBytes, { uri: 'scene.glb', maxIssues: 0 });
for (const m of report.issues.messages) {
    const uvs = /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? '');
    if (m.severity <= 1 || (m.code === 'UNUSED_OBJECT' && !uvs)) {
        fail(`scene.glb: validator ${m.code} at ${m.pointer ?? ''}: ${m.message}`);
    }
}

const buffer = glbBytes.buffer.slice(glbBytes.byteOffset, glbBytes.byteOffset + glbBytes.byteLength);
const gltf = await new Promise((resolve, reject) =>
    new GLTFLoader().parse(buffer, '', resolve, reject));
const glbVertices = new Map();  // tree id → vertices
const names = new Set();
for (const node of gltf.scene.children) {
    names.add(node.name);
    const id = node.userData.tree_id;
    let vertices = 0, meshes = 0;
    node.traverse((o) => {
        if (o.isMesh) {
            vertices += o.geometry.attributes.position.count;
            ++meshes;
        }
    });
    glbVertices.set(id, (glbVertices.get(id) ?? 0) + vertices);
    if (node.name === 'terrain' || node.name === 'ground-cover') {
        if (id !== 0) fail(`${node.name}: tree_id ${id}, expected 0`);
    } else if (trees.get(id) !== node.name) {
        fail(`node ${node.name}: tree_id ${id} names ${trees.get(id)}`);
    } else if (meshes !== 2) {
        fail(`${node.name}: ${meshes} meshes, expected wood and leaves`);
    }
}
for (const expected of ['terrain', 'ground-cover', ...trees.values()]) {
    if (!names.has(expected)) fail(`scene.glb: no node ${expected}`);
}
if (names.size !== trees.size + 2) fail(`scene.glb: ${names.size} nodes, expected ${trees.size + 2}`);

const plyBytes = fs.readFileSync(path.join(dir, 'scene.ply'));
const loader = new PLYLoader();
loader.setCustomPropertyNameMapping({ treeId: ['tree_id'], part: ['part'] });
const geometry = loader.parse(plyBytes.buffer.slice(plyBytes.byteOffset,
                                                    plyBytes.byteOffset + plyBytes.byteLength));
const ids = geometry.attributes.treeId?.array;
if (!ids) {
    fail('scene.ply: PLYLoader found no tree_id');
} else {
    const plyVertices = new Map();
    for (const id of ids) plyVertices.set(id, (plyVertices.get(id) ?? 0) + 1);
    const want = [0, ...trees.keys()].sort((a, b) => a - b);
    const got = [...plyVertices.keys()].sort((a, b) => a - b);
    if (JSON.stringify(got) !== JSON.stringify(want)) {
        fail(`scene.ply: tree ids ${got}, expected ${want}`);
    }
    for (const [id, n] of plyVertices) {
        if (glbVertices.get(id) !== n) {
            fail(`tree_id ${id}: ${n} PLY vertices, ${glbVertices.get(id)} in the GLB`);
        }
    }
}

if (failures.length) {
    for (const f of failures) console.error(`FAIL ${f}`);
    process.exit(1);
}
console.log(`check_plot: scene.glb (${names.size} nodes) and scene.ply agree with trees.csv`);
