// A decoder for the 16-bit PNGs of `derma export web` (greyscale, RGB or RGBA, not interlaced):
// chunks parsed here, the zlib stream inflated by the browser's DecompressionStream, and the five
// scanline filters of the PNG specification (ISO/IEC 15948, §9) undone byte by byte.

const CHANNELS = { 0: 1, 2: 3, 4: 2, 6: 4 };

async function inflate(bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

/** `bytes` of a PNG → {width, height, channels, data: Uint16Array}; `name` labels errors. */
export async function decodePng16(bytes, name) {
  const sig = [137, 80, 78, 71, 13, 10, 26, 10];
  if (!sig.every((b, i) => bytes[i] === b)) throw new Error(`${name}: not a PNG file`);
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  let width = 0, height = 0, depth = 0, type = 0, interlace = 0;
  const idat = [];
  for (let p = 8; p + 8 <= bytes.length; ) {
    const len = view.getUint32(p);
    const kind = String.fromCharCode(...bytes.subarray(p + 4, p + 8));
    const body = bytes.subarray(p + 8, p + 8 + len);
    if (kind === 'IHDR') {
      width = view.getUint32(p + 8);
      height = view.getUint32(p + 12);
      depth = body[8];
      type = body[9];
      interlace = body[12];
    } else if (kind === 'IDAT') idat.push(body);
    else if (kind === 'IEND') break;
    p += 12 + len;
  }
  const channels = CHANNELS[type];
  if (depth !== 16 || !channels) throw new Error(`${name}: ${depth}-bit colour type ${type}; expected a 16-bit greyscale, RGB or RGBA PNG`);
  if (interlace) throw new Error(`${name}: interlaced; expected a non-interlaced PNG`);
  const raw = await inflate(new Blob(idat));
  const bpp = 2 * channels;
  const stride = width * bpp;
  if (raw.length < height * (stride + 1)) throw new Error(`${name}: image data ends early`);
  const out = new Uint8Array(height * stride);
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    const cur = out.subarray(y * stride, (y + 1) * stride);
    const prev = y > 0 ? out.subarray((y - 1) * stride, y * stride) : new Uint8Array(stride);
    for (let x = 0; x < stride; x++) {
      const a = x >= bpp ? cur[x - bpp] : 0;
      const b = prev[x];
      const c = x >= bpp ? prev[x - bpp] : 0;
      let pred;
      switch (filter) {
        case 0: pred = 0; break;
        case 1: pred = a; break;
        case 2: pred = b; break;
        case 3: pred = (a + b) >> 1; break;
        case 4: {
          const p = a + b - c;
          const pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
          pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
          break;
        }
        default: throw new Error(`${name}: row ${y} has filter type ${filter}; expected 0–4`);
      }
      cur[x] = (line[x] + pred) & 255;
    }
  }
  const data = new Uint16Array(width * height * channels);
  for (let i = 0; i < data.length; i++) data[i] = (out[2 * i] << 8) | out[2 * i + 1];
  return { width, height, channels, data };
}
