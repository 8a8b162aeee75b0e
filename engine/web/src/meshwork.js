// The mesh work the viewer does off the main thread (see worker.js): reading the engine's
// `raw` arrays, vertex normals, the bounding sphere and boundary edges. Plain functions over
// typed arrays, no three.js, so the worker stays small.

const RAW_MAGIC = 'MFR1';
const RAW_HEADER_BYTES = 12;

/** Reads a `raw` answer (a 12-byte header, then f32 positions and u32 corners, little
 *  endian) into typed arrays over the same buffer (no copy). */
export function parseRaw(buffer) {
  if (buffer.byteLength < RAW_HEADER_BYTES) throw new Error('the engine sent no raw mesh');
  const header = new DataView(buffer, 0, RAW_HEADER_BYTES);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== RAW_MAGIC) throw new Error('the engine sent no raw mesh');
  const vertices = header.getUint32(4, true);
  const triangles = header.getUint32(8, true);
  if (RAW_HEADER_BYTES + vertices * 12 + triangles * 12 > buffer.byteLength) {
    throw new Error(`the raw mesh is cut short (${vertices} vertices, ${triangles} triangles in ${buffer.byteLength} bytes)`);
  }
  const positions = new Float32Array(buffer, RAW_HEADER_BYTES, vertices * 3);
  const corners = new Uint32Array(buffer, RAW_HEADER_BYTES + vertices * 12, triangles * 3);
  return { vertices, triangles, positions, corners };
}

const ATTRIBUTES_TAG = 'attributes-v1';
const DOMAINS = ['vertex', 'face', 'corner'];
const TYPES = [['u8', 1], ['i32', 4], ['u32', 4], ['f32', 4], ['f64', 8]];

/** The attribute section after a `raw` mesh's arrays (what the content hash covers after
 *  them): each attribute's domain, name, type, components and where its numbers lie, and
 *  the byte offset of the per-vertex RGBA colours when the mesh has them. Bounds are
 *  checked: a section that runs past the buffer is refused. */
export function parseAttributes(buffer, vertices, triangles) {
  let at = RAW_HEADER_BYTES + vertices * 12 + triangles * 12;
  const found = { list: [], colorOffset: null, vertexUvOffset: null, cornerUvOffset: null, textures: [] };
  if (at === buffer.byteLength) return found;
  const view = new DataView(buffer);
  const need = (n) => {
    if (at + n > buffer.byteLength) throw new Error('the raw mesh\'s attributes are cut short');
  };
  const text = (n) => {
    need(n);
    const s = new TextDecoder().decode(new Uint8Array(buffer, at, n));
    at += n;
    return s;
  };
  const u32 = () => {
    need(4);
    const v = view.getUint32(at, true);
    at += 4;
    return v;
  };
  if (text(ATTRIBUTES_TAG.length) !== ATTRIBUTES_TAG) throw new Error('the raw mesh has trailing bytes');
  const count = u32();
  for (let i = 0; i < count; i += 1) {
    need(3);
    const [domain, type, components] = new Uint8Array(buffer, at, 3);
    at += 3;
    const name = text(u32());
    need(8);
    const numbers = Number(view.getBigUint64(at, true));
    at += 8;
    const [typeName, size] = TYPES[type] ?? [];
    if (!typeName || !DOMAINS[domain]) throw new Error(`attribute ${name} has an unknown shape`);
    need(numbers * size);
    found.list.push({ domain: DOMAINS[domain], name, type: typeName, components, offset: at });
    if (domain === 0 && name === 'color' && typeName === 'u8' && components === 4 && numbers === vertices * 4) {
      found.colorOffset = at;
    }
    // Numbers in the section need not be 4-byte aligned: floats are copied out (slice).
    if (name === 'texcoord' && typeName === 'f32' && components === 2) {
      if (domain === 0 && numbers === vertices * 2) found.vertexUvOffset = at;
      if (domain === 2 && numbers === triangles * 6) found.cornerUvOffset = at;
    }
    at += numbers * size;
  }
  for (const list of [[], [], found.textures]) {
    const n = u32();
    for (let i = 0; i < n; i += 1) list.push(text(u32()));
  }
  return found;
}

/** One vertex per corner (what a texture with seams needs: a vertex's corners may have
 *  different texture coordinates): positions, normals and colours copied to each corner. */
export function perCorner(mesh, normals, colors) {
  const { corners } = mesh;
  const n = corners.length;
  const positions = new Float32Array(n * 3);
  const cornerNormals = new Float32Array(n * 3);
  const cornerColors = colors ? new Uint8Array(n * 4) : null;
  for (let c = 0; c < n; c += 1) {
    const v = corners[c];
    positions.set(mesh.positions.subarray(3 * v, 3 * v + 3), 3 * c);
    cornerNormals.set(normals.subarray(3 * v, 3 * v + 3), 3 * c);
    if (cornerColors) cornerColors.set(colors.subarray(4 * v, 4 * v + 4), 4 * c);
  }
  return { positions, normals: cornerNormals, colors: cornerColors };
}

/** Area-weighted vertex normals (what three.js's computeVertexNormals gives). */
export function vertexNormals(positions, corners) {
  const normals = new Float32Array(positions.length);
  for (let t = 0; t < corners.length; t += 3) {
    const a = corners[t] * 3;
    const b = corners[t + 1] * 3;
    const c = corners[t + 2] * 3;
    const ux = positions[b] - positions[a];
    const uy = positions[b + 1] - positions[a + 1];
    const uz = positions[b + 2] - positions[a + 2];
    const vx = positions[c] - positions[a];
    const vy = positions[c + 1] - positions[a + 1];
    const vz = positions[c + 2] - positions[a + 2];
    const nx = uy * vz - uz * vy;
    const ny = uz * vx - ux * vz;
    const nz = ux * vy - uy * vx;
    for (const v of [a, b, c]) {
      normals[v] += nx;
      normals[v + 1] += ny;
      normals[v + 2] += nz;
    }
  }
  for (let i = 0; i < normals.length; i += 3) {
    const length = Math.hypot(normals[i], normals[i + 1], normals[i + 2]) || 1;
    normals[i] /= length;
    normals[i + 1] /= length;
    normals[i + 2] /= length;
  }
  return normals;
}

/** The centre of the bounding box and the radius around it that holds every vertex. */
export function boundingSphere(positions) {
  if (!positions.length) return { center: [0, 0, 0], radius: 0 };
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3) {
    for (let k = 0; k < 3; k += 1) {
      const x = positions[i + k];
      if (x < min[k]) min[k] = x;
      if (x > max[k]) max[k] = x;
    }
  }
  const center = [0, 1, 2].map((k) => (min[k] + max[k]) / 2);
  let most = 0;
  for (let i = 0; i < positions.length; i += 3) {
    const d = (positions[i] - center[0]) ** 2 + (positions[i + 1] - center[1]) ** 2 + (positions[i + 2] - center[2]) ** 2;
    if (d > most) most = d;
  }
  return { center, radius: Math.sqrt(most) };
}

/** Edges used by exactly one triangle, as vertex pairs: sort all edge keys, keep singles. */
export function boundaryEdges(vertices, corners) {
  const keys = new Float64Array(corners.length);
  for (let t = 0; t < corners.length; t += 3) {
    for (let k = 0; k < 3; k += 1) {
      const a = corners[t + k];
      const b = corners[t + ((k + 1) % 3)];
      keys[t + k] = a < b ? a * vertices + b : b * vertices + a;
    }
  }
  keys.sort();
  const pairs = [];
  for (let i = 0; i < keys.length;) {
    let j = i + 1;
    while (j < keys.length && keys[j] === keys[i]) j += 1;
    if (j - i === 1) pairs.push(Math.floor(keys[i] / vertices), keys[i] % vertices);
    i = j;
  }
  return new Uint32Array(pairs);
}
