// Draws a built dataset's textured mesh.glb with three.js in headless Chromium (render_glb.mjs)
// from its first view's camera (transforms.json) and checks that a glTF viewer shows the colours
// sylva put in the file:
//   - bark: unlit, the leaves hidden, the mean linear colour of the bark pixels is within
//     kBarkTolerance (relative, per channel) of the mean of the GLB's own bark image — the
//     visible bark samples the tile, mipmapped, over the trunk's near side;
//   - leaves: unlit, the wood hidden, antialiasing off, every leaf pixel is (±1 of 255) the
//     sRGB of one of the leaves' COLOR_0 values (each leaf face is one colour, so a viewer
//     must show exactly those);
//   - lit: the whole tree under a sun and ambient light draws (covers pixels) and differs
//     from the unlit picture.
// Usage: node tests/js/check_render.mjs DATASET_DIR [OUT_DIR]   (OUT_DIR keeps the PNGs)
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { cameraFromTransforms, renderGlb } from './render_glb.mjs';
import { decodePng, linearToSrgb, meanLinear } from './png.mjs';

const kBarkTolerance = 0.08;
const kScale = 4;  // the views are small: draw at 4× their resolution

const root = process.argv[2];
const outDir = process.argv[3] ?? fs.mkdtempSync(path.join(os.tmpdir(), 'sylva-check-render-'));
if (!root) {
    console.error('usage: node check_render.mjs DATASET_DIR [OUT_DIR]');
    process.exit(2);
}
fs.mkdirSync(outDir, { recursive: true });

const failures = [];
const fail = (what) => failures.push(what);

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
const record = records.find((r) => {
    if (!r.files.mesh_glb || !r.files.transforms) return false;
    const { json } = glbParts(new Uint8Array(fs.readFileSync(path.join(root, r.files.mesh_glb))));
    return (json.images ?? []).length > 0;
});
if (!record) {
    console.error(`check_render: no textured mesh.glb with views in ${root}`);
    process.exit(1);
}
const glbPath = path.join(root, record.files.mesh_glb);
const glb = new Uint8Array(fs.readFileSync(glbPath));
const { json, viewBytes } = glbParts(glb);
const camera = cameraFromTransforms(
    JSON.parse(fs.readFileSync(path.join(root, record.files.transforms), 'utf8')), 0);
const log = path.join(outDir, 'chromium.stderr');

async function draw(name, options) {
    const result = await renderGlb(glbPath, { camera, scale: kScale, log, ...options });
    fs.writeFileSync(path.join(outDir, `${name}.png`), result.png);
    return { image: decodePng(result.png), renderer: result.renderer };
}
const opaque = (img) => (i) => img.data[i * img.channels + 3] === 255;
const covered = (img) => {
    let n = 0;
    for (let i = 0; i < img.width * img.height; ++i) n += img.data[i * img.channels + 3] > 0;
    return n;
};

// Bark: the mean of the tile the GLB carries (linear) and of what three.js draws with it.
const barkImage = json.images[0];
const tile = decodePng(viewBytes(barkImage.bufferView));
const tileMean = meanLinear(tile).mean;
const bark = await draw('bark_unlit', { unlit: true, hide: ['leaves'] });
const barkMean = meanLinear(bark.image, opaque(bark.image));
if (barkMean.count < 200) fail(`only ${barkMean.count} bark pixels drawn`);
const barkError = tileMean.map((t, c) => Math.abs(barkMean.mean[c] - t) / t);
if (barkError.some((e) => !(e <= kBarkTolerance))) {
    fail(`bark pixels' mean ${barkMean.mean.map((v) => v.toFixed(4))} vs the tile's ` +
         `${tileMean.map((v) => v.toFixed(4))} (relative ${barkError.map((e) => e.toFixed(3))})`);
}

// Leaves: every pixel one of the COLOR_0 colours.
const leavesMesh = json.meshes.findIndex((m) => m.name === 'leaves');
const colourAccessor = json.accessors[json.meshes[leavesMesh].primitives[0].attributes.COLOR_0];
const colourBytes = viewBytes(colourAccessor.bufferView);
const colours = new Float32Array(colourBytes.buffer.slice(colourBytes.byteOffset,
                                                         colourBytes.byteOffset + colourBytes.byteLength));
const palette = new Set();
for (let i = 0; i < colours.length; i += 3) {
    palette.add([0, 1, 2].map((c) => Math.round(255 * linearToSrgb(colours[i + c]))).join(','));
}
const paletteList = [...palette].map((s) => s.split(',').map(Number));
const leaves = await draw('leaves_unlit', { unlit: true, hide: ['wood'] });
let leafPixels = 0, offPalette = 0;
{
    const img = leaves.image;
    const isOpaque = opaque(img);
    for (let i = 0; i < img.width * img.height; ++i) {
        if (!isOpaque(i)) continue;
        ++leafPixels;
        const px = [0, 1, 2].map((c) => img.data[i * img.channels + c]);
        if (palette.has(px.join(','))) continue;
        if (!paletteList.some((q) => q.every((v, c) => Math.abs(v - px[c]) <= 1))) ++offPalette;
    }
}
if (leafPixels < 200) fail(`only ${leafPixels} leaf pixels drawn`);
if (offPalette > 0) fail(`${offPalette} of ${leafPixels} leaf pixels are no leaf's COLOR_0`);

// Lit: draws, and light changes it.
const lit = await draw('lit', { light: { direction: [0.4, 1, 0.6], intensity: Math.PI },
                                ambient: 0.4 * Math.PI });
const unlit = await draw('unlit', { unlit: true });
const litCovered = covered(lit.image);
if (litCovered < barkMean.count + leafPixels / 2) fail(`lit picture covers ${litCovered} pixels`);
let changed = 0;
for (let i = 0; i < lit.image.data.length; ++i) changed += lit.image.data[i] !== unlit.image.data[i];
if (changed === 0) fail('the lit picture equals the unlit one');

if (failures.length) {
    console.error(failures.join('\n'));
    console.error(`check_render: ${failures.length} problems (${glbPath}; pictures in ${outDir})`);
    process.exit(1);
}
console.log(`check_render: ${record.id} drawn by three.js in Chromium (${bark.renderer}), ` +
            `${bark.image.width}×${bark.image.height}: ${barkMean.count} bark pixels, mean linear ` +
            `${barkMean.mean.map((v) => v.toFixed(4))} vs the tile's ` +
            `${tileMean.map((v) => v.toFixed(4))} (within ${(100 * Math.max(...barkError)).toFixed(1)}%); ` +
            `${leafPixels} leaf pixels, all of the ${palette.size} COLOR_0 colours; lit ` +
            `${litCovered} pixels`);
