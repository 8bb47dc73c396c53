// Minimal PNG reader for the tests (8-bit grey, RGB, grey+alpha and RGBA,
// not interlaced): returns {width, height, rgb: Uint8Array (3 per pixel)}.
'use strict';
const zlib = require('zlib');
const PNG = require('../../web/prt-png.js');

function readPng(buf) {
  const { width, height, channels, idat } = PNG.chunks(new Uint8Array(buf.buffer, buf.byteOffset, buf.length), 'PNG');
  const out = PNG.unfilter(zlib.inflateSync(Buffer.concat(idat)), width, height, channels, 'PNG');
  const rgb = new Uint8Array(width * height * 3);
  for (let i = 0; i < width * height; ++i)
    for (let c = 0; c < 3; ++c) rgb[3 * i + c] = out[i * channels + (channels >= 3 ? c : 0)];
  return { width, height, rgb };
}

module.exports = { readPng };

// 8-bit RGB PNG of `rgb` (3 bytes per pixel, row 0 at the top).
function writePng(width, height, rgb) {
  const crcTable = new Int32Array(256).map((_, n) => {
    let c = n;
    for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c;
  });
  const crc = (b) => { let c = -1; for (const x of b) c = crcTable[(c ^ x) & 255] ^ (c >>> 8); return (c ^ -1) >>> 0; };
  const chunk = (kind, body) => {
    const head = Buffer.alloc(8);
    head.writeUInt32BE(body.length, 0);
    head.write(kind, 4, 'latin1');
    const tail = Buffer.alloc(4);
    tail.writeUInt32BE(crc(Buffer.concat([head.subarray(4), body])), 0);
    return Buffer.concat([head, body, tail]);
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0);
  ihdr.writeUInt32BE(height, 4);
  ihdr[8] = 8;
  ihdr[9] = 2;
  const raw = Buffer.alloc((width * 3 + 1) * height);
  for (let y = 0; y < height; ++y) Buffer.from(rgb.buffer, rgb.byteOffset + y * width * 3, width * 3).copy(raw, y * (width * 3 + 1) + 1);
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), chunk('IHDR', ihdr),
                        chunk('IDAT', zlib.deflateSync(raw, { level: 9 })), chunk('IEND', Buffer.alloc(0))]);
}

module.exports.writePng = writePng;
