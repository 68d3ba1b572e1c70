// Reads sylva's LAS 1.4 files with the npm package `copc` (Las.Header, Las.Vlr, Las.ExtraBytes,
// Las.View: a LAS 1.4 reader of point formats 0–3 and 6–8 that sylva did not write) and checks
// them against the closed-form scan they were written from (formulaScan in
// tests/pipeline/formats/scan_writers_test.cpp, 300 points, GPS start 123456.5), failing (exit 1)
// on the first class of problem:
//   - the header: version 1.4, 375 bytes, global encoding 17, point format 6 (formula.las) or 7
//     (formula_rgb.las), record length, 2 VLRs, point count, points by return, scale, offset,
//     bounds;
//   - the VLRs: the WKT (LASF_Projection 2112) and the Extra Bytes (LASF_Spec 4): the eight
//     fields' names, types, sizes, minima and maxima (the six labels), node_id's no-data value,
//     the scale of elevation and label_purity;
//   - every point, through the field readers copc builds from the header and the extra-bytes
//     list: X, Y, Z within half the scale, intensity, return number and number of returns,
//     scanner channel, scan direction, edge of flight line, classification, user data, scan
//     angle, GPS time, RGB (format 7), and each extra-bytes field.
// Then the same checks on formula.laz and formula_rgb.laz (the same points, LAZ-compressed in
// chunks of 64 points), whose records copc decompresses with the npm package `laz-perf` (the
// WebAssembly build of the LAZ library, Las.PointData.decompressFile): the header with the
// compression bit, a third VLR (the LASzip VLR, "laszip encoded" 22204), and the decompressed
// records equal to the LAS file's byte for byte.
//
// Usage: node tests/js/check_scan.mjs DIR   (the directory ScanOutputs.WritesFilesForReaders
// wrote)
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

import { checker } from './expect.mjs';

const { Las } = createRequire(import.meta.url)('copc');

const dir = process.argv[2];
if (!dir) {
    console.error('usage: node check_scan.mjs DIR');
    process.exit(2);
}
const { failures, fail, expectEq, expectNear } = checker();

// The scan, point i, as formulaScan writes it (scene frame, +y up) ...
const N = 300;
const GPS_START = 123456.5;
const SCALE = 0.001;
function scenePoint(i) {
    const nr = 1 + (Math.floor(i / 4) % 15);
    return {
        x: -12.5 + 0.0731 * i,
        y: -1.0 + 0.043 * i,
        z: 7.25 - 0.0517 * i,
        gpsTime: 0.001 * i + 0.000001 * (i % 7),
        intensity: (i * 40503) % 65536,
        numberOfReturns: nr,
        returnNumber: 1 + (i % nr),
        channel: i % 4,
        sourceId: i % 8,
        scanDirection: i % 2,
        edge: i % 11 === 0 ? 1 : 0,
        scanAngle: -45 + 0.3 * i,
        // Stored as integers of 0.01 (float32 in the writer, rounded half away from zero).
        elevation: Math.round(Math.fround(-40 + 0.37 * i) / 0.01),
        label_purity: Math.round(Math.fround(0.2 + 0.1 * (i % 9)) / 0.01),
        treeID: i % 6,
        node_id: (i % 9) - 1,
        hitObjectId: (i * 13) % 1000,
        treeSP: (i * 37) % 1000,
        part: i % 6,
        branch_order: i % 4,
        classification: i % 7,
        semantic_seg: i % 4,
    };
}
// ... and in the survey frame of the LAS file: x east = x, y north = −z, z up = y.
const survey = (p) => [p.x, -p.z, p.y];
// The FOR-instance class colours of format 7 (docs/scanning.md), 8-bit.
const classColour = [
    [128, 128, 128], [154, 205, 50], [139, 115, 85], [255, 0, 255], [139, 69, 19],
    [34, 139, 34], [210, 180, 140],
];
const extraBytes = [  // name, copc type, size, min, max over the formula (none: scaled)
    ['treeID', 'signed', 4, 0, 5],
    ['treeSP', 'unsigned', 2, 0, 999],
    ['semantic_seg', 'unsigned', 1, 0, 3],
    ['hitObjectId', 'signed', 4, 0, 990],
    ['branch_order', 'unsigned', 1, 0, 3],
    ['node_id', 'signed', 4, -1, 7],
    ['elevation', 'signed', 2, undefined, undefined],
    ['label_purity', 'unsigned', 1, undefined, undefined],
];
const scaled = new Set(['elevation', 'label_purity']);

// `las`: for a LAZ file, the LAS file of the same points (its records are compared).
async function check(file, format, las) {
    const filename = path.join(dir, file);
    const buffer = new Uint8Array(fs.readFileSync(filename));
    const header = Las.Header.parse(buffer);
    const w = (what) => `${file}: ${what}`;
    // copc masks the format byte; the compression bit (7) is in the file.
    expectEq(w('point format byte'), buffer[104], las ? format | 128 : format);
    expectEq(w('version'), `${header.majorVersion}.${header.minorVersion}`, '1.4');
    expectEq(w('header size'), header.headerLength, 375);
    expectEq(w('global encoding'), header.globalEncoding, 17);
    expectEq(w('point format'), header.pointDataRecordFormat, format);
    expectEq(w('record length'), header.pointDataRecordLength, (format === 7 ? 36 : 30) + 19);
    expectEq(w('VLR count'), header.vlrCount, las ? 3 : 2);
    expectEq(w('point count'), header.pointCount, N);
    expectEq(w('generating software'), header.generatingSoftware.startsWith('sylva '), true);
    const byReturn = new Array(15).fill(0);
    const points = [...Array(N).keys()].map(scenePoint);
    for (const p of points) byReturn[p.returnNumber - 1] += 1;
    for (let k = 0; k < 15; ++k) {
        expectEq(w(`points of return ${k + 1}`), header.pointCountByReturn[k], byReturn[k]);
    }
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (const p of points) {
        survey(p).forEach((v, a) => { lo[a] = Math.min(lo[a], v); hi[a] = Math.max(hi[a], v); });
    }
    for (let a = 0; a < 3; ++a) {
        expectEq(w(`scale[${a}]`), header.scale[a], SCALE);
        expectEq(w(`offset[${a}]`), header.offset[a], Math.floor(lo[a]));
        expectNear(w(`min[${a}]`), header.min[a], lo[a], SCALE / 2 + 1e-9);
        expectNear(w(`max[${a}]`), header.max[a], hi[a], SCALE / 2 + 1e-9);
    }

    const vlrs = await Las.Vlr.walk(filename, header);
    const wktVlr = Las.Vlr.find(vlrs, 'LASF_Projection', 2112);
    if (!wktVlr) fail(w('no WKT VLR (LASF_Projection 2112)'));
    else {
        const wkt = Buffer.from(await Las.Vlr.fetch(filename, wktVlr)).toString('latin1');
        if (!wkt.startsWith('LOCAL_CS[') || !wkt.endsWith('\0')) fail(w(`WKT ${wkt}`));
    }
    if (las && !Las.Vlr.find(vlrs, 'laszip encoded', 22204)) {
        fail(w('no LASzip VLR (laszip encoded 22204)'));
    }
    const ebVlr = Las.Vlr.find(vlrs, 'LASF_Spec', 4);
    if (!ebVlr) {
        fail(w('no Extra Bytes VLR (LASF_Spec 4)'));
        return;
    }
    const ebPayload = await Las.Vlr.fetch(filename, ebVlr);
    const eb = Las.ExtraBytes.parse(ebPayload);
    expectEq(w('extra-bytes fields'), eb.map((e) => e.name).join(','),
        extraBytes.map((e) => e[0]).join(','));
    for (const [name, type, size, min, max] of extraBytes) {
        const e = eb.find((v) => v.name === name);
        if (!e) continue;
        expectEq(w(`${name} type`), e.type, type);
        expectEq(w(`${name} size`), e.length, size);
        expectEq(w(`${name} min`), e.min, min);
        expectEq(w(`${name} max`), e.max, max);
        expectEq(w(`${name} no-data`), e.nodata, name === 'node_id' ? -1 : undefined);
        // copc sees whether a scale is set, but reads its double big-endian: read it here.
        expectEq(w(`${name} has a scale`), e.scale !== undefined, scaled.has(name));
        const k = eb.indexOf(e);
        const dv = new DataView(ebPayload.buffer, ebPayload.byteOffset + 192 * k, 192);
        expectEq(w(`${name} scale`), dv.getFloat64(112, true), scaled.has(name) ? 0.01 : 0);
    }

    // The points, through copc's field readers: Las.View builds one per dimension of the point
    // format plus one per extra-bytes field (it is handed the list parsed above).
    const data = las ? await Las.PointData.decompressFile(buffer)
        : buffer.subarray(header.pointDataOffset,
            header.pointDataOffset + N * header.pointDataRecordLength);
    if (las) {
        const lasBuffer = new Uint8Array(fs.readFileSync(path.join(dir, las)));
        const lasHeader = Las.Header.parse(lasBuffer);
        const records = lasBuffer.subarray(lasHeader.pointDataOffset);
        expectEq(w(`decompressed records equal ${las}'s`), Buffer.compare(data, records), 0);
    }
    const view = Las.View.create(data, header, eb);
    expectEq(w('view point count'), view.pointCount, N);
    for (const [name, type, size] of extraBytes) {
        const d = view.dimensions[name];
        if (!d || d.type !== type || d.size !== size) {
            fail(w(`copc's view has no ${type} ${size}-byte dimension ${name}: ${JSON.stringify(d)}`));
        }
    }
    const get = {};
    for (const name of Object.keys(view.dimensions)) get[name] = view.getter(name);
    for (let i = 0; i < N; ++i) {
        const p = points[i];
        const s = survey(p);
        const at = (what) => w(`point ${i} ${what}`);
        ['X', 'Y', 'Z'].forEach((d, a) => expectNear(at(d), get[d](i), s[a], SCALE / 2 + 1e-9));
        ['X', 'Y', 'Z'].forEach((d, a) => {
            if (get[d](i) < header.min[a] || get[d](i) > header.max[a]) fail(at(`${d} outside bounds`));
        });
        expectEq(at('Intensity'), get.Intensity(i), p.intensity);
        expectEq(at('ReturnNumber'), get.ReturnNumber(i), p.returnNumber);
        expectEq(at('NumberOfReturns'), get.NumberOfReturns(i), p.numberOfReturns);
        expectEq(at('ScannerChannel'), get.ScannerChannel(i), p.channel);
        expectEq(at('ScanDirectionFlag'), get.ScanDirectionFlag(i), p.scanDirection);
        expectEq(at('EdgeOfFlightLine'), get.EdgeOfFlightLine(i), p.edge);
        for (const flag of ['Synthetic', 'KeyPoint', 'Withheld', 'Overlap']) {
            expectEq(at(flag), get[flag](i), 0);
        }
        expectEq(at('Classification'), get.Classification(i), p.classification);
        expectEq(at('UserData'), get.UserData(i), p.part);
        expectNear(at('ScanAngle'), get.ScanAngle(i), p.scanAngle, 0.003 + 1e-5);
        expectEq(at('PointSourceId'), get.PointSourceId(i), p.sourceId);
        expectNear(at('GpsTime'), get.GpsTime(i), GPS_START + p.gpsTime, 1e-9);
        if (format === 7) {
            const c = classColour[p.classification];
            expectEq(at('Red'), get.Red(i), c[0] * 257);
            expectEq(at('Green'), get.Green(i), c[1] * 257);
            expectEq(at('Blue'), get.Blue(i), c[2] * 257);
        }
        for (const [name] of extraBytes) {
            if (!get[name]) continue;
            if (!scaled.has(name)) {
                expectEq(at(name), get[name](i), p[name]);
                continue;
            }
            // copc's view multiplies by the scale it read (big-endian, as above): divided by
            // that again, the stored integer.
            const e = eb.find((v) => v.name === name);
            expectNear(at(name), get[name](i) / e.scale, p[name], 1e-6);
        }
    }
}

await check('formula.las', 6);
await check('formula_rgb.las', 7);
await check('formula.laz', 6, 'formula.las');
await check('formula_rgb.laz', 7, 'formula_rgb.las');

if (failures.length) {
    for (const f of failures.slice(0, 40)) console.error(`check_scan: ${f}`);
    if (failures.length > 40) console.error(`check_scan: … ${failures.length - 40} more`);
    process.exit(1);
}
console.log(`check_scan: formula.las (format 6) and formula_rgb.las (format 7), and both as LAZ ` +
    `(decompressed by laz-perf): ${N} points, header, WKT, 8 extra-bytes fields and every ` +
    'field of every point as copc reads them');
