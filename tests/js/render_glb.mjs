// Renders a GLB with three.js in headless Chromium (software WebGL: SwiftShader) from a
// nerfstudio camera, and writes a PNG: the harness for comparing sylva's colour views with
// what a glTF viewer draws from its textured meshes.
//
// No puppeteer: Node serves a page, the GLB and three.js (tests/js/node_modules/three) on a
// loopback port, starts Chromium on the page with kChromiumFlags, and the page posts the
// canvas back as a PNG data URL; then Chromium (its process group, started here) is stopped.
//
// Camera: as a frame of sylva's transforms.json — a camera-to-world 4×4 (rows), OpenGL axes
// (x right, y up, looking along −z; three.js's own convention), metres — with the intrinsics
// fl_x, fl_y, cx, cy, w, h (pixels, pixel centres at i + 0.5; or a vertical fov in degrees,
// square pixels, centred), or orthographic (ortho_height_m). The projection is built from
// them exactly: P = [[2fx/w, 0, 1 − 2cx/w, 0], [0, 2fy/h, 2cy/h − 1, 0], [0, 0, −(f+n)/(f−n),
// −2fn/(f−n)], [0, 0, −1, 0]], near and far bracketing the model's bounding sphere.
// Light (three.js units, physically based: a white Lambertian surface facing a directional
// light of intensity π, or under ambient light of intensity π, shows its base colour): a
// directional light toward `direction` and an ambient light. `unlit`: every material becomes a
// MeshBasicMaterial with the same colour, map, vertex colours and sides, so a pixel is
// sRGB(base colour × texture × vertex colour), no light at all. Output: sRGB (three.js's
// outputColorSpace), no tone mapping, antialiasing off unless asked (so a pixel's alpha is 0 or
// 255 on a transparent background).
//
// CLI:
//   node tests/js/render_glb.mjs --glb MODEL.glb --out IMAGE.png
//        ( --transforms transforms.json [--frame K] | --camera CAMERA.json |
//          --matrix m00,m01,…,m33 --fov-deg F --size WxH )
//        [--scale S] [--light x,y,z[,intensity]] [--ambient I] [--unlit]
//        [--background r,g,b (sRGB 0–1; default transparent)] [--hide NAME[,NAME…]]
//        [--antialias] [--chromium PATH]
//   CAMERA.json: {"transform_matrix": [[…] ×4], "fov_deg": F, "w": W, "h": H} or a frame with
//   fl_x, fl_y, cx, cy, w, h. --scale multiplies the resolution (and the intrinsics).
//   --hide: nodes left out by name (sylva's mesh.glb: "wood", "leaves").
// Module: import { renderGlb, renderGlbViews, cameraFromTransforms } from './render_glb.mjs'
// (renderGlbViews draws several views in one Chromium session: ≈ 5 s saved per view).
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const threeDir = path.join(here, 'node_modules', 'three');

// Headless Chromium with WebGL 2 on SwiftShader (ANGLE's Vulkan backend on the CPU): no GPU,
// no display. --enable-unsafe-swiftshader: Chromium no longer falls back to SwiftShader for
// WebGL silently (it warns that the automatic fallback is deprecated).
export const kChromiumFlags = [
    '--headless', '--no-sandbox', '--no-first-run', '--no-default-browser-check',
    '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
    '--hide-scrollbars', '--mute-audio', '--disable-background-networking',
];

export function findChromium() {
    for (const name of ['chromium', 'chromium-browser', 'google-chrome']) {
        try {
            return execFileSync('sh', ['-c', `command -v ${name}`]).toString().trim();
        } catch { /* next */ }
    }
    return null;
}

// A camera from transforms.json (sylva's, nerfstudio's): frame k's pose, its intrinsics or
// the file's.
export function cameraFromTransforms(transforms, k = 0) {
    const frame = transforms.frames[k];
    if (!frame) throw new Error(`transforms.json has no frame ${k}`);
    const get = (key) => frame[key] ?? transforms[key];
    const camera = {
        matrix: frame.transform_matrix,
        width: get('w'), height: get('h'),
        fx: get('fl_x'), fy: get('fl_y'), cx: get('cx'), cy: get('cy'),
    };
    if (get('orthographic')) camera.orthoHeight = get('ortho_height_m');
    return camera;
}

// A camera from a JSON object: a transforms.json frame with intrinsics, or fov_deg + w, h.
function cameraFromJson(j) {
    const camera = {
        matrix: j.transform_matrix, width: j.w ?? j.width, height: j.h ?? j.height,
        fx: j.fl_x, fy: j.fl_y, cx: j.cx, cy: j.cy,
    };
    if (j.fov_deg !== undefined) camera.fovDeg = j.fov_deg;
    if (j.orthographic) camera.orthoHeight = j.ortho_height_m;
    return camera;
}

// Pixel intrinsics of a camera (fov_deg: square pixels, centred), scaled by `scale`.
function intrinsics(camera, scale = 1) {
    const width = Math.round(camera.width * scale), height = Math.round(camera.height * scale);
    let { fx, fy, cx, cy } = camera;
    if (camera.orthoHeight === undefined && fy === undefined) {
        if (!(camera.fovDeg > 0)) throw new Error('camera: give fl_x/fl_y or fov_deg');
        fy = camera.height / (2 * Math.tan((camera.fovDeg * Math.PI) / 360));
        fx = fy;
    }
    if (camera.orthoHeight !== undefined) {
        fy = fy ?? camera.height / camera.orthoHeight;
        fx = fx ?? fy;
    }
    cx = cx ?? camera.width / 2;
    cy = cy ?? camera.height / 2;
    const rows = camera.matrix.length === 16
        ? [0, 1, 2, 3].map((r) => camera.matrix.slice(4 * r, 4 * r + 4))
        : camera.matrix;
    return {
        matrix: rows.flat(), width, height,
        fx: fx * scale, fy: fy * scale, cx: cx * scale, cy: cy * scale,
        orthographic: camera.orthoHeight !== undefined,
    };
}

const kPage = `<!doctype html>
<html><head><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "/three/build/three.module.js",
                                      "three/addons/": "/three/examples/jsm/"}}</script>
</head><body style="margin:0">
<script type="module">
const post = (result) => fetch('/result', { method: 'POST', body: JSON.stringify(result) });
window.addEventListener('error', (e) => post({ error: String(e.message) }));
window.addEventListener('unhandledrejection', (e) => post({ error: String(e.reason) }));
try {
    const THREE = await import('three');
    const { GLTFLoader } = await import('three/addons/loaders/GLTFLoader.js');
    const { DRACOLoader } = await import('three/addons/loaders/DRACOLoader.js');
    const { MeshoptDecoder } = await import('three/addons/libs/meshopt_decoder.module.js');
    const { views } = await (await fetch('/params.json')).json();
    // Compressed files too: three's Draco decoder (WebAssembly, in a worker) and meshopt's.
    const loader = new GLTFLoader()
        .setDRACOLoader(new DRACOLoader().setDecoderPath('/three/examples/jsm/libs/draco/gltf/'))
        .setMeshoptDecoder(MeshoptDecoder);
    const gltf = await loader.loadAsync('/model.glb');
    const scene = new THREE.Scene();
    scene.add(gltf.scene);
    // Each mesh's own material and its unlit twin (same colour, map, vertex colours, sides).
    const meshes = [];
    gltf.scene.traverse((o) => {
        if (!o.isMesh) return;
        const m = o.material;
        const unlit = new THREE.MeshBasicMaterial({
            name: m.name, color: m.color, map: m.map, vertexColors: m.vertexColors,
            side: m.side, transparent: m.transparent, opacity: m.opacity });
        meshes.push({ mesh: o, lit: m, unlit });
    });
    const sun = new THREE.DirectionalLight(0xffffff, 1);  // shines from its position to the origin
    const ambient = new THREE.AmbientLight(0xffffff, 1);
    scene.add(sun, sun.target, ambient);
    // The model's bounding sphere brackets near and far.
    const sphere = new THREE.Box3().setFromObject(gltf.scene).getBoundingSphere(new THREE.Sphere());
    const results = [];
    for (const p of views) {
        const c = p.camera;
        const renderer = new THREE.WebGLRenderer({
            antialias: p.antialias, alpha: true, preserveDrawingBuffer: true });
        renderer.setPixelRatio(1);
        renderer.setSize(c.width, c.height, false);
        renderer.outputColorSpace = THREE.SRGBColorSpace;
        renderer.toneMapping = THREE.NoToneMapping;
        const hidden = new Set(p.hide);
        gltf.scene.traverse((o) => { o.visible = !hidden.has(o.name); });
        for (const m of meshes) m.mesh.material = p.unlit ? m.unlit : m.lit;
        scene.background = p.background
            ? new THREE.Color().setRGB(...p.background, THREE.SRGBColorSpace) : null;
        renderer.setClearColor(0x000000, 0);
        sun.visible = ambient.visible = !p.unlit;
        sun.intensity = p.light.intensity;
        sun.position.set(...p.light.direction);
        ambient.intensity = p.ambient;

        const pose = new THREE.Matrix4().set(...c.matrix);
        const eye = new THREE.Vector3().setFromMatrixPosition(pose);
        const forward = new THREE.Vector3(-pose.elements[8], -pose.elements[9], -pose.elements[10])
            .normalize();
        const along = sphere.center.clone().sub(eye).dot(forward);
        const r = Math.max(sphere.radius, 1e-3);
        let camera;
        if (c.orthographic) {
            camera = new THREE.OrthographicCamera(-c.width / (2 * c.fx), c.width / (2 * c.fx),
                                                  c.height / (2 * c.fy), -c.height / (2 * c.fy),
                                                  along - 1.5 * r, along + 1.5 * r);
            camera.projectionMatrix.elements[12] += (2 * c.cx) / c.width - 1;
            camera.projectionMatrix.elements[13] += 1 - (2 * c.cy) / c.height;
        } else {
            camera = new THREE.PerspectiveCamera();
            const far = Math.max(along + 1.5 * r, 1e-2);
            const near = Math.max(along - 1.5 * r, far * 1e-4);
            camera.near = near;
            camera.far = far;
            camera.projectionMatrix.set(
                (2 * c.fx) / c.width, 0, 1 - (2 * c.cx) / c.width, 0,
                0, (2 * c.fy) / c.height, (2 * c.cy) / c.height - 1, 0,
                0, 0, -(far + near) / (far - near), (-2 * far * near) / (far - near),
                0, 0, -1, 0);
        }
        camera.projectionMatrixInverse.copy(camera.projectionMatrix).invert();
        camera.matrixAutoUpdate = false;
        camera.matrix.copy(pose);
        camera.updateMatrixWorld(true);

        renderer.render(scene, camera);
        const gl = renderer.getContext();
        const debug = gl.getExtension('WEBGL_debug_renderer_info');
        results.push({
            png: renderer.domElement.toDataURL('image/png'),
            renderer: gl.getParameter(debug ? debug.UNMASKED_RENDERER_WEBGL : gl.RENDERER),
            materials: meshes.map((m) => m.lit.name),
        });
        renderer.dispose();
        renderer.forceContextLoss();
    }
    await post({ results });
} catch (e) {
    await post({ error: String(e && e.stack || e) });
}
</script></body></html>`;

const kTypes = { '.js': 'text/javascript', '.html': 'text/html', '.json': 'application/json',
                 '.wasm': 'application/wasm' };

// A view's parameters as the page takes them (the options of renderGlb below).
function viewParams(options) {
    return {
        camera: intrinsics(options.camera, options.scale ?? 1),
        light: {
            direction: options.light?.direction ?? [0.3, 1, 0.5],
            intensity: options.light?.intensity ?? Math.PI,
        },
        ambient: options.ambient ?? 0.3 * Math.PI,
        unlit: !!options.unlit,
        background: options.background ?? null,
        hide: options.hide ?? [],
        antialias: !!options.antialias,
    };
}

// Renders `glb` (a path or bytes) once per view in one Chromium session, resolving to
// [{ png (Buffer), renderer (WebGL's renderer string), materials }]. A view: camera
// (cameraFromTransforms' or {matrix, fovDeg, width, height}), scale (1), light ({direction:
// [x, y, z] toward the light, intensity: π}), ambient (0.3 π), unlit (false), background (null:
// transparent; [r, g, b] sRGB), hide ([] node names), antialias (false). session: chromium
// (found on PATH), timeoutMs (120 000), log (a file for Chromium's stderr).
export async function renderGlbViews(glb, views, session = {}) {
    const bytes = typeof glb === 'string' ? fs.readFileSync(glb) : Buffer.from(glb);
    const params = { views: views.map(viewParams) };
    const chromium = session.chromium ?? findChromium();
    if (!chromium) throw new Error('render_glb: no chromium on PATH');

    let settle;
    const done = new Promise((resolve, reject) => { settle = { resolve, reject }; });
    const server = http.createServer((req, res) => {
        const url = new URL(req.url, 'http://localhost');
        if (req.method === 'POST' && url.pathname === '/result') {
            const chunks = [];
            req.on('data', (d) => chunks.push(d));
            req.on('end', () => {
                res.end('ok');
                try {
                    settle.resolve(JSON.parse(Buffer.concat(chunks).toString('utf8')));
                } catch (e) {
                    settle.reject(e);
                }
            });
            return;
        }
        let body = null, type = 'application/octet-stream';
        if (url.pathname === '/' || url.pathname === '/index.html') {
            body = kPage;
            type = kTypes['.html'];
        } else if (url.pathname === '/params.json') {
            body = JSON.stringify(params);
            type = kTypes['.json'];
        } else if (url.pathname === '/model.glb') {
            body = bytes;
            type = 'model/gltf-binary';
        } else if (url.pathname.startsWith('/three/')) {
            const file = path.normalize(path.join(threeDir, url.pathname.slice('/three/'.length)));
            if (file.startsWith(threeDir + path.sep) && fs.existsSync(file)) {
                body = fs.readFileSync(file);
                type = kTypes[path.extname(file)] ?? type;
            }
        }
        if (body === null) {
            res.statusCode = 404;
            res.end();
            return;
        }
        res.setHeader('Content-Type', type);
        res.end(body);
    });
    await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
    const port = server.address().port;
    const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'sylva-render-glb-'));
    const stderr = session.log ? fs.openSync(session.log, 'a') : 'ignore';
    // Its own process group, so stopping it stops its GPU and renderer processes too.
    const browser = spawn(chromium, [...kChromiumFlags, `--user-data-dir=${profile}`,
                                     `http://127.0.0.1:${port}/index.html`],
                          { detached: true, stdio: ['ignore', 'ignore', stderr] });
    browser.on('exit', (code) => settle.reject(new Error(`chromium exited (${code}) first`)));
    const timer = setTimeout(() => settle.reject(new Error('render_glb: timed out')),
                             session.timeoutMs ?? 120000);
    try {
        const result = await done;
        if (result.error) throw new Error(`render_glb: the page failed: ${result.error}`);
        const prefix = 'data:image/png;base64,';
        return result.results.map((r) => {
            if (!r.png?.startsWith(prefix)) throw new Error('render_glb: no PNG came back');
            return {
                png: Buffer.from(r.png.slice(prefix.length), 'base64'),
                renderer: r.renderer,
                materials: r.materials,
            };
        });
    } finally {
        clearTimeout(timer);
        browser.removeAllListeners('exit');
        try {
            process.kill(-browser.pid, 'SIGTERM');
        } catch { /* already gone */ }
        await new Promise((resolve) => {
            if (browser.exitCode !== null || browser.signalCode !== null) resolve();
            else browser.once('exit', resolve);
        });
        if (typeof stderr === 'number') fs.closeSync(stderr);
        server.close();
        fs.rmSync(profile, { recursive: true, force: true });
    }
}

// One view (options: a view's and the session's, as renderGlbViews takes them).
export async function renderGlb(glb, options) {
    return (await renderGlbViews(glb, [options], options))[0];
}

function parseArgs(argv) {
    const a = {};
    for (let i = 0; i < argv.length; ++i) {
        const key = argv[i];
        if (!key.startsWith('--')) throw new Error(`unexpected argument ${key}`);
        const flag = ['--unlit', '--antialias'].includes(key);
        a[key.slice(2)] = flag ? true : argv[++i];
    }
    return a;
}

const numbers = (s) => s.split(',').map(Number);

async function main() {
    const a = parseArgs(process.argv.slice(2));
    if (!a.glb || !a.out) {
        console.error('usage: node render_glb.mjs --glb MODEL.glb --out IMAGE.png (--transforms ' +
                      'FILE [--frame K] | --camera FILE | --matrix 16 numbers --fov-deg F ' +
                      '--size WxH) [--scale S] [--light x,y,z[,I]] [--ambient I] [--unlit] ' +
                      '[--background r,g,b] [--hide NAMES] [--antialias] [--chromium PATH]');
        process.exit(2);
    }
    let camera;
    if (a.transforms) {
        camera = cameraFromTransforms(JSON.parse(fs.readFileSync(a.transforms, 'utf8')),
                                      Number(a.frame ?? 0));
    } else if (a.camera) {
        camera = cameraFromJson(JSON.parse(fs.readFileSync(a.camera, 'utf8')));
    } else if (a.matrix) {
        const [width, height] = a.size.split('x').map(Number);
        camera = { matrix: numbers(a.matrix), fovDeg: Number(a['fov-deg']), width, height };
    } else {
        throw new Error('render_glb: give --transforms, --camera or --matrix');
    }
    const light = a.light ? numbers(a.light) : null;
    const result = await renderGlb(a.glb, {
        camera,
        scale: a.scale ? Number(a.scale) : 1,
        light: light ? { direction: light.slice(0, 3), intensity: light[3] ?? Math.PI } : undefined,
        ambient: a.ambient !== undefined ? Number(a.ambient) : undefined,
        unlit: a.unlit,
        background: a.background ? numbers(a.background) : null,
        hide: a.hide ? a.hide.split(',') : [],
        antialias: a.antialias,
        chromium: a.chromium,
    });
    fs.writeFileSync(a.out, result.png);
    console.log(`render_glb: ${a.out} (${result.renderer})`);
}

if (process.argv[1] && path.resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
    main().catch((e) => {
        console.error(e.message ?? e);
        process.exit(1);
    });
}
