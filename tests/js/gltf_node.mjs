// What the GLB checks share in Node.js: images decoded for three.js's GLTFLoader, the files of
// a dataset by name (and paired with a plain dataset's), a GLB's JSON, a GLB parsed by
// GLTFLoader (with three's MeshoptDecoder for EXT_meshopt_compression), its world matrices up
// to date, and the failure report that ends a check.
import fs from 'node:fs';
import path from 'node:path';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { decodePng } from './png.mjs';

// Node has no image decoding: GLTFLoader's ImageBitmapLoader fetches the image's blob URL
// (made with self.URL: Node's URL) and hands the blob to createImageBitmap, here a PNG decoder
// of our own (png.mjs).
export function decodeImagesWithPng() {
    globalThis.self ??= globalThis;
    globalThis.createImageBitmap ??= async (blob) => {
        const img = decodePng(new Uint8Array(await blob.arrayBuffer()));
        return { ...img, close() {} };
    };
}

// The files under `dir` whose name `keep` accepts, sorted.
export function filesUnder(dir, keep) {
    const out = [];
    for (const e of fs.readdirSync(dir, { withFileTypes: true })) {
        const p = path.join(dir, e.name);
        if (e.isDirectory()) out.push(...filesUnder(p, keep));
        else if (keep(e.name)) out.push(p);
    }
    return out.sort();
}

// The GLBs under `root` (those whose name `keep` accepts) each with the file of the same path
// under `plainRoot`: { rel, packed, plain } (bytes); a file without its plain twin is reported
// through `fail(rel, what)` and skipped.
export function* pairedFiles(root, plainRoot, keep, fail) {
    for (const file of filesUnder(root, keep)) {
        const rel = path.relative(root, file);
        const plainFile = path.join(plainRoot, rel);
        if (!fs.existsSync(plainFile)) {
            fail(rel, 'no plain GLB of the same tree');
            continue;
        }
        yield { rel, packed: new Uint8Array(fs.readFileSync(file)),
                plain: new Uint8Array(fs.readFileSync(plainFile)) };
    }
}

// A triangle (three vertex indices) as a string, rotated so that its smallest index comes first
// (winding kept): equal for the same triangle however its corners were rotated.
export function triangleKey(a) {
    const k = a.indexOf(Math.min(...a));
    return `${a[k]},${a[(k + 1) % 3]},${a[(k + 2) % 3]}`;
}

// The JSON chunk of a GLB's bytes.
export function glbJson(bytes) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const length = view.getUint32(12, true);
    return JSON.parse(new TextDecoder().decode(bytes.subarray(20, 20 + length)));
}

// The glTF of a GLB's bytes as GLTFLoader makes it.
export async function parseGlb(bytes, meshopt) {
    const loader = new GLTFLoader();
    if (meshopt) {
        await MeshoptDecoder.ready;
        loader.setMeshoptDecoder(MeshoptDecoder);
    }
    const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
    const gltf = await new Promise((resolve, reject) => loader.parse(buffer, '', resolve, reject));
    gltf.scene.updateMatrixWorld(true);
    return gltf;
}

// The end of a check of paired GLB files: with problems, the first 40 of them and their count
// on stderr, and exit status 1.
export function exitIfFailed(name, failures, files) {
    if (!failures.length) return;
    for (const f of failures.slice(0, 40)) console.error(f);
    console.error(`${name}: ${failures.length} problem(s) in ${files} GLB file(s)`);
    process.exit(1);
}
