// The scene a report embeds (docs/formats.md, "The report's 3D view"): a JSON description in
// <script type="application/json" id="ID-description"> and the binary arrays it names, one
// little-endian blob in <script type="application/octet-stream" id="ID-arrays">: base64 of the
// blob deflated by zlib when the element says data-encoding="deflate" (with the blob's size in
// data-bytes), of the blob itself without data-encoding.

const kTypes = {
  float32: Float32Array,
  uint32: Uint32Array,
  uint16: Uint16Array,
  uint8: Uint8Array,
};

// base64 to bytes: the browser's own decoder where it has one, else a table-driven loop (a
// report's few megabytes decode in tens of milliseconds either way).
export function base64ToBytes(text) {
  const clean = text.replace(/[^A-Za-z0-9+/=]/g, '');
  if (typeof Uint8Array.fromBase64 === 'function') return Uint8Array.fromBase64(clean);
  const table = new Uint8Array(128);
  const alphabet = 'ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/';
  for (let i = 0; i < alphabet.length; ++i) table[alphabet.charCodeAt(i)] = i;
  let n = clean.length;
  while (n > 0 && clean[n - 1] === '=') --n;
  const out = new Uint8Array(Math.floor((n * 3) / 4));
  let o = 0, i = 0;
  for (; i + 4 <= n; i += 4) {
    const v = (table[clean.charCodeAt(i)] << 18) | (table[clean.charCodeAt(i + 1)] << 12) |
              (table[clean.charCodeAt(i + 2)] << 6) | table[clean.charCodeAt(i + 3)];
    out[o++] = v >> 16;
    out[o++] = (v >> 8) & 255;
    out[o++] = v & 255;
  }
  if (n - i >= 2) {
    const v = (table[clean.charCodeAt(i)] << 18) | (table[clean.charCodeAt(i + 1)] << 12) |
              (n - i === 3 ? table[clean.charCodeAt(i + 2)] << 6 : 0);
    out[o++] = v >> 16;
    if (n - i === 3) out[o++] = (v >> 8) & 255;
  }
  return out;
}

// The blob inflated by the browser's own zlib (DecompressionStream, in every browser since
// 2023; no network: a stream over bytes in memory).
async function inflate(bytes, expected, id) {
  if (typeof DecompressionStream !== 'function') {
    throw new Error('this browser cannot inflate the embedded scene (no DecompressionStream)');
  }
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
  const out = new Uint8Array(await new Response(stream).arrayBuffer());
  if (out.byteLength !== expected) {
    throw new Error(`scene ${id}: the arrays inflate to ${out.byteLength} bytes, not ${expected}`);
  }
  return out;
}

// The description and its arrays (typed views on the decoded blob) of the scene whose
// container is `element`. Rejects when the page's scene is malformed.
export async function readScene(element) {
  const id = element.id;
  const descriptionElement = document.getElementById(`${id}-description`);
  const arraysElement = document.getElementById(`${id}-arrays`);
  if (!descriptionElement || !arraysElement) throw new Error(`scene ${id}: data missing`);
  const description = JSON.parse(descriptionElement.textContent);
  let bytes = base64ToBytes(arraysElement.textContent);
  const encoding = arraysElement.dataset.encoding;
  if (encoding === 'deflate') {
    bytes = await inflate(bytes, Number(arraysElement.dataset.bytes), id);
  } else if (encoding !== undefined) {
    throw new Error(`scene ${id}: unknown encoding ${encoding}`);
  }
  const arrays = {};
  for (const [name, a] of Object.entries(description.arrays || {})) {
    const Type = kTypes[a.type];
    if (!Type) throw new Error(`scene ${id}: array ${name}: unknown type ${a.type}`);
    if (a.offset % Type.BYTES_PER_ELEMENT !== 0 ||
        a.offset + a.count * Type.BYTES_PER_ELEMENT > bytes.byteLength) {
      throw new Error(`scene ${id}: array ${name} lies outside the data`);
    }
    arrays[name] = new Type(bytes.buffer, bytes.byteOffset + a.offset, a.count);
  }
  return { description, arrays, bytes: bytes.byteLength };
}
