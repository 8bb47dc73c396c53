// prt-png.js - reads 8-bit PNG images (grey, grey+alpha, RGB, RGBA; not
// interlaced) for the relighting page (a browser global PrtPNG: the
// lightmap's coefficient textures and materials) and the node tests
// (require: tests/js/png.js). The caller inflates the zlib stream (the page
// with DecompressionStream, node with zlib): this file is the chunks and
// the five row filters (PNG specification, section 9), so the bytes arrive
// as stored, with no colour management and no premultiplied alpha.
(function (root) {
  'use strict';

  // The header and the concatenated IDAT chunks' parts of `bytes`
  // (Uint8Array). Throws an Error naming `what` on anything else.
  function chunks(bytes, what) {
    const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    if (bytes.length < 8 || dv.getUint32(0) !== 0x89504e47) throw new Error(what + ': not a PNG image');
    let off = 8, width = 0, height = 0, depth = 0, type = 0, interlace = 0;
    const idat = [];
    while (off + 8 <= bytes.length) {
      const len = dv.getUint32(off), kind = String.fromCharCode(...bytes.subarray(off + 4, off + 8));
      const body = bytes.subarray(off + 8, off + 8 + len);
      if (kind === 'IHDR') {
        width = dv.getUint32(off + 8);
        height = dv.getUint32(off + 12);
        depth = body[8];
        type = body[9];
        interlace = body[12];
      } else if (kind === 'IDAT') idat.push(body);
      else if (kind === 'IEND') break;
      off += 12 + len;
    }
    const channels = { 0: 1, 2: 3, 4: 2, 6: 4 }[type];
    if (depth !== 8 || !channels || interlace || !width || !height)
      throw new Error(`${what}: PNG of type ${type}, depth ${depth}, interlace ${interlace}: ` +
                      '8-bit, not interlaced grey or RGB (with or without alpha) expected');
    return { width, height, channels, idat };
  }

  // The pixels (channels bytes each, row 0 at the top) of the inflated
  // IDAT data `raw`: each row a filter byte, then the filtered bytes.
  function unfilter(raw, width, height, channels, what) {
    const stride = width * channels;
    if (raw.length < height * (stride + 1)) throw new Error(what + ': truncated PNG data');
    const px = new Uint8Array(stride * height);
    for (let y = 0; y < height; ++y) {
      const f = raw[y * (stride + 1)], src = y * (stride + 1) + 1, row = y * stride, prev = row - stride;
      for (let i = 0; i < stride; ++i) {
        const a = i >= channels ? px[row + i - channels] : 0, b = y > 0 ? px[prev + i] : 0;
        const c = y > 0 && i >= channels ? px[prev + i - channels] : 0;
        let p = 0;
        if (f === 1) p = a;
        else if (f === 2) p = b;
        else if (f === 3) p = (a + b) >> 1;
        else if (f === 4) {
          const pa = Math.abs(b - c), pb = Math.abs(a - c), pc = Math.abs(a + b - 2 * c);
          p = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
        } else if (f !== 0) throw new Error(what + ': bad PNG filter ' + f);
        px[row + i] = (raw[src + i] + p) & 255;
      }
    }
    return px;
  }

  // The unfiltered pixels `px` (`channels` a pixel) as RGBA8: grey to R, G
  // and B, A 255 where the image has none.
  function rgba(px, width, height, channels) {
    const out = new Uint8Array(width * height * 4);
    for (let i = 0; i < width * height; ++i) {
      const s = px.subarray(i * channels, (i + 1) * channels), grey = channels < 3;
      out[4 * i] = s[0];
      out[4 * i + 1] = grey ? s[0] : s[1];
      out[4 * i + 2] = grey ? s[0] : s[2];
      out[4 * i + 3] = channels === 2 ? s[1] : channels === 4 ? s[3] : 255;
    }
    return out;
  }

  const api = { chunks, unfilter, rgba };
  if (typeof module !== 'undefined' && module.exports) module.exports = api;
  else root.PrtPNG = api;
})(typeof self !== 'undefined' ? self : this);
