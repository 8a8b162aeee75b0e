// The viewer's worker: a mesh's `raw` bytes in, GPU-ready arrays out, so a 1M-vertex mesh
// never holds the page's main thread. Buffers move both ways as transferables (no copies):
//
//   in:  { id, buffer }
//   out: { id, kind: 'mesh', buffer, normals, vertices, triangles, sphere,
//          colorOffset, attributes }                                    (first frame)
//        { id, kind: 'boundary', pairs }                                      (then holes)
//        { id, kind: 'error', message }

import { parseRaw, parseAttributes, perCorner, vertexNormals, boundingSphere, boundaryEdges } from './meshwork.js';

self.onmessage = ({ data: { id, buffer } }) => {
  let mesh;
  let normals;
  let sphere;
  let corners;
  let attributes;
  let corner = null;
  let vertexUv = null;
  try {
    mesh = parseRaw(buffer);
    attributes = parseAttributes(buffer, mesh.vertices, mesh.triangles);
    normals = vertexNormals(mesh.positions, mesh.corners);
    sphere = boundingSphere(mesh.positions);
    // The worker's own copy of the corners: the buffer goes to the page before the holes
    // are found, so the first frame does not wait for them.
    corners = mesh.corners.slice();
    if (attributes.vertexUvOffset !== null) {
      vertexUv = new Float32Array(buffer.slice(attributes.vertexUvOffset, attributes.vertexUvOffset + mesh.vertices * 8));
    }
    // A texture with per-corner coordinates needs a vertex per corner; made here, once.
    if (attributes.cornerUvOffset !== null) {
      const colors = attributes.colorOffset === null ? null : new Uint8Array(buffer, attributes.colorOffset, mesh.vertices * 4);
      corner = perCorner(mesh, normals, colors);
      corner.uv = new Float32Array(buffer.slice(attributes.cornerUvOffset, attributes.cornerUvOffset + mesh.triangles * 24));
    }
  } catch (error) {
    self.postMessage({ id, kind: 'error', message: error.message });
    return;
  }
  self.postMessage({
    id, kind: 'mesh', buffer, normals, sphere, vertices: mesh.vertices, triangles: mesh.triangles,
    colorOffset: attributes.colorOffset,
    vertexUv,
    textures: attributes.textures,
    corner,
    attributes: attributes.list.map(({ domain, name, type, components }) => `${domain} ${name} (${components} × ${type})`),
  }, [buffer, normals.buffer, ...(vertexUv ? [vertexUv.buffer] : []), ...(corner ? [corner.positions.buffer, corner.normals.buffer, corner.uv.buffer, ...(corner.colors ? [corner.colors.buffer] : [])] : [])]);
  const pairs = boundaryEdges(mesh.vertices, corners);
  self.postMessage({ id, kind: 'boundary', pairs }, [pairs.buffer]);
};
