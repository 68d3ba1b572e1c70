// A small PNG decoder for the readers' checks (no npm package needed): 8-bit greyscale, grey +
// alpha, RGB and RGBA, not interlaced — what sylva and Chromium write. decodePng(bytes) returns
// { width, height, channels, data } (data: Uint8Array, rows top to bottom, `channels` bytes a
// pixel, as stored). PNG specification (W3C, 2nd ed.) §7.3 filters, §11.2.2 IHDR.
import zlib from 'node:zlib';

const kSignature = [137, 80, 78, 71, 13, 10, 26, 10];
const kChannels = { 0: 1, 2: 3, 4: 2, 6: 4 };

export function decodePng(bytes) {
    const b = bytes instanceof Uint8Array ? bytes : new Uint8Array(bytes);
    if (!kSignature.every((v, i) => b[i] === v)) throw new Error('not a PNG');
    const view = new DataView(b.buffer, b.byteOffset, b.byteLength);
    let width = 0, height = 0, channels = 0;
    const idat = [];
    for (let pos = 8; pos + 8 <= b.length;) {
        const length = view.getUint32(pos);
        const type = String.fromCharCode(...b.subarray(pos + 4, pos + 8));
        const data = b.subarray(pos + 8, pos + 8 + length);
        if (type === 'IHDR') {
            width = view.getUint32(pos + 8);
            height = view.getUint32(pos + 12);
            const depth = data[8], colourType = data[9], interlace = data[12];
            channels = kChannels[colourType];
            if (depth !== 8 || !channels || interlace !== 0) {
                throw new Error(`unsupported PNG: depth ${depth}, colour type ${colourType}, ` +
                                `interlace ${interlace}`);
            }
        } else if (type === 'IDAT') {
            idat.push(data);
        } else if (type === 'IEND') {
            break;
        }
        pos += 12 + length;
    }
    const raw = zlib.inflateSync(Buffer.concat(idat));
    const stride = width * channels;
    const out = new Uint8Array(stride * height);
    for (let y = 0; y < height; ++y) {
        const filter = raw[y * (stride + 1)];
        const src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
        const row = out.subarray(y * stride, (y + 1) * stride);
        const up = y > 0 ? out.subarray((y - 1) * stride, y * stride) : new Uint8Array(stride);
        for (let i = 0; i < stride; ++i) {
            const a = i >= channels ? row[i - channels] : 0;
            const c = i >= channels ? up[i - channels] : 0;
            const u = up[i];
            let p;
            switch (filter) {
                case 0: p = 0; break;
                case 1: p = a; break;
                case 2: p = u; break;
                case 3: p = (a + u) >> 1; break;
                case 4: {
                    const e = a + u - c, pa = Math.abs(e - a), pb = Math.abs(e - u),
                          pc = Math.abs(e - c);
                    p = pa <= pb && pa <= pc ? a : pb <= pc ? u : c;
                    break;
                }
                default: throw new Error(`bad PNG filter ${filter} in row ${y}`);
            }
            row[i] = (src[i] + p) & 255;
        }
    }
    return { width, height, channels, data: out };
}

// sRGB ↔ linear (IEC 61966-2-1), one channel in [0, 1]: as species/model/look.cpp.
export const srgbToLinear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
export const linearToSrgb = (c) => {
    c = Math.min(1, Math.max(0, c));
    return c <= 0.0031308 ? 12.92 * c : 1.055 * c ** (1 / 2.4) - 0.055;
};

// The mean linear RGB of the pixels of an RGB(A) image `img` (decodePng's) that `keep(i)`
// accepts (i: the pixel's index), and how many there were.
export function meanLinear(img, keep = () => true) {
    const sum = [0, 0, 0];
    let n = 0;
    for (let i = 0; i < img.width * img.height; ++i) {
        if (!keep(i)) continue;
        for (let c = 0; c < 3; ++c) sum[c] += srgbToLinear(img.data[i * img.channels + c] / 255);
        ++n;
    }
    return { mean: sum.map((s) => s / Math.max(1, n)), count: n };
}
