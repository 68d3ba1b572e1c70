// Reads the scans `sylva build` wrote (tests/cli/test-scan-readers builds
// tests/data/scan/tls_trees.toml and uls_plot.toml) with the npm package `copc` (Las.Header,
// Las.Vlr, Las.ExtraBytes, Las.View: a LAS 1.4 reader sylva did not write) and checks, for every
// manifest record with a `scan` block, what must hold of any real scan (exit 1 on a failure):
//   - the header: LAS 1.4, point format 6 (7 when the spec's las_colour is set), point count =
//     the manifest's scan.points, points by return = the counted returns, scale 0.001, offset =
//     floor of the smallest coordinate, min/max = the extents of the points (every point inside);
//   - per point: treeID in {0} ∪ the tree ids (1 for a single tree; a plot's trees.csv ids),
//     and 0 exactly on ground points; classification in {1, 2, 4, 5, 6} and consistent with
//     semantic_seg (terrain 2 and low vegetation 1 → 1; stem 4 and woody branches 6 → 2; live
//     branches 5 → 2 (its wood) or 3 (leaves)) and with the part hit (user data); branch_order 0
//     on stems; node_id −1 exactly when the hit is not wood; 1 ≤ return number ≤ number of
//     returns ≤ the platform's max_returns; GPS time non-decreasing (pulse order); a single
//     tree's TLS points within [min_range, max_range] of the station; with RGB by tree, one
//     colour per tree, grey for 0;
//   - the manifest's scan block: class fractions and points per TLS station (point source ID)
//     equal to the counts, every tree of scan.trees with wood_surface_hit > 0 has wood points,
//     no points of a tree the list does not name;
//   - occlusion: a single tree's TLS scan from one station has more of the tree's points on the
//     station's side of its base than on the far side, and at least 99 % of its stem points lie
//     on the face of their cylinder (qsm.csv, the row of the point's node_id) that looks at the
//     station (less than 120° round the axis from the station's direction): the back of the
//     trunk is not seen;
//   - scan.laz (when the spec's formats have "laz"): copc decompresses it (Las.PointData, the
//     npm package `laz-perf`) to scan.las's records byte for byte, and its header is scan.las's
//     but for the point format's compression bit (7), the VLR count (3: the LASzip VLR) and the
//     offset to the points.
// It also writes what copc read, per record, to OUT/copc/<id>.f64 (float64, one row per point:
// x y z classification treeID treeSP semantic_seg return number, number of returns, intensity,
// gps_time, branch_order, node_id) for tests/python/test_scan_build.py to compare with numpy and
// sylva_dataset.
//
// Usage: node tests/js/check_scan_build.mjs OUT DATASET_DIR...
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

import { checker } from './expect.mjs';

const { Las } = createRequire(import.meta.url)('copc');

const [out, ...datasets] = process.argv.slice(2);
if (!out || datasets.length === 0) {
    console.error('usage: node check_scan_build.mjs OUT DATASET_DIR...');
    process.exit(2);
}
const { failures, fail, expectEq, expectNear } = checker();
// A point that fails a per-point rule is reported once per rule (the first one), with a count.
const pointFailures = new Map();
const pointFail = (what, detail) => {
    const f = pointFailures.get(what);
    if (f) f.count += 1;
    else pointFailures.set(what, { count: 1, detail });
};

const DEFAULT_MAX_RETURNS = { tls: 15, uls: 5, als: 4 };  // docs/scanning.md, the [scan] table
const CLASS_NAMES = ['unclassified', 'low_vegetation', 'terrain', 'out_points', 'stem',
    'live_branches', 'woody_branches'];
// The part hit (LAS user data, the plot's part codes) → the FOR-instance classes it may have.
const PART_CLASSES = { 0: [2], 1: [4], 2: [5, 6], 3: [5], 4: [4], 5: [1] };
// semantic_seg → the classes it may have (ForestFormer3D: 1 ground, 2 wood, 3 leaf).
const SEMANTIC_CLASSES = { 1: [1, 2], 2: [4, 5, 6], 3: [5] };
const COLUMNS = ['X', 'Y', 'Z', 'Classification', 'treeID', 'treeSP', 'semantic_seg',
    'ReturnNumber', 'NumberOfReturns', 'Intensity', 'GpsTime', 'branch_order', 'node_id'];
fs.mkdirSync(path.join(out, 'copc'), { recursive: true });

async function checkLaz(dir, record, las) {
    const w = (what) => `${record.id}: scan.laz: ${what}`;
    const laz = new Uint8Array(fs.readFileSync(path.join(dir, record.files.scan_laz)));
    const lasHeader = Las.Header.parse(las);
    const lazHeader = Las.Header.parse(laz);
    expectEq(w('point format byte'), laz[104], las[104] | 128);
    expectEq(w('VLR count'), lazHeader.vlrCount, 3);
    for (let k = 0; k < 375; ++k) {
        if (k >= 96 && k <= 104) continue;  // offset to points, VLR count, point format
        if (laz[k] !== las[k]) {
            fail(w(`header byte ${k}: ${laz[k]}, scan.las has ${las[k]}`));
            break;
        }
    }
    const records = await Las.PointData.decompressFile(laz);
    expectEq(w('decompressed records = scan.las records'),
        Buffer.compare(records, las.subarray(lasHeader.pointDataOffset)), 0);
    return laz.length;
}

function treeIds(dir, record) {
    if (record.kind !== 'plot') return [1];
    const csv = fs.readFileSync(path.join(dir, record.files.trees_csv), 'utf8').trim().split('\n');
    const col = csv[0].split(',').indexOf('id');
    return csv.slice(1).map((row) => Number(row.split(',')[col]));
}

async function checkRecord(dir, spec, record) {
    const w = (what) => `${record.id}: ${what}`;
    const scan = record.scan;
    const filename = path.join(dir, record.files.scan_las);
    const buffer = new Uint8Array(fs.readFileSync(filename));
    const header = Las.Header.parse(buffer);
    const colour = (spec.scan.las_colour ?? 'none') !== 'none';
    expectEq(w('version'), `${header.majorVersion}.${header.minorVersion}`, '1.4');
    expectEq(w('point format'), header.pointDataRecordFormat, colour ? 7 : 6);
    expectEq(w('point count = manifest scan.points'), header.pointCount, scan.points);
    const N = header.pointCount;
    const lazBytes = record.files.scan_laz ? await checkLaz(dir, record, buffer) : 0;
    const vlrs = await Las.Vlr.walk(filename, header);
    const ebVlr = Las.Vlr.find(vlrs, 'LASF_Spec', 4);
    if (!ebVlr) {
        fail(w('no Extra Bytes VLR (LASF_Spec 4)'));
        return;
    }
    const eb = Las.ExtraBytes.parse(await Las.Vlr.fetch(filename, ebVlr));
    const data = buffer.subarray(header.pointDataOffset,
        header.pointDataOffset + N * header.pointDataRecordLength);
    const view = Las.View.create(data, header, eb);
    const get = {};
    for (const name of Object.keys(view.dimensions)) get[name] = view.getter(name);
    for (const name of COLUMNS) {
        if (!get[name]) {
            fail(w(`copc's view has no dimension ${name}`));
            return;
        }
    }

    const platform = spec.scan.platform ?? 'tls';
    const maxReturns = spec.scan.max_returns ?? DEFAULT_MAX_RETURNS[platform];
    const ids = new Set(treeIds(dir, record));
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    const byReturn = new Array(15).fill(0);
    const byClass = new Array(256).fill(0);
    const bySource = new Map();
    const pointsOfTree = new Map(), woodOfTree = new Map(), colourOfTree = new Map();
    // Occlusion (a single tree, one TLS station): the tree's points on either side of the plane
    // through the trunk (x = y = 0 in the survey frame) facing the station.
    const station = platform === 'tls' && record.kind !== 'plot' && spec.scan.stations?.length === 1
        ? JSON.parse(fs.readFileSync(path.join(dir, record.files.scan_stations), 'utf8'))[0] : null;
    const minRange = spec.scan.min_range ?? 1.5, maxRange = spec.scan.max_range ?? 600;  // TLS defaults
    const side = { near: 0, far: 0, stemNear: 0, stemFar: 0 };
    const cylinders = new Map();  // node_id → the QSM cylinder (survey frame) ending at it
    if (station) {
        const csv = fs.readFileSync(path.join(dir, record.files.qsm_csv), 'utf8').trim().split('\n');
        const col = Object.fromEntries(csv[0].split(',').map((name, k) => [name, k]));
        for (const row of csv.slice(1).map((l) => l.split(',').map(Number))) {
            cylinders.set(row[col.node_id], {
                start: [row[col.start_x], row[col.start_y], row[col.start_z]],
                axis: [row[col.axis_x], row[col.axis_y], row[col.axis_z]],
            });
        }
    }
    const rows = new Float64Array(N * COLUMNS.length);
    const at = (i, what) => w(`point ${i}: ${what}`);
    for (let i = 0; i < N; ++i) {
        const p = {};
        COLUMNS.forEach((name, c) => {
            p[name] = get[name](i);
            rows[i * COLUMNS.length + c] = p[name];
        });
        const xyz = [p.X, p.Y, p.Z];
        xyz.forEach((v, a) => { lo[a] = Math.min(lo[a], v); hi[a] = Math.max(hi[a], v); });
        xyz.forEach((v, a) => {
            if (v < header.min[a] || v > header.max[a]) pointFail(w(`point outside the header bounds on axis ${a}`), at(i, v));
        });
        if (i > 0 && p.GpsTime < rows[(i - 1) * COLUMNS.length + 10]) {
            pointFail(w('GPS time decreasing (points are in pulse order)'), at(i, p.GpsTime));
        }
        if (station) {
            const range = Math.hypot(p.X - station.x, p.Y - station.y, p.Z - station.z);
            if (!(range >= minRange - 0.1 && range <= maxRange + 0.1)) {
                pointFail(w(`range from the station outside [${minRange}, ${maxRange}] m`), at(i, range));
            }
        }
        const cls = p.Classification, sem = p.semantic_seg, part = get.UserData(i), tree = p.treeID;
        byClass[cls] += 1;
        byReturn[p.ReturnNumber - 1] += 1;
        const src = get.PointSourceId(i);
        bySource.set(src, (bySource.get(src) ?? 0) + 1);
        if (![1, 2, 4, 5, 6].includes(cls)) pointFail(w('classification not in {1, 2, 4, 5, 6}'), at(i, cls));
        if (!(SEMANTIC_CLASSES[sem] ?? []).includes(cls)) {
            pointFail(w('classification inconsistent with semantic_seg'), at(i, `class ${cls}, semantic ${sem}`));
        }
        if (!(PART_CLASSES[part] ?? []).includes(cls)) {
            pointFail(w('classification inconsistent with the part hit (user data)'), at(i, `class ${cls}, part ${part}`));
        }
        if (tree !== 0 && !ids.has(tree)) pointFail(w('treeID not a tree of the instance'), at(i, tree));
        if ((tree === 0) !== (sem === 1)) pointFail(w('treeID 0 not exactly on ground points'), at(i, `tree ${tree}, semantic ${sem}`));
        if (part === 1 && p.branch_order !== 0) pointFail(w('stem point with branch_order ≠ 0'), at(i, p.branch_order));
        if ((p.node_id === -1) !== (sem !== 2)) pointFail(w('node_id −1 not exactly on non-wood points'), at(i, `node ${p.node_id}, semantic ${sem}`));
        if (!(p.ReturnNumber >= 1 && p.ReturnNumber <= p.NumberOfReturns && p.NumberOfReturns <= maxReturns)) {
            pointFail(w(`not 1 ≤ return number ≤ number of returns ≤ max_returns ${maxReturns}`),
                at(i, `${p.ReturnNumber} of ${p.NumberOfReturns}`));
        }
        pointsOfTree.set(tree, (pointsOfTree.get(tree) ?? 0) + 1);
        if (sem === 2) woodOfTree.set(tree, (woodOfTree.get(tree) ?? 0) + 1);
        if (colour) {
            const rgb = `${get.Red(i)},${get.Green(i)},${get.Blue(i)}`;
            if (spec.scan.las_colour === 'tree') {
                const seen = colourOfTree.get(tree);
                if (seen === undefined) colourOfTree.set(tree, rgb);
                else if (seen !== rgb) pointFail(w('two colours for one tree'), at(i, `tree ${tree}: ${seen} and ${rgb}`));
            }
        }
        if (station && tree === 1) {
            // The station's side: the half-plane through the trunk towards the station.
            const near = p.X * station.x + p.Y * station.y > 0;
            side[near ? 'near' : 'far'] += 1;
            // A stem point lies on the face of its cylinder (the QSM row ending at its node)
            // that looks at the station: its offset from the axis points towards the station.
            const c = part === 1 ? cylinders.get(p.node_id) : undefined;
            if (c) {
                const d = [p.X - c.start[0], p.Y - c.start[1], p.Z - c.start[2]];
                const t = d[0] * c.axis[0] + d[1] * c.axis[1] + d[2] * c.axis[2];
                const foot = c.start.map((v, a) => v + t * c.axis[a]);
                const radial = xyz.map((v, a) => v - foot[a]);
                const look = [station.x - foot[0], station.y - foot[1], station.z - foot[2]];
                const along = look[0] * c.axis[0] + look[1] * c.axis[1] + look[2] * c.axis[2];
                const across = look.map((v, a) => v - along * c.axis[a]);  // ⟂ to the axis
                const norm = (v) => Math.hypot(v[0], v[1], v[2]);
                const cos = (radial[0] * across[0] + radial[1] * across[1] + radial[2] * across[2]) /
                    (norm(radial) * norm(across));
                // The silhouette (cos ≈ 0) is hit by the beam's edge and moved by range noise;
                // a point more than 60° round the back is on the far face.
                side[cos > -0.5 ? 'stemNear' : 'stemFar'] += 1;
            }
        }
    }
    for (const [what, { count, detail }] of pointFailures) fail(`${what}: ${count} points, first ${detail}`);
    pointFailures.clear();

    for (let k = 0; k < 15; ++k) {
        expectEq(w(`header points of return ${k + 1}`), header.pointCountByReturn[k], byReturn[k]);
    }
    const scale = 0.001;
    for (let a = 0; a < 3; ++a) {
        expectEq(w(`scale[${a}]`), header.scale[a], scale);
        expectEq(w(`offset[${a}]`), header.offset[a], Math.floor(lo[a] + 1e-9));
        expectNear(w(`min[${a}]`), header.min[a], lo[a], 1e-9);
        expectNear(w(`max[${a}]`), header.max[a], hi[a], 1e-9);
    }

    // The manifest's statistics against the points.
    CLASS_NAMES.forEach((name, c) => {
        expectNear(w(`scan.class_fraction.${name}`), scan.class_fraction?.[name], N ? byClass[c] / N : 0, 1e-12);
    });
    if (platform === 'tls') {
        const perStation = scan.points_per_station ?? [];
        // Station k's points carry point source ID k + 1 (LAS reads 0 as "no source").
        perStation.forEach((n, k) => expectEq(w(`scan.points_per_station[${k}] = points of source ${k + 1}`), bySource.get(k + 1) ?? 0, n));
        expectEq(w('point source ids'), bySource.size <= perStation.length, true);
        expectEq(w('no point of source 0'), bySource.has(0), false);
    }
    const listed = new Set();
    for (const t of scan.trees ?? []) {
        listed.add(t.tree);
        if (!ids.has(t.tree)) fail(w(`scan.trees names tree ${t.tree}, not a tree of the instance`));
        if (t.wood_surface_hit > 0 && !(woodOfTree.get(t.tree) > 0)) {
            fail(w(`tree ${t.tree}: wood_surface_hit ${t.wood_surface_hit} but no wood points`));
        }
        if (t.wood_surface_hit === 0 && woodOfTree.get(t.tree) > 0) {
            fail(w(`tree ${t.tree}: wood_surface_hit 0 but ${woodOfTree.get(t.tree)} wood points`));
        }
    }
    for (const t of pointsOfTree.keys()) {
        if (t !== 0 && !listed.has(t)) fail(w(`${pointsOfTree.get(t)} points of tree ${t}, which scan.trees does not list`));
    }
    if (spec.scan.las_colour === 'tree') {
        if (colourOfTree.has(0)) expectEq(w('colour of treeID 0'), colourOfTree.get(0), `${128 * 257},${128 * 257},${128 * 257}`);
        const colours = [...colourOfTree.values()];
        expectEq(w('distinct colours per tree'), new Set(colours).size, colours.length);
    }
    if (station) {
        if (!(side.near > side.far)) fail(w(`occlusion: ${side.near} points of the tree on the station's side, ${side.far} behind the trunk`));
        if (!(side.stemNear > 0 && side.stemNear >= 0.99 * (side.stemNear + side.stemFar))) {
            fail(w(`occlusion: ${side.stemNear} stem points on the faces of their cylinders that look at the station, ${side.stemFar} on the far faces`));
        }
    }
    fs.writeFileSync(path.join(out, 'copc', `${record.id}.f64`), Buffer.from(rows.buffer));
    return { id: record.id, points: N, trees: pointsOfTree.size - (pointsOfTree.has(0) ? 1 : 0), side,
        lazBytes };
}

const summary = [];
for (const dir of datasets) {
    const spec = JSON.parse(fs.readFileSync(path.join(dir, 'dataset.json'), 'utf8')).spec;
    const records = fs.readFileSync(path.join(dir, 'manifest.jsonl'), 'utf8').split('\n')
        .filter((l) => l.trim()).map((l) => JSON.parse(l));
    const scanned = records.filter((r) => r.scan);
    if (scanned.length === 0 || scanned.length !== records.length) {
        fail(`${dir}: ${scanned.length} of ${records.length} records have a scan block`);
    }
    for (const record of scanned) {
        const s = await checkRecord(dir, spec, record);
        if (s) summary.push(s);
    }
}

if (failures.length) {
    for (const f of failures.slice(0, 40)) console.error(`check_scan_build: ${f}`);
    if (failures.length > 40) console.error(`check_scan_build: … ${failures.length - 40} more`);
    process.exit(1);
}
console.log(`check_scan_build: ${summary.map((s) => `${s.id} ${s.points} points, ${s.trees} trees` +
    (s.side.near + s.side.far ? ` (near/far of trunk ${s.side.near}/${s.side.far}, stem ${s.side.stemNear}/${s.side.stemFar})` : '') +
    (s.lazBytes ? `, scan.laz ${s.lazBytes} bytes = scan.las decompressed` : '')).join('; ')}`);
