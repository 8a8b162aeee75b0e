// The 3D viewer (three.js, WebGL). Meshes arrive as the engine's `raw` arrays (a 12-byte
// header, then f32 positions and u32 corners, little endian), which become GPU buffers
// without parsing. Reading them, their normals and bounding sphere, and then their
// boundary edges (holes) happen in a worker (`worker.js`, buffers transferred, not copied),
// so a 1M-vertex mesh never holds the main thread; the holes follow the first frame. Two
// slots, before and after, shown alone or side by side in one canvas (two scissored
// viewports sharing a camera). The canvas takes focus: arrows orbit, + and - zoom.

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { request } from './api.js';
import { el, fill } from './dom.js';

const SLOTS = ['before', 'after'];
/** One keyboard orbit step, and one zoom step's factor. */
const KEY_ANGLE = THREE.MathUtils.degToRad(10);
const KEY_ZOOM = 0.85;

/** The worker, started on the first mesh; answers go to the waiting load by id. */
let worker = null;
const waiting = new Map();
let nextId = 0;

function meshWorker() {
  if (worker) return worker;
  worker = new Worker(new URL('./worker.js', import.meta.url), { type: 'module' });
  worker.onmessage = ({ data }) => waiting.get(data.id)?.(data);
  worker.onerror = (event) => {
    for (const answer of waiting.values()) answer({ kind: 'error', message: `the viewer's worker failed: ${event.message ?? 'unknown error'}` });
  };
  return worker;
}

/** Hands a `raw` buffer to the worker: `onMesh(mesh)` for the first frame, then
 *  `onBoundary(pairs)`; rejects when the bytes are not a mesh. */
function decode(buffer, onBoundary) {
  const id = (nextId += 1);
  return new Promise((resolve, reject) => {
    waiting.set(id, (data) => {
      if (data.kind === 'mesh') {
        const { vertices, triangles } = data;
        resolve({
          vertices, triangles, normals: data.normals, sphere: data.sphere,
          positions: new Float32Array(data.buffer, 12, vertices * 3),
          corners: new Uint32Array(data.buffer, 12 + vertices * 12, triangles * 3),
          colors: data.colorOffset === null ? null : new Uint8Array(data.buffer, data.colorOffset, vertices * 4),
          uv: data.vertexUv,
          textures: data.textures,
          corner: data.corner,
          attributes: data.attributes,
        });
        return;
      }
      waiting.delete(id);
      if (data.kind === 'boundary') onBoundary(data.pairs);
      else reject(new Error(data.message));
    });
    meshWorker().postMessage({ id, buffer }, [buffer]);
  });
}

export class Viewer {
  constructor(root) {
    this.root = root;
    this.canvas = el('canvas', {
      testid: 'viewer', width: 800, height: 500, tabIndex: 0,
      'aria-label': 'Mesh viewer: arrow keys orbit, + and - zoom, F fits',
      onkeydown: (event) => this.key(event),
    });
    this.status = el('div', { className: 'note', testid: 'viewer-status', 'aria-live': 'polite' }, 'Nothing to show yet: run a workflow or open a run.');
    this.slots = {};
    /** Image files chosen with meshes, by name (see `useTextures`). */
    this.textures = new Map();
    /** Counts clears, so a load that began before one is dropped. */
    this.generation = 0;
    /** Where the shown run's input is, for "Before" and "Side by side" (`setInput`). */
    this.inputPath = null;
    this.mode = 'after';
    const toggle = (label, mode) => el('button', { testid: `view-${mode}`, onclick: () => this.choose(mode) }, label);
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

  /** The shown run's input (`/runs/{id}/input`), loaded when "Before" or "Side by side" is
   *  chosen and not shown yet. */
  setInput(path) {
    this.inputPath = path;
    if ((this.mode === 'before' || this.mode === 'side') && !this.slots.before && !this.loadingInput) this.loadInput();
  }

  loadInput() {
    if (!this.inputPath) return;
    this.loadingInput = true;
    this.load('input', this.inputPath).finally(() => { this.loadingInput = false; });
  }

  /** A view the user chose: the input is fetched if it is needed and not there. */
  choose(mode) {
    this.setMode(mode);
    // A mesh already there (the input fetched for an earlier "Side by side") is shown now.
    const entry = this.slots[mode === 'before' ? 'before' : 'after'];
    if (mode !== 'side' && entry) this.canvas.dataset.shown = entry.label;
    if (mode !== 'after' && !this.slots.before && !this.loadingInput) {
      if (this.inputPath) this.loadInput();
      else this.status.textContent = 'No input to show yet: run a workflow or open a run.';
    }
  }

  /** Fetches a mesh (`path?format=raw`) into a slot ('before' for the input, else 'after'). */
  async load(label, path) {
    const slot = label === 'input' ? 'before' : 'after';
    const started = performance.now();
    // Only the latest request changes what is shown; an earlier one still fills its slot.
    const asked = (this.latest = Symbol(label));
    const generation = this.generation;
    delete this.canvas.dataset.shown;
    this.canvas.dataset.loadStartedMs = started.toFixed(0);
    this.status.textContent = `loading ${label}…`;
    let mesh;
    try {
      const buffer = await (await request(`${path}?format=raw`)).arrayBuffer();
      if (generation !== this.generation) return;
      mesh = await decode(buffer, (pairs) => this.addBoundary(slot, mesh, pairs));
      // Fetched and decoded (in the worker): what follows is drawing.
      this.canvas.dataset.decodedAtMs = performance.now().toFixed(0);
    } catch (error) {
      if (asked === this.latest) this.status.textContent = `cannot show ${label}: ${error.message}`;
      return;
    }
    if (generation !== this.generation) return; // Cleared meanwhile: another run's mesh.
    this.put(slot, label, mesh);
    if (asked === this.latest) {
      const side = this.slots.before && this.slots.after && this.mode === 'side';
      // The input loaded for "Before" or "Side by side" keeps that view.
      this.setMode(side ? 'side' : slot === 'before' && this.mode === 'side' ? 'side' : slot);
      this.fit();
      await new Promise((resolve) => requestAnimationFrame(resolve));
      const firstFrameMs = performance.now() - started;
      Object.assign(this.canvas.dataset, {
        firstFrameMs: firstFrameMs.toFixed(0),
        pageToFrameMs: performance.now().toFixed(0),
        shown: label,
        vertices: mesh.vertices,
        vertexColors: mesh.colors ? 'yes' : 'no',
      });
      const carries = mesh.attributes.length ? `; carries ${mesh.attributes.join(', ')}` : '';
      this.status.textContent = `${label}: ${mesh.vertices.toLocaleString('en')} vertices, ${mesh.triangles.toLocaleString('en')} triangles${carries}; first frame ${firstFrameMs.toFixed(0)} ms after asking`;
    }
  }

  /** Forgets both meshes (another run is shown: its meshes must not mix with these). */
  clear() {
    for (const entry of Object.values(this.slots)) entry.scene.traverse((node) => node.geometry?.dispose());
    this.slots = {};
    this.inputPath = null;
    this.generation += 1;
    this.latest = Symbol('cleared');
    delete this.canvas.dataset.shown;
    delete this.canvas.dataset.boundaryEdges;
    this.status.textContent = 'Nothing to show yet.';
    this.render();
  }

  /** Image files chosen with a mesh: a textured mesh names its textures, and those with
   *  the same file name are drawn on it. They stay in this browser. */
  useTextures(files, fresh) {
    if (fresh) this.textures.clear();
    for (const file of files) this.textures.set(file.name, file);
  }

  put(slot, label, mesh) {
    this.slots[slot]?.scene.traverse((node) => node.geometry?.dispose());
    const geometry = new THREE.BufferGeometry();
    // Texture coordinates per corner need a vertex per corner (the worker made them).
    const arrays = mesh.corner ?? mesh;
    geometry.setAttribute('position', new THREE.BufferAttribute(arrays.positions, 3));
    geometry.setAttribute('normal', new THREE.BufferAttribute(arrays.normals, 3));
    if (!mesh.corner) geometry.setIndex(new THREE.BufferAttribute(mesh.corners, 1));
    geometry.boundingSphere = new THREE.Sphere(new THREE.Vector3(...mesh.sphere.center), mesh.sphere.radius);
    // A mesh's own vertex colours (RGBA bytes, normalised) replace the slot's tint.
    if (arrays.colors) geometry.setAttribute('color', new THREE.BufferAttribute(arrays.colors, 4, true));
    const uv = mesh.corner?.uv ?? mesh.uv;
    if (uv) geometry.setAttribute('uv', new THREE.BufferAttribute(uv, 2));
    // An OBJ names its textures in its material library, not in itself: with one image
    // chosen beside it, that image is its texture.
    const named = mesh.textures[0] ?? (this.textures.size === 1 ? [...this.textures.keys()][0] : null);
    const map = uv && named ? this.texture(named) : null;
    const surface = new THREE.Mesh(geometry, new THREE.MeshStandardMaterial({
      color: mesh.colors || map ? 0xffffff : slot === 'before' ? 0xb0b8c8 : 0x9cc3a8, vertexColors: Boolean(mesh.colors),
      map, side: THREE.DoubleSide, roughness: 0.7, metalness: 0.05,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
    }));
    const scene = new THREE.Scene();
    scene.background = new THREE.Color(0xf4f5f7);
    scene.add(surface, new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
    const light = new THREE.DirectionalLight(0xffffff, 1.8);
    light.position.set(1, 2, 3);
    scene.add(light);
    this.slots[slot] = { scene, surface, boundary: null, label, positions: mesh.positions };
    this.applyStyle();
  }

  /** The named texture: the image chosen with the mesh, or a checker that shows the
   *  texture coordinates' layout when the image is not in this browser. */
  texture(name) {
    const file = this.textures.get(name.split('/').pop());
    this.canvas.dataset.texture = file ? name : `${name} (not chosen here: a checker shows its layout)`;
    if (!file) {
      const cells = new Uint8Array(8 * 8 * 4).map((_, i) => ((((i >> 2) & 7) + (i >> 5)) % 2 ? 230 : 90));
      const checker = new THREE.DataTexture(cells, 8, 8);
      checker.magFilter = THREE.NearestFilter;
      checker.needsUpdate = true;
      return checker;
    }
    const url = URL.createObjectURL(file);
    const map = new THREE.TextureLoader().load(url, () => {
      URL.revokeObjectURL(url);
      this.canvas.dataset.textureLoaded = name;
      this.render();
    });
    map.colorSpace = THREE.SRGBColorSpace;
    return map;
  }

  /** The holes the worker found, once the mesh they belong to is still shown. */
  addBoundary(slot, mesh, pairs) {
    const entry = this.slots[slot];
    if (!mesh || !entry || entry.positions !== mesh.positions) return;
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(mesh.positions, 3));
    geometry.setIndex(new THREE.BufferAttribute(pairs, 1));
    geometry.boundingSphere = entry.surface.geometry.boundingSphere;
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

  /** Arrows orbit around the target, + and - zoom, F fits. */
  key(event) {
    const offset = this.camera.position.clone().sub(this.controls.target);
    const spin = (axis, angle) => offset.applyAxisAngle(axis, angle);
    const right = new THREE.Vector3().crossVectors(this.camera.up, offset).normalize();
    switch (event.key) {
      case 'ArrowLeft': spin(this.camera.up, -KEY_ANGLE); break;
      case 'ArrowRight': spin(this.camera.up, KEY_ANGLE); break;
      case 'ArrowUp': spin(right, -KEY_ANGLE); break;
      case 'ArrowDown': spin(right, KEY_ANGLE); break;
      case '+': case '=': offset.multiplyScalar(KEY_ZOOM); break;
      case '-': case '_': offset.multiplyScalar(1 / KEY_ZOOM); break;
      case 'f': case 'F': this.fit(); event.preventDefault(); return;
      default: return;
    }
    event.preventDefault();
    // Not over a pole: the camera would flip.
    if (Math.abs(offset.clone().normalize().dot(this.camera.up)) > 0.99) return;
    this.camera.position.copy(this.controls.target).add(offset);
    this.controls.update();
    this.render();
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

  /** Draws at the next frame, once however many changes asked for it (a large mesh's
   *  frame is costly: one per frame, not one per change). */
  render() {
    const p = this.camera.position;
    this.canvas.dataset.camera = `${p.x.toFixed(3)},${p.y.toFixed(3)},${p.z.toFixed(3)}`;
    this.frame ||= requestAnimationFrame(() => {
      this.frame = 0;
      this.draw();
    });
  }

  draw() {
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
