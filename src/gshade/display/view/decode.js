/* gshade view, part 1: numbers (half floats, the shortest round-tripping print), unpacking
 * the page's channel data (base64, deflate, the neighbour prediction undone) and the colour
 * tables.  view.js (part 2) uses what this returns; both are inlined into one script. */
const gshadeDecode = (function () {
  "use strict";

  // ------------------------------------------------------------------ numbers

  function halfToFloat(h) {
    const sign = h & 0x8000 ? -1 : 1;
    const exponent = (h >> 10) & 0x1f;
    const fraction = h & 0x3ff;
    if (exponent === 0) return sign * fraction * Math.pow(2, -24);
    if (exponent === 31) return fraction ? NaN : sign * Infinity;
    return sign * (1 + fraction / 1024) * Math.pow(2, exponent - 15);
  }
  const HALF = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) HALF[h] = halfToFloat(h);

  /** The half-precision number nearest x (ties to even). */
  function roundToHalf(x) {
    if (!isFinite(x) || x === 0) return x;
    const a = Math.abs(x);
    if (a >= 65520) return Math.sign(x) * Infinity;
    let e = Math.floor(Math.log2(a));
    if (Math.pow(2, e) > a) e -= 1;
    if (Math.pow(2, e + 1) <= a) e += 1;
    const step = Math.pow(2, Math.max(e, -14) - 10);
    const m = a / step;
    let r = Math.round(m);
    if (m - Math.floor(m) === 0.5 && Math.floor(m) % 2 === 0) r = Math.floor(m);
    return Math.sign(x) * r * step;
  }

  /** The shortest text that reads back to v in the stored precision (float32: at most 9
   * significant digits, half: 5). */
  function formatValue(v, stored) {
    if (Number.isNaN(v)) return "NaN";
    if (!isFinite(v)) return v > 0 ? "inf" : "-inf";
    if (v === 0) return Object.is(v, -0) ? "-0" : "0";
    const digits = stored === "float16" ? 5 : 9;
    const round = stored === "float16" ? roundToHalf : Math.fround;
    for (let k = 1; k <= digits; k++) {
      const s = v.toPrecision(k);
      if (round(parseFloat(s)) === v) return s;
    }
    return v.toPrecision(digits);
  }

  function formatShort(v) {
    if (Number.isNaN(v)) return "NaN";
    if (!isFinite(v)) return v > 0 ? "inf" : "-inf";
    return String(Number(v.toPrecision(4)));
  }

  // ------------------------------------------------------------------ unpacking

  function base64Bytes(text) {
    const s = atob(text);
    const out = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out;
  }

  async function inflate(bytes) {
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Uint8Array(await new Response(stream).arrayBuffer());
  }

  /** Planes (n of height x width, `size` bytes each) from gshade's packing: inflate, join
   * the byte planes, undo the 2-D difference by prefix sums (typed arrays wrap). */
  async function unpackPlanes(text, n, height, width, size) {
    const bytes = await inflate(base64Bytes(text));
    const count = height * width;
    const Kind = size === 1 ? Uint8Array : size === 2 ? Uint16Array : Uint32Array;
    const planes = [];
    for (let p = 0; p < n; p++) {
      const base = p * size * count;
      const out = new Kind(count);
      if (size === 1) out.set(bytes.subarray(base, base + count));
      else if (size === 2) {
        for (let i = 0; i < count; i++) out[i] = bytes[base + i] | (bytes[base + count + i] << 8);
      } else {
        const b1 = base + count, b2 = b1 + count, b3 = b2 + count;
        for (let i = 0; i < count; i++) {
          out[i] = (bytes[base + i] | (bytes[b1 + i] << 8) | (bytes[b2 + i] << 16)) +
            bytes[b3 + i] * 16777216;
        }
      }
      for (let y = 0; y < height; y++) {
        const row = y * width;
        for (let x = 1; x < width; x++) out[row + x] += out[row + x - 1];
      }
      for (let i = width; i < count; i++) out[i] += out[i - width];
      planes.push(out);
    }
    return planes;
  }

  /** An image's channels (a Map: channel names are the file's, and "__proto__" or
   * "length" must stay plain keys) and their stored types (a Map too). */
  async function loadImage(image, width, height) {
    const channels = new Map();
    const stored = new Map();
    for (const c of image.channels) {
      stored.set(c.name, c.stored);
      if (c.same_as !== undefined) {
        channels.set(c.name, channels.get(c.same_as));
        continue;
      }
      if (c.stored === "float16") {
        const [bits] = await unpackPlanes(c.data, 1, height, width, 2);
        const values = new Float32Array(bits.length);
        for (let i = 0; i < bits.length; i++) values[i] = HALF[bits[i]];
        channels.set(c.name, values);
      } else {
        const [bits] = await unpackPlanes(c.data, 1, height, width, 4);
        channels.set(c.name, new Float32Array(bits.buffer));
      }
    }
    let picture = null;
    if (image.picture) {
      const [r, g, b, a] = await unpackPlanes(image.picture, 4, height, width, 1);
      picture = new Uint8ClampedArray(width * height * 4);
      for (let i = 0; i < r.length; i++) {
        picture[4 * i] = r[i];
        picture[4 * i + 1] = g[i];
        picture[4 * i + 2] = b[i];
        picture[4 * i + 3] = a[i];
      }
    }
    let seams = null;
    if (image.seams) {
      const [x2, y2, j] = await unpackPlanes(image.seams.data, 3, 1, image.seams.count, 4);
      seams = { x2, y2, j };
    }
    return { meta: image, channels, stored, picture, seams };
  }

  // ------------------------------------------------------------------ colours

  function table(hex) {
    const out = new Uint8Array(hex.length / 2);
    for (let i = 0; i < out.length; i++) out[i] = parseInt(hex.substr(2 * i, 2), 16);
    return out;
  }

  /** A colour per patch id: hues a golden angle apart (HSL, s 0.65, l 0.55). */
  function patchColour(id) {
    const hue = (((id * 0.618033988749895) % 1) + 1) % 1;
    const l = 0.55, a = 0.65 * Math.min(l, 1 - l);
    const f = (m) => {
      const k = (m + hue * 12) % 12;
      return l - a * Math.max(-1, Math.min(k - 3, 9 - k, 1));
    };
    return [f(0), f(8), f(4)].map((c) => Math.round(c * 255));
  }

  const MAGENTA = [255, 0, 255];

  return { formatValue, formatShort, loadImage, table, patchColour, MAGENTA };
})();
