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
//     count equals the manifest's `mesh_vertices`, skeleton.ply's equals `nodes`);
//   - textured meshes ([outputs] textures; a GLB with an image): the validator as above, the
//     wood's TEXCOORD_0 used (only the leaves' may be reported unused); three.js's GLTFLoader
//     gives the bark a white material whose map is the embedded 256² PNG (sRGB, REPEAT both
//     ways, linear filtering, not flipped) and the leaves a `color` attribute (COLOR_0) with
//     vertexColors on; the OBJ's MTL maps the bark (`map_Kd`) to the manifest's
//     `mesh_bark_png`, which is the GLB's image upside down (OBJ's v runs up the image), and
//     OBJLoader's leaf vertex colours (sRGB in the file) equal COLOR_0 corner by corner.
//
// Usage: node tests/js/check_meshes.mjs [--textured] DATASET_DIR   (tests/js/README.md)
//   --textured: fail unless some GLB and OBJ are textured.
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import {
    LinearFilter, LinearMipmapLinearFilter, RepeatWrapping, SRGBColorSpace, Texture,
} from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { MTLLoader } from 'three/addons/loaders/MTLLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';
import { decodePng } from './png.mjs';

const validator = createRequire(import.meta.url)('gltf-validator');

const args = process.argv.slice(2);
const expectTextured = args[0] === '--textured';
const root = expectTextured ? args[1] : args[0];
if (!root) {
    console.error('usage: node check_meshes.mjs [--textured] DATASET_DIR');
    process.exit(2);
}

const failures = [];
const fail = (file, what) => failures.push(`${file}: ${what}`);
const counts = { glb: 0, obj: 0, ply: 0, texturedGlb: 0, texturedObj: 0 };

// Node has no image decoding: GLTFLoader's ImageBitmapLoader fetches the image's blob URL
// (made with self.URL: Node's URL) and hands the blob to createImageBitmap, here a PNG decoder
// of our own (png.mjs).
globalThis.self ??= globalThis;
globalThis.createImageBitmap ??= async (blob) => {
    const img = decodePng(new Uint8Array(await blob.arrayBuffer()));
    return { ...img, close() {} };
};

// The JSON chunk of a GLB (glTF 2.0 §4.4: 12-byte header, then chunk length, type, data).
function glbJson(bytes) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const length = view.getUint32(12, true);
    return JSON.parse(new TextDecoder().decode(bytes.subarray(20, 20 + length)));
}

async function checkGlb(rel) {
    const bytes = new Uint8Array(fs.readFileSync(path.join(root, rel)));
    const json = glbJson(bytes);
    const textured = (json.images ?? []).length > 0;
    // The mesh whose TEXCOORD_0 a texture reads: the wood's, in a textured GLB.
    const wood = (json.meshes ?? []).findIndex((m) => m.name === 'wood');
    const report = await validator.validateBytes(bytes, { uri: rel, maxIssues: 0 });
    const issues = report.issues;
    for (const m of issues.messages) {
        // Severity: 0 error, 1 warning, 2 info, 3 hint.
        // TEXCOORD_0 is "unused" only where no material has a texture: the bark and leaf
        // UVs are an output of their own (docs/outputs.md), kept for users who texture.
        const uvs = /\/attributes\/TEXCOORD_0$/.test(m.pointer ?? '') &&
                    !(textured && (m.pointer ?? '').startsWith(`/meshes/${wood}/`));
        if (m.severity <= 1 || (m.code === 'UNUSED_OBJECT' && !uvs)) {
            fail(rel, `validator ${['error', 'warning', 'info', 'hint'][m.severity]} ` +
                      `${m.code} at ${m.pointer ?? ''}: ${m.message}`);
        }
    }
    if (issues.numErrors !== 0) fail(rel, `${issues.numErrors} validator errors`);
    ++counts.glb;
    return { json, textured: textured ? await checkTexturedGlb(rel, bytes, json) : null };
}

// A textured GLB through three.js's GLTFLoader: the bark's map and the leaves' colours. Returns
// the image (decoded) and the leaves' colours and indices for the OBJ beside it.
async function checkTexturedGlb(rel, bytes, json) {
    const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
    const gltf = await new Promise((resolve, reject) =>
        new GLTFLoader().parse(buffer, '', resolve, reject));
    const meshes = {};
    gltf.scene.traverse((o) => { if (o.isMesh) meshes[o.name] = o; });
    const out = { image: null, colours: null, index: null };
    const white = (c) => c.r === 1 && c.g === 1 && c.b === 1;
    if (meshes.wood) {
        const bark = meshes.wood.material;
        const map = bark.map;
        if (!map) {
            fail(rel, 'three.js: the bark material has no map');
        } else {
            const want = {
                'image.width': 256, 'image.height': 256, wrapS: RepeatWrapping,
                wrapT: RepeatWrapping, magFilter: LinearFilter, minFilter: LinearMipmapLinearFilter,
                colorSpace: SRGBColorSpace, flipY: false,
            };
            for (const [key, value] of Object.entries(want)) {
                const got = key.split('.').reduce((o, k) => o?.[k], map);
                if (got !== value) fail(rel, `three.js: bark map ${key} ${got}, expected ${value}`);
            }
            out.image = map.image;
        }
        if (!white(bark.color)) fail(rel, `three.js: bark colour ${bark.color.toArray()}, not white`);
        if (!bark.name || bark.name !== 'bark') fail(rel, `three.js: wood material "${bark.name}"`);
    }
    if (meshes.leaves) {
        const g = meshes.leaves.geometry;
        const colour = g.getAttribute('color');
        if (!colour || colour.itemSize !== 3 ||
            colour.count !== g.getAttribute('position').count) {
            fail(rel, 'three.js: the leaves have no colour per vertex (COLOR_0)');
        } else if (colour.array.some((v) => !(v >= 0 && v <= 1))) {
            fail(rel, 'three.js: a leaf colour outside [0, 1]');
        } else {
            out.colours = colour.array;
            out.index = g.index.array;
        }
        if (!meshes.leaves.material.vertexColors) fail(rel, 'three.js: leaves without vertexColors');
        if (!white(meshes.leaves.material.color)) fail(rel, 'three.js: leaf colour not white');
    }
    if (!out.image && !out.colours) fail(rel, 'textured, but neither bark map nor leaf colours');
    ++counts.texturedGlb;
    return out;
}

function checkObj(rel, mtlRel, glb, triangles, barkRel) {
    const objText = fs.readFileSync(path.join(root, rel), 'utf8');
    const group = new OBJLoader().parse(objText);
    const expectedLib = path.basename(mtlRel);
    if (JSON.stringify(group.materialLibraries) !== JSON.stringify([expectedLib])) {
        fail(rel, `mtllib ${JSON.stringify(group.materialLibraries)}, expected [${expectedLib}]`);
    }
    if (path.dirname(mtlRel) !== path.dirname(rel)) fail(rel, `${mtlRel} is not beside it`);
    const creator = new MTLLoader().parse(fs.readFileSync(path.join(root, mtlRel), 'utf8'), '');
    // Node cannot load images: a map becomes a Texture that remembers its file.
    creator.loadTexture = (url) => Object.assign(new Texture(), { name: url });
    const defined = creator.materialsInfo;  // name -> {kd: [r, g, b], ...} as written
    const used = new Set();
    let tris = 0;
    let leafColours = null;  // OBJLoader's, linear, per triangle corner
    group.traverse((o) => {
        if (!o.isMesh) return;
        tris += o.geometry.getAttribute('position').count / 3;
        for (const m of [].concat(o.material)) used.add(m.name);
        if (o.name === 'leaves') leafColours = o.geometry.getAttribute('color')?.array ?? null;
    });
    for (const name of used) {
        if (!(name in defined)) fail(rel, `material "${name}" is used but not defined in ${mtlRel}`);
    }
    for (const name of Object.keys(defined)) {
        if (!used.has(name)) fail(mtlRel, `material "${name}" is defined but never used`);
        const g = (glb.json.materials ?? []).find((m) => m.name === name);
        if (!g) {
            fail(mtlRel, `material "${name}" is not in the GLB`);
            continue;
        }
        const kd = defined[name].kd;
        const base = g.pbrMetallicRoughness.baseColorFactor ?? [1, 1, 1, 1];  // glTF's default
        if (!kd || kd.length !== 3 || kd.some((v, c) => v !== base[c])) {
            fail(mtlRel, `"${name}" Kd ${JSON.stringify(kd)}, the GLB's base colour ${base}`);
        }
        // three.js builds the material it would draw with (Phong, colour from Kd).
        if (!creator.create(name).color) fail(mtlRel, `three.js made no colour for "${name}"`);
    }
    if (triangles !== undefined && tris !== triangles) {
        fail(rel, `${tris} triangles read, the manifest says ${triangles}`);
    }
    if (glb.textured) checkTexturedObj(rel, mtlRel, glb.textured, creator, leafColours, barkRel);
    ++counts.obj;
}

// The OBJ of a textured GLB: the bark's map is the manifest's PNG, the GLB's image upside down;
// the leaves' vertex colours are the GLB's COLOR_0 (sRGB in the file, linear as read).
function checkTexturedObj(rel, mtlRel, tex, creator, leafColours, barkRel) {
    if (tex.image) {
        const mapKd = creator.materialsInfo.bark?.map_kd;
        if (!barkRel) {
            fail(rel, 'textured GLB beside it, but the manifest has no mesh_bark_png');
        } else if (mapKd !== path.basename(barkRel) ||
                   path.dirname(barkRel) !== path.dirname(mtlRel)) {
            fail(mtlRel, `bark map_Kd ${mapKd}, the manifest's PNG ${barkRel}`);
        } else {
            const map = creator.create('bark').map;
            if (map?.name !== mapKd) fail(mtlRel, `three.js: bark map ${map?.name}, not ${mapKd}`);
            const png = decodePng(fs.readFileSync(path.join(root, barkRel)));
            const img = tex.image;
            const row = img.width * img.channels;
            let same = png.width === img.width && png.height === img.height &&
                       png.channels === img.channels;
            for (let y = 0; same && y < img.height; ++y) {
                const a = png.data.subarray(y * row, (y + 1) * row);
                const b = img.data.subarray((img.height - 1 - y) * row, (img.height - y) * row);
                same = a.every((v, i) => v === b[i]);
            }
            if (!same) fail(barkRel, "is not the GLB's bark image upside down");
        }
    }
    if (tex.colours) {
        if (!leafColours || leafColours.length !== 3 * tex.index.length) {
            fail(rel, 'three.js: the leaves have no colour per vertex');
            return;
        }
        let worst = 0;
        for (let k = 0; k < tex.index.length; ++k) {
            for (let c = 0; c < 3; ++c) {
                worst = Math.max(worst,
                                 Math.abs(leafColours[3 * k + c] - tex.colours[3 * tex.index[k] + c]));
            }
        }
        // sRGB text of a float read back and linearised: a few float ulps apart.
        if (worst > 1e-5) fail(rel, `leaf vertex colours differ from COLOR_0 by up to ${worst}`);
    }
    ++counts.texturedObj;
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
                         stem === 'mesh' ? r.stats.mesh_triangles : undefined,
                         f[`${stem}_bark_png`]);
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
if (expectTextured && (counts.texturedGlb === 0 || counts.texturedObj === 0)) {
    fail(root, `--textured, but no textured GLB or OBJ: ${JSON.stringify(counts)}`);
}
if (failures.length) {
    console.error(failures.slice(0, 40).join('\n'));
    console.error(`check_meshes: ${failures.length} problems in ${records.length} instances`);
    process.exit(1);
}
console.log(`check_meshes: ${records.length} instances; ${counts.glb} GLB valid (0 errors, 0 ` +
            `warnings, no unused material), ${counts.obj} OBJ with every material in its MTL, ` +
            `${counts.ply} PLY with units and up axis` +
            (counts.texturedGlb + counts.texturedObj > 0
                ? `; textured: ${counts.texturedGlb} GLB (bark map and COLOR_0 in three.js), ` +
                  `${counts.texturedObj} OBJ (map_Kd = the GLB's image flipped, vertex colours ` +
                  '= COLOR_0)'
                : ''));
