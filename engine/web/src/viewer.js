// The 3D viewer (three.js, WebGL). Meshes arrive as the engine's `raw` arrays (a 12-byte
// header, then f32 positions and u32 corners, little endian), which become GPU buffers
// without parsing. Two slots, before and after, shown alone or side by side in one canvas
// (two scissored viewports sharing a camera). Boundary edges (holes) are found after the
// first frame, so a large mesh shows at once.

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { request } from './api.js';
import { el, fill } from './dom.js';

const RAW_MAGIC = 'MFR1';
const RAW_HEADER_BYTES = 12;
const SLOTS = ['before', 'after'];

/** Reads a `raw` answer into typed arrays over the same buffer (no copy). */
export function parseRaw(buffer) {
  const header = new DataView(buffer, 0, RAW_HEADER_BYTES);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== RAW_MAGIC) throw new Error('the engine sent no raw mesh');
  const vertices = header.getUint32(4, true);
  const triangles = header.getUint32(8, true);
  const positions = new Float32Array(buffer, RAW_HEADER_BYTES, vertices * 3);
  const corners = new Uint32Array(buffer, RAW_HEADER_BYTES + vertices * 12, triangles * 3);
  return { vertices, triangles, positions, corners };
}

/** Edges used by exactly one triangle, as vertex pairs: sort all edge keys, keep singles. */
export function boundaryEdges({ vertices, corners }) {
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
  for (let i = 0; i < keys.length; ) {
    let j = i + 1;
    while (j < keys.length && keys[j] === keys[i]) j += 1;
    if (j - i === 1) pairs.push(Math.floor(keys[i] / vertices), keys[i] % vertices);
    i = j;
  }
  return new Uint32Array(pairs);
}

export class Viewer {
  constructor(root) {
    this.root = root;
    this.canvas = el('canvas', { testid: 'viewer', width: 800, height: 500 });
    this.status = el('div', { className: 'note', testid: 'viewer-status' }, 'Nothing to show yet: run a workflow or open a run.');
    this.slots = {};
    /** Counts clears, so a load that began before one is dropped. */
    this.generation = 0;
    this.mode = 'after';
    const toggle = (label, mode) => el('button', { testid: `view-${mode}`, onclick: () => this.setMode(mode) }, label);
    this.wireframe = el('input', { type: 'checkbox', testid: 'view-wireframe', onchange: () => this.applyStyle() });
    this.edges = el('input', { type: 'checkbox', testid: 'view-edges', checked: true, onchange: () => this.applyStyle() });
    fill(root,
      el('div', { className: 'toolbar' },
        toggle('Before', 'before'), toggle('After', 'after'), toggle('Side by side', 'side'),
        el('button', { testid: 'view-fit', onclick: () => this.fit() }, 'Fit'),
        el('label', {}, this.wireframe, ' wireframe'),
        el('label', {}, this.edges, ' boundary edges')),
      this.canvas, this.status);
    // preserveDrawingBuffer: tests (and screenshots) read the canvas after drawing.
    this.renderer = new THREE.WebGLRenderer({ canvas: this.canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.setScissorTest(true);
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.addEventListener('change', () => this.render());
    new ResizeObserver(() => this.resize()).observe(this.canvas);
    this.resize();
  }

  /** Fetches a mesh (`path?format=raw`) into a slot ('before' for the input, else 'after'). */
  async load(label, path) {
    const slot = label === 'input' ? 'before' : 'after';
    const started = performance.now();
    // Only the latest request changes what is shown; an earlier one still fills its slot.
    const asked = (this.latest = Symbol(label));
    const generation = this.generation;
    delete this.canvas.dataset.shown;
    this.status.textContent = `loading ${label}…`;
    let mesh;
    try {
      mesh = parseRaw(await (await request(`${path}?format=raw`)).arrayBuffer());
    } catch (error) {
      if (asked === this.latest) this.status.textContent = `cannot show ${label}: ${error.message}`;
      return;
    }
    if (generation !== this.generation) return; // Cleared meanwhile: another run's mesh.
    this.put(slot, label, mesh);
    if (asked === this.latest) {
      this.setMode(this.slots.before && this.slots.after && this.mode === 'side' ? 'side' : slot);
      this.fit();
      await new Promise((resolve) => requestAnimationFrame(resolve));
      const firstFrameMs = performance.now() - started;
      Object.assign(this.canvas.dataset, {
        firstFrameMs: firstFrameMs.toFixed(0),
        pageToFrameMs: performance.now().toFixed(0),
        shown: label,
        vertices: mesh.vertices,
      });
      this.status.textContent = `${label}: ${mesh.vertices.toLocaleString('en')} vertices, ${mesh.triangles.toLocaleString('en')} triangles; first frame ${firstFrameMs.toFixed(0)} ms after asking`;
    }
    // Holes after the first frame: sorting a large mesh's edges takes a moment.
    setTimeout(() => this.addBoundary(slot, mesh), 0);
  }

  /** Forgets both meshes (another run is shown: its meshes must not mix with these). */
  clear() {
    for (const entry of Object.values(this.slots)) entry.scene.traverse((node) => node.geometry?.dispose());
    this.slots = {};
    this.generation += 1;
    this.latest = Symbol('cleared');
    delete this.canvas.dataset.shown;
    this.status.textContent = 'Nothing to show yet.';
    this.render();
  }

  put(slot, label, mesh) {
    this.slots[slot]?.scene.traverse((node) => node.geometry?.dispose());
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(mesh.positions, 3));
    geometry.setIndex(new THREE.BufferAttribute(mesh.corners, 1));
    geometry.computeVertexNormals();
    geometry.computeBoundingSphere();
    const surface = new THREE.Mesh(geometry, new THREE.MeshStandardMaterial({
      color: slot === 'before' ? 0xb0b8c8 : 0x9cc3a8, side: THREE.DoubleSide, roughness: 0.7, metalness: 0.05,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
    }));
    const scene = new THREE.Scene();
    scene.background = new THREE.Color(0xf4f5f7);
    scene.add(surface, new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
    const light = new THREE.DirectionalLight(0xffffff, 1.8);
    light.position.set(1, 2, 3);
    scene.add(light);
    this.slots[slot] = { scene, surface, boundary: null, label };
    this.applyStyle();
  }

  addBoundary(slot, mesh) {
    const entry = this.slots[slot];
    if (!entry || entry.surface.geometry.attributes.position.array !== mesh.positions) return;
    const pairs = boundaryEdges(mesh);
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', entry.surface.geometry.attributes.position);
    geometry.setIndex(new THREE.BufferAttribute(pairs, 1));
    entry.boundary = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color: 0xdc2626 }));
    entry.scene.add(entry.boundary);
    this.canvas.dataset.boundaryEdges = pairs.length / 2;
    this.applyStyle();
  }

  applyStyle() {
    for (const entry of Object.values(this.slots)) {
      entry.surface.material.wireframe = this.wireframe.checked;
      if (entry.boundary) entry.boundary.visible = this.edges.checked;
    }
    this.render();
  }

  setMode(mode) {
    this.mode = mode;
    this.canvas.dataset.mode = mode;
    this.resize();
  }

  /** Puts the camera where the shown meshes fill the view. */
  fit() {
    const spheres = SLOTS.map((slot) => this.slots[slot]?.surface.geometry.boundingSphere).filter(Boolean);
    if (!spheres.length) return;
    const sphere = spheres.reduce((a, b) => a.clone().union(b));
    const distance = sphere.radius / Math.sin(THREE.MathUtils.degToRad(this.camera.fov / 2));
    this.camera.position.copy(sphere.center).add(new THREE.Vector3(0.4, 0.3, 1).normalize().multiplyScalar(distance));
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.controls.target.copy(sphere.center);
    this.controls.update();
    this.render();
  }

  resize() {
    const width = this.canvas.clientWidth || 800;
    const height = this.canvas.clientHeight || 500;
    this.renderer.setSize(width, height, false);
    this.render();
  }

  render() {
    const width = this.canvas.clientWidth || 800;
    const height = this.canvas.clientHeight || 500;
    const shown = this.mode === 'side' ? SLOTS : [this.mode];
    const part = width / shown.length;
    this.renderer.setScissor(0, 0, width, height);
    this.renderer.setClearColor(0xf4f5f7);
    this.renderer.clear();
    shown.forEach((slot, i) => {
      const entry = this.slots[slot];
      if (!entry) return;
      this.camera.aspect = part / height;
      this.camera.updateProjectionMatrix();
      this.renderer.setViewport(i * part, 0, part, height);
      this.renderer.setScissor(i * part, 0, part, height);
      this.renderer.render(entry.scene, this.camera);
    });
  }
}
