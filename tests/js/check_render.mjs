// Draws a built dataset's textured mesh.glb with three.js in headless Chromium (render_glb.mjs)
// from its first view's camera (transforms.json) and checks that a glTF viewer shows the colours
// sylva put in the file:
//   - bark: unlit, the leaves hidden, the mean linear colour of the bark pixels is within
//     kBarkTolerance (relative, per channel) of the mean of the GLB's own bark image — the
//     visible bark samples the tile, mipmapped, over the trunk's near side;
//   - leaves: unlit, the wood hidden, antialiasing off, a leaf pixel is (±1 of 255) the sRGB
//     of the COLOR_0 of the leaf face a ray through its centre meets first, among the faces
//     turned toward the camera (each face is one colour: the front's where the leaf faces the
//     camera, the underside's where it faces away), but for at most 1% (edges; and at most 5%
//     whose ray passes just outside every leaf);
//   - lit: the whole tree under a sun and ambient light draws (covers pixels) and differs
//     from the unlit picture;
//   - sylva's own colour picture of the same view (views/000_rgb.png, colour_lighting "none":
//     albedo) against three.js's unlit picture of the whole tree: over the pixels sylva's label
//     image calls bark (1–254) and leaf (255), fully covered in both, the mean linear colours
//     agree within kSylvaTolerance (relative, per channel).
// Usage: node tests/js/check_render.mjs DATASET_DIR [OUT_DIR]   (OUT_DIR keeps the PNGs)
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { cameraFromTransforms, renderGlbViews } from './render_glb.mjs';
import { decodePng, linearToSrgb, meanLinear } from './png.mjs';

const kBarkTolerance = 0.08;
const kSylvaTolerance = 0.10;
const kScale = 2;  // the views are small: draw at 2× their resolution

const root = process.argv[2];
const outDir = process.argv[3] ?? fs.mkdtempSync(path.join(os.tmpdir(), 'sylva-check-render-'));
if (!root) {
    console.error('usage: node check_render.mjs DATASET_DIR [OUT_DIR]');
    process.exit(2);
}
fs.mkdirSync(outDir, { recursive: true });

const failures = [];

function glbParts(bytes) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const jsonLength = view.getUint32(12, true);
    const json = JSON.parse(new TextDecoder().decode(bytes.subarray(20, 20 + jsonLength)));
    const binStart = 20 + jsonLength + 8;
    const bin = bytes.subarray(binStart, binStart + view.getUint32(20 + jsonLength, true));
    const viewBytes = (i) => {
        const v = json.bufferViews[i];
        return bin.subarray(v.byteOffset ?? 0, (v.byteOffset ?? 0) + v.byteLength);
    };
    return { json, viewBytes };
}

const records = fs.readFileSync(path.join(root, 'manifest.jsonl'), 'utf8')
    .split('\n').filter((l) => l.trim()).map((l) => JSON.parse(l));
// The first textured instance with views of each species.
const chosen = new Map();
for (const r of records) {
    if (!r.files.mesh_glb || !r.files.transforms || chosen.has(r.species)) continue;
    const { json } = glbParts(new Uint8Array(fs.readFileSync(path.join(root, r.files.mesh_glb))));
    if ((json.images ?? []).length > 0) chosen.set(r.species, r);
}
if (chosen.size === 0) {
    console.error(`check_render: no textured mesh.glb with views in ${root}`);
    process.exit(1);
}
const log = path.join(outDir, 'chromium.stderr');
const opaque = (img) => (i) => img.data[i * img.channels + 3] === 255;
const covered = (img) => {
    let n = 0;
    for (let i = 0; i < img.width * img.height; ++i) n += img.data[i * img.channels + 3] > 0;
    return n;
};
const lines = [];  // one summary per instance drawn

// Draws one instance's mesh.glb four times (bark, leaves, unlit and lit) and checks them.
async function checkInstance(record) {
    const glbPath = path.join(root, record.files.mesh_glb);
    const glb = new Uint8Array(fs.readFileSync(glbPath));
    const { json, viewBytes } = glbParts(glb);
    const camera = cameraFromTransforms(
        JSON.parse(fs.readFileSync(path.join(root, record.files.transforms), 'utf8')), 0);
    const fail = (what) => failures.push(`${record.id}: ${what}`);

    // The four pictures, in one Chromium session.
    const views = {
        bark_unlit: { unlit: true, hide: ['leaves'] },
        leaves_unlit: { unlit: true, hide: ['wood'] },
        lit: { light: { direction: [0.4, 1, 0.6], intensity: Math.PI }, ambient: 0.4 * Math.PI },
        unlit: { unlit: true },
    };
    const drawn = await renderGlbViews(
        glbPath, Object.values(views).map((v) => ({ camera, scale: kScale, ...v })), { log });
    const pictures = {};
    Object.keys(views).forEach((name, k) => {
        fs.writeFileSync(path.join(outDir, `${record.id}_${name}.png`), drawn[k].png);
        pictures[name] = { image: decodePng(drawn[k].png), renderer: drawn[k].renderer };
    });

    // Bark: the mean of the tile the GLB carries (linear) and of what three.js draws with it.
    const barkImage = json.images[0];
    const tile = decodePng(viewBytes(barkImage.bufferView));
    const tileMean = meanLinear(tile).mean;
    const bark = pictures.bark_unlit;
    const barkMean = meanLinear(bark.image, opaque(bark.image));
    if (barkMean.count < 200) fail(`only ${barkMean.count} bark pixels drawn`);
    const barkError = tileMean.map((t, c) => Math.abs(barkMean.mean[c] - t) / t);
    if (barkError.some((e) => !(e <= kBarkTolerance))) {
        fail(`bark pixels' mean ${barkMean.mean.map((v) => v.toFixed(4))} vs the tile's ` +
             `${tileMean.map((v) => v.toFixed(4))} (relative ${barkError.map((e) => e.toFixed(3))})`);
    }

    // Leaves: each pixel's colour is the COLOR_0 of the leaf face its centre's ray meets
    // first among those turned toward the camera (a ray cast here, brute force).
    const leavesMesh = json.meshes.findIndex((m) => m.name === 'leaves');
    const primitive = json.meshes[leavesMesh].primitives[0];
    const typed = (accessor, Type) => {
        const b = viewBytes(json.accessors[accessor].bufferView);
        return new Type(b.buffer.slice(b.byteOffset, b.byteOffset + b.byteLength));
    };
    const colours = typed(primitive.attributes.COLOR_0, Float32Array);
    const positions = typed(primitive.attributes.POSITION, Float32Array);
    const normals = typed(primitive.attributes.NORMAL, Float32Array);
    const indices = typed(primitive.indices, Uint32Array);
    const srgb8 = (v) => [0, 1, 2].map((c) => Math.round(255 * linearToSrgb(colours[3 * v + c])));
    const leaves = pictures.leaves_unlit;
    const img = leaves.image;
    const k = img.width / camera.width;  // the pictures' scale
    const fx = camera.fx * k, fy = camera.fy * k, cx = camera.cx * k, cy = camera.cy * k;
    const pose = camera.matrix;
    const eye = [0, 1, 2].map((r) => pose[r][3]);
    // Triangles turned toward the camera, with their corners.
    const tris = [];
    for (let t = 0; t < indices.length; t += 3) {
        const [a, b2, c2] = [indices[t], indices[t + 1], indices[t + 2]];
        let facing = 0;
        for (let c = 0; c < 3; ++c) facing += normals[3 * a + c] * (eye[c] - positions[3 * a + c]);
        if (facing > 0) tris.push([a, b2, c2]);
    }
    const P = (v) => [positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]];
    const sub = (u, v) => [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
    const cross = (u, v) => [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                             u[0] * v[1] - u[1] * v[0]];
    const dot = (u, v) => u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    // Möller–Trumbore: the distance along `dir` to the triangle, or Infinity.
    const hit = (dir, [a, b2, c2]) => {
        const p0 = P(a), e1 = sub(P(b2), p0), e2 = sub(P(c2), p0);
        const q = cross(dir, e2), det = dot(e1, q);
        if (Math.abs(det) < 1e-18) return Infinity;
        const s0 = sub(eye, p0), u = dot(s0, q) / det;
        if (u < 0 || u > 1) return Infinity;
        const r = cross(s0, e1), v = dot(dir, r) / det;
        if (v < 0 || u + v > 1) return Infinity;
        const t = dot(e2, r) / det;
        return t > 0 ? t : Infinity;
    };
    let leafPixels = 0, wrong = 0, missed = 0;
    const isOpaque = opaque(img);
    for (let j = 0; j < img.height; ++j) {
        for (let i = 0; i < img.width; ++i) {
            const pixel = j * img.width + i;
            if (!isOpaque(pixel)) continue;
            ++leafPixels;
            const d = [(i + 0.5 - cx) / fx, -(j + 0.5 - cy) / fy, -1];  // camera frame
            const dir = [0, 1, 2].map((r) => pose[r][0] * d[0] + pose[r][1] * d[1] + pose[r][2] * d[2]);
            let best = Infinity, first = null;
            for (const tri of tris) {
                const t = hit(dir, tri);
                if (t < best) [best, first] = [t, tri];
            }
            if (!first) {  // the pixel's centre just misses (an edge the rasteriser took)
                ++missed;
                continue;
            }
            const want = srgb8(first[0]);
            if (want.some((v, c) => Math.abs(v - img.data[pixel * img.channels + c]) > 1)) ++wrong;
        }
    }
    if (leafPixels < 200) fail(`only ${leafPixels} leaf pixels drawn`);
    // A few pixels on edges between leaves may go either way, and a pixel the rasteriser
    // covers may have its centre's ray pass just by the triangle's edge (the leaves here are a
    // few pixels wide: ~1% of them); a face drawn from behind is every pixel of it.
    if (wrong > 0.01 * leafPixels || missed > 0.05 * leafPixels) {
        fail(`${wrong} of ${leafPixels} leaf pixels are not the colour of the leaf face the ` +
             `camera sees (${missed} pixels' rays met no leaf)`);
    }

    // Lit: draws, and light changes it.
    const { lit, unlit } = pictures;
    const litCovered = covered(lit.image);
    if (litCovered < barkMean.count + leafPixels / 2) fail(`lit picture covers ${litCovered} pixels`);
    let changed = 0;
    for (let i = 0; i < lit.image.data.length; ++i) changed += lit.image.data[i] !== unlit.image.data[i];
    if (changed === 0) fail('the lit picture equals the unlit one');

    // sylva's own colour picture (albedo) of the same camera against three.js's unlit one,
    // over the pixels sylva's label image gives to bark and to leaves.
    const viewsDir = path.join(root, record.files.views);
    const sylvaRgb = decodePng(fs.readFileSync(path.join(viewsDir, '000_rgb.png')));
    const labels = decodePng(fs.readFileSync(path.join(viewsDir, '000_label.png')));
    const three = unlit.image;
    const scale = three.width / sylvaRgb.width;
    const compared = {};
    for (const [part, isPart] of [['bark', (l) => l >= 1 && l <= 254], ['leaf', (l) => l === 255]]) {
        const inSylva = (i) => sylvaRgb.data[i * 4 + 3] === 255 && isPart(labels.data[i * labels.channels]);
        const ours = meanLinear(sylvaRgb, inSylva);
        const theirs = meanLinear(three, (i) => {
            const x = Math.floor((i % three.width) / scale), y = Math.floor(Math.floor(i / three.width) / scale);
            return three.data[i * 4 + 3] === 255 && inSylva(y * sylvaRgb.width + x);
        });
        const error = ours.mean.map((v, c) => Math.abs(theirs.mean[c] - v) / Math.max(v, 1e-3));
        compared[part] = { ours, theirs, error };
        if (ours.count < 20 || theirs.count < 80) {
            fail(`${part}: too few pixels to compare (sylva ${ours.count}, three.js ${theirs.count})`);
        } else if (error.some((e) => !(e <= kSylvaTolerance))) {
            fail(`${part}: sylva's mean ${ours.mean.map((v) => v.toFixed(4))} vs three.js's ` +
                 `${theirs.mean.map((v) => v.toFixed(4))} (relative ${error.map((e) => e.toFixed(3))})`);
        }
    }

    const within = (100 * Math.max(...barkError)).toFixed(1);
    lines.push(`${record.id} drawn by three.js in Chromium (${bark.renderer}), ` +
               `${bark.image.width}×${bark.image.height}: ${barkMean.count} bark pixels, mean ` +
               `linear ${barkMean.mean.map((v) => v.toFixed(4))} vs the tile's ` +
               `${tileMean.map((v) => v.toFixed(4))} (within ${within}%); ${leafPixels} leaf ` +
               `pixels, ${leafPixels - wrong - missed} the COLOR_0 of the face a ray meets ` +
               `there (${wrong} not, ${missed} rays missed); lit ${litCovered} pixels; ` +
               `sylva's picture vs three.js, bark ${compared.bark.ours.mean.map((v) => v.toFixed(4))} ` +
               `vs ${compared.bark.theirs.mean.map((v) => v.toFixed(4))}, leaves ` +
               `${compared.leaf.ours.mean.map((v) => v.toFixed(4))} vs ` +
               `${compared.leaf.theirs.mean.map((v) => v.toFixed(4))} (within ` +
               `${(100 * Math.max(...compared.bark.error, ...compared.leaf.error)).toFixed(1)}%)`);
}

for (const record of chosen.values()) await checkInstance(record);
if (failures.length) {
    console.error(failures.join('\n'));
    console.error(`check_render: ${failures.length} problems (pictures in ${outDir})`);
    process.exit(1);
}
console.log(`check_render: ${lines.join('; ')}`);
