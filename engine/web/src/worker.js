// The viewer's worker: a mesh's `raw` bytes in, GPU-ready arrays out, so a 1M-vertex mesh
// never holds the page's main thread. Buffers move both ways as transferables (no copies):
//
//   in:  { id, buffer }
//   out: { id, kind: 'mesh', buffer, normals, vertices, triangles, sphere,
//          colorOffset, attributes }                                    (first frame)
//        { id, kind: 'boundary', pairs }                                      (then holes)
//        { id, kind: 'error', message }

import { parseRaw, parseAttributes, vertexNormals, boundingSphere, boundaryEdges } from './meshwork.js';

self.onmessage = ({ data: { id, buffer } }) => {
  let mesh;
  let normals;
  let sphere;
  let corners;
  let attributes;
  try {
    mesh = parseRaw(buffer);
    attributes = parseAttributes(buffer, mesh.vertices, mesh.triangles);
    normals = vertexNormals(mesh.positions, mesh.corners);
    sphere = boundingSphere(mesh.positions);
    // The worker's own copy of the corners: the buffer goes to the page before the holes
    // are found, so the first frame does not wait for them.
    corners = mesh.corners.slice();
  } catch (error) {
    self.postMessage({ id, kind: 'error', message: error.message });
    return;
  }
  self.postMessage({
    id, kind: 'mesh', buffer, normals, sphere, vertices: mesh.vertices, triangles: mesh.triangles,
    colorOffset: attributes.colorOffset,
    attributes: attributes.list.map(({ domain, name, type, components }) => `${domain} ${name} (${components} × ${type})`),
  }, [buffer, normals.buffer]);
  const pairs = boundaryEdges(mesh.vertices, corners);
  self.postMessage({ id, kind: 'boundary', pairs }, [pairs.buffer]);
};
