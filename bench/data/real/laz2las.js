// Decompresses a LAZ file to plain LAS for bench/sim2real.py, with the npm package laz-perf
// (Apache-2.0), installed in the working directory:
//   npm install laz-perf@0.0.7 && node PATH/TO/laz2las.js in.laz out.las
// The header and VLRs are copied as they are (the compression bits of the point format cleared);
// the points follow at the header's offset to point data.
const fs = require('fs');
// laz-perf is looked up from the working directory too, so it can be installed anywhere.
const { createLazPerf } = require(require.resolve('laz-perf', { paths: [process.cwd(), __dirname] }));

(async () => {
  const [inPath, outPath] = process.argv.slice(2);
  const buf = fs.readFileSync(inPath);
  const LazPerf = await createLazPerf();
  const offsetToPoints = buf.readUInt32LE(96);
  const fmtByte = buf[104];
  const recLen = buf.readUInt16LE(105);
  const filePtr = LazPerf._malloc(buf.length);
  LazPerf.HEAPU8.set(buf, filePtr);
  const laszip = new LazPerf.LASZip();
  laszip.open(filePtr, buf.length);
  const n = laszip.getCount();
  const len = laszip.getPointLength();
  if (len !== recLen) console.error('record length', len, 'header says', recLen);
  const out = Buffer.alloc(offsetToPoints + n * len);
  buf.copy(out, 0, 0, offsetToPoints);
  out[104] = fmtByte & 0x3f;
  const pt = LazPerf._malloc(len);
  for (let i = 0; i < n; i++) {
    laszip.getPoint(pt);
    out.set(LazPerf.HEAPU8.subarray(pt, pt + len), offsetToPoints + i * len);
  }
  laszip.delete();
  LazPerf._free(pt);
  LazPerf._free(filePtr);
  fs.writeFileSync(outPath, out);
  console.log(JSON.stringify({ points: n, record_length: len, format: fmtByte & 0x3f,
                               version: buf[24] + '.' + buf[25] }));
})();
