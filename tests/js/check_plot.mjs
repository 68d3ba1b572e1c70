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
// With --textured ([outputs] textures): the validator passes with the bark's UVs used; through
// GLTFLoader every tree's wood has a material "bark-<species>" (its species in trees.csv)
// whose map is a decoded 256 × 256 image, its leaves a material "leaf-<species>" with vertex
// colours in [0, 1] (COLOR_0), trees of one species sharing the materials; terrain and ground
// cover untextured; every tree's own mesh.glb valid with its bark image. (No scene.ply is read:
// the textured plot writes none.)
//
// Usage: node tests/js/check_plot.mjs [--textured] PLOT_DIR   (the directory holding scene.glb
// and trees.csv)
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';
import { decodePng } from './png.mjs';

const validator = createRequire(import.meta.url)('gltf-validator');

const args = process.argv.slice(2);
const textured = args[0] === '--textured';
const dir = textured ? args[1] : args[0];
if (!dir) {
    console.error('usage: node check_plot.mjs [--textured] PLOT_DIR');
    process.exit(2);
}
const failures = [];
const fail = (what) => failures.push(what);
const barkMaps = new Map();  // textured: species → its trees' bark materials
let colouredLeaves = 0;      // textured: trees whose leaves have their colours

// Node has no image decoding: GLTFLoader hands the image's blob to createImageBitmap, here a
// PNG decoder of our own (png.mjs), as check_meshes.mjs does.
globalThis.self ??= globalThis;
globalThis.createImageBitmap ??= async (blob) => {
    const img = decodePng(new Uint8Array(await blob.arrayBuffer()));
    return { ...img, close() {} };
};

const rows = fs.readFileSync(path.join(dir, 'trees.csv'), 'utf8').trim().split('\n').slice(1)
    .map((l) => l.split(','));
const trees = new Map(rows.map((r) => [Number(r[0]), r[1]]));
const speciesOf = new Map(rows.map((r) => [r[1], r[2]]));  // tree name → species
if (trees.size < 2) fail(`trees.csv: ${trees.size} trees`);

const glbBytes = new Uint8Array(fs.readFileSync(path.join(dir, 'scene.glb')));
const glbJsonLength = new DataView(glbBytes.buffer, glbBytes.byteOffset).getUint32(12, true);
const glbJson = JSON.parse(new TextDecoder().decode(glbBytes.subarray(20, 20 + glbJsonLength)));
// The material of the primitive a validator pointer names (/meshes/m/primitives/p/…).
const materialAt = (pointer) => {
    const m = /^\/meshes\/(\d+)\/primitives\/(\d+)\//.exec(pointer);
    return m ? glbJson.materials?.[glbJson.meshes[m[1]].primitives[m[2]].material] : undefined;
};
const report = await validator.validateBytes(glbBytes, { uri: 'scene.glb', maxIssues: 0 });
for (const m of report.issues.messages) {
    // TEXCOORD_0 is "unused" only where its material has no texture (docs/outputs.md).
    const uvs = /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? '') &&
                !materialAt(m.pointer)?.pbrMetallicRoughness?.baseColorTexture;
    if (m.severity <= 1 || (m.code === 'UNUSED_OBJECT' && !uvs)) {
        fail(`scene.glb: validator ${m.code} at ${m.pointer ?? ''}: ${m.message}`);
    }
}
if (textured !== (glbJson.images ?? []).length > 0) {
    fail(`scene.glb: ${(glbJson.images ?? []).length} images, textured ${textured}`);
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
    if (textured) checkLook(node);
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

// A node's materials in a textured scene (above).
function checkLook(node) {
    const ground = node.name === 'terrain' || node.name === 'ground-cover';
    node.traverse((o) => {
        if (!o.isMesh) return;
        const mat = o.material;
        if (ground) {
            if (mat.map || mat.vertexColors) fail(`${node.name}: textured`);
            return;
        }
        const species = speciesOf.get(node.name);
        const colour = o.geometry.getAttribute('color');
        if (mat.map) {
            if (mat.name !== `bark-${species}`) fail(`${node.name}: bark material "${mat.name}"`);
            if (mat.map.image?.width !== 256 || mat.map.image?.height !== 256) {
                fail(`${node.name}: bark map ${mat.map.image?.width} × ${mat.map.image?.height}`);
            }
            barkMaps.set(species, [...(barkMaps.get(species) ?? []), mat]);
        } else if (mat.name !== `leaf-${species}`) {
            fail(`${node.name}: a mesh of material "${mat.name}" without a map`);
        } else if (!mat.vertexColors || !colour || colour.itemSize !== 3 ||
                   colour.array.some((v) => !(v >= 0 && v <= 1))) {
            fail(`${node.name}: leaves without colours in [0, 1] per vertex`);
        } else {
            ++colouredLeaves;
        }
    });
}
if (textured) {
    // Each tree's own textured mesh.glb (the single-tree writer under the tree's look): the
    // validator as above, with an image.
    for (const name of trees.values()) {
        const rel = `trees/${name}/mesh.glb`;
        const bytes = new Uint8Array(fs.readFileSync(path.join(dir, rel)));
        const length = new DataView(bytes.buffer, bytes.byteOffset).getUint32(12, true);
        const doc = JSON.parse(new TextDecoder().decode(bytes.subarray(20, 20 + length)));
        if ((doc.images ?? []).length !== 1) fail(`${rel}: ${(doc.images ?? []).length} images`);
        const r = await validator.validateBytes(bytes, { uri: rel, maxIssues: 0 });
        for (const m of r.issues.messages) {
            const uvs = /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? '');
            if (m.severity <= 1 || (m.code === 'UNUSED_OBJECT' && !uvs)) {
                fail(`${rel}: validator ${m.code} at ${m.pointer ?? ''}: ${m.message}`);
            }
        }
    }
    if (barkMaps.size < 2) fail(`textured: bark maps of ${barkMaps.size} species`);
    for (const [species, mats] of barkMaps) {
        // Materials are per species: one object however many trees (GLTFLoader caches them).
        if (new Set(mats.map((m) => m.name)).size !== 1 || new Set(mats).size !== 1) {
            fail(`textured: ${species}'s trees do not share one bark material`);
        }
    }
    if (colouredLeaves === 0) fail('textured: no leaves with vertex colours');
}

// The PLY (untextured plots: the textured one writes no scene.ply).
if (!textured) {
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
}

if (failures.length) {
    for (const f of failures) console.error(`FAIL ${f}`);
    process.exit(1);
}
console.log(textured
    ? `check_plot: textured scene.glb (${names.size} nodes, ${barkMaps.size} species' bark maps)`
    : `check_plot: scene.glb (${names.size} nodes) and scene.ply agree with trees.csv`);
