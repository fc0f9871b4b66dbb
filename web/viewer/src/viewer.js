// The interactive 3D view of a fringe report (issue 31): three.js (WebGL) with OrbitControls,
// drawn from the scene the report embeds (data.js). Every element with class "fringe-scene"
// gets a viewer; without WebGL it says why and the page's pictures stand in for it.
//
// Test and benchmark hooks: window.fringeViewer (the page's first viewer) and
// window.fringeViewers (all of them), see FringeViewer's methods below.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { CSS2DObject, CSS2DRenderer } from 'three/addons/renderers/CSS2DRenderer.js';

import { categoryColour, categoryCss, drawColourBar, kNoValue, turbo } from './colour.js';
import { readScene } from './data.js';

const kStyle = `
.fringe-scene{border:1px solid #ccc;margin:.6em 0;max-width:1200px;font-size:.9em}
.fringe-scene .fv-bar{display:flex;flex-wrap:wrap;gap:.4em 1em;align-items:center;padding:4px 8px;
  background:#f0f0f0;border-bottom:1px solid #ccc}
.fringe-scene .fv-port{position:relative;height:560px;background:#e9ecf0;overflow:hidden;
  cursor:crosshair}
.fringe-scene .fv-port canvas{display:block}
.fringe-scene .fv-label{font:11px sans-serif;color:#111;background:rgba(255,255,255,.75);
  padding:0 2px;border-radius:2px;pointer-events:none}
.fringe-scene .fv-label.fv-view{color:#fff;background:rgba(40,40,40,.7)}
.fringe-scene .fv-foot{display:flex;flex-wrap:wrap;gap:1em;padding:4px 8px;align-items:flex-start}
.fringe-scene .fv-info{font-family:monospace;white-space:pre;min-width:22em}
.fringe-scene .fv-swatch{display:inline-block;width:.9em;height:.9em;margin:0 .25em 0 .6em;
  vertical-align:middle}
.fringe-scene .fv-message{padding:1em;color:#444}
tr.fringe-view-row{cursor:pointer}
tr.fringe-view-row:hover td{background:#eef4ff}
tr.fringe-view-row.fringe-view-selected td{background:#ffe7c2}
`;

// Can this browser draw WebGL at all (disabled by a flag or a policy, no GPU nor software GL)?
function webglUnavailableReason() {
  if (!window.WebGLRenderingContext) return 'this browser does not support WebGL';
  try {
    const canvas = document.createElement('canvas');
    if (canvas.getContext('webgl2') || canvas.getContext('webgl')) return null;
  } catch (e) {
    return `WebGL could not start (${e.message})`;
  }
  return 'WebGL is disabled or not available in this browser';
}

function element(tag, className, parent, text) {
  const e = document.createElement(tag);
  if (className) e.className = className;
  if (text !== undefined) e.textContent = text;
  if (parent) parent.appendChild(e);
  return e;
}

// The quantiles q0 and q1 of the finite values of `values` (every stride-th, at most ~100k).
function quantiles(values, q0, q1) {
  const stride = Math.max(1, Math.floor(values.length / 100000));
  const sample = [];
  for (let i = 0; i < values.length; i += stride) {
    if (Number.isFinite(values[i])) sample.push(values[i]);
  }
  if (sample.length === 0) return [0, 1];
  sample.sort((a, b) => a - b);
  const at = (q) => sample[Math.min(sample.length - 1, Math.floor(q * (sample.length - 1)))];
  const lo = at(q0), hi = at(q1);
  return hi > lo ? [lo, hi] : [lo - 0.5, hi + 0.5];
}

class FringeViewer {
  constructor(container, scene) {
    this.container = container;
    this.description = scene.description;
    this.arrays = scene.arrays;
    this.frames = 0;
    this.firstFrameMs = null;
    this.highlighted = null;  // name of the highlighted view
    this.lastPick = null;
    const d = this.description;
    this.origin = d.origin || [0, 0, 0];
    this.viewNames = (d.views || []).map((v) => v.name);
    this.buildDom();
    this.buildScene();
    this.setColouring(this.colourings[0]?.id);
    this.reset();
    this.connectTables();
    const observer = new ResizeObserver(() => this.resize());
    observer.observe(this.port);
    this.resize();
  }

  // --- The page around the canvas ---------------------------------------------------------
  buildDom() {
    const c = this.container;
    c.textContent = '';
    const bar = element('div', 'fv-bar', c);
    const d = this.description;
    this.colourings =
        (d.colourings || []).filter((k) => k.mesh || k.points || k.boards || k.kind === 'height');
    const label = element('label', null, bar, 'colour: ');
    this.select = element('select', 'fv-colouring', label);
    for (const k of this.colourings) {
      const o = element('option', null, this.select, k.title);
      o.value = k.id;
    }
    this.select.addEventListener('change', () => this.setColouring(this.select.value));
    this.toggles = {};
    const toggle = (key, text, on) => {
      const l = element('label', null, bar);
      const box = element('input', `fv-show-${key}`, l);
      box.type = 'checkbox';
      box.checked = on;
      l.appendChild(document.createTextNode(` ${text}`));
      box.addEventListener('change', () => this.show(key, box.checked));
      this.toggles[key] = box;
    };
    if (d.mesh) toggle('mesh', `mesh (${d.mesh.triangles.toLocaleString('en')} triangles)`, true);
    if (d.points) {
      toggle('points', `points (${d.points.count.toLocaleString('en')})`, !d.mesh);
    }
    if (d.markers?.length) toggle('markers', `markers (${d.markers.length})`, true);
    if (d.views?.length) toggle('views', `sensors (${d.views.length})`, true);
    if (d.boards?.length) toggle('boards', `boards (${d.boards.length})`, true);
    const reset = element('button', 'fv-reset', bar, 'reset view');
    reset.addEventListener('click', () => this.reset());
    element('span', 'fv-hint', bar,
            'drag: turn · right-drag: pan · wheel: zoom · click: pick a point');
    this.port = element('div', 'fv-port', c);
    const foot = element('div', 'fv-foot', c);
    this.legend = element('div', 'fv-legend', foot);
    this.info = element('div', 'fv-info', foot, 'Click the model to read a point.');
    if (d.note) element('div', 'fv-note', foot, d.note);
  }

  // --- Scene -------------------------------------------------------------------------------
  buildScene() {
    const d = this.description;
    this.renderer = new THREE.WebGLRenderer({ antialias: true });
    this.renderer.setPixelRatio(1);
    this.port.appendChild(this.renderer.domElement);
    this.labels = new CSS2DRenderer();
    this.labels.domElement.style.position = 'absolute';
    this.labels.domElement.style.top = '0';
    this.labels.domElement.style.pointerEvents = 'none';
    this.port.appendChild(this.labels.domElement);

    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#e9ecf0');
    this.camera = new THREE.PerspectiveCamera(35, 1, 1, 1e5);
    this.camera.up.set(0, 0, 1);  // the display frame's z is up
    this.scene.add(this.camera);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x555555, 1.6));
    const light = new THREE.DirectionalLight(0xffffff, 1.6);
    light.position.set(-0.5, 0.5, 1);  // over the viewer's left shoulder, as the pictures
    this.camera.add(light);

    // Display frame <- world (mesh.ply's frame) <- local (world - origin, float32 on the GPU).
    this.world = new THREE.Group();
    this.world.matrixAutoUpdate = false;
    const m = d.display_from_world || [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0];
    this.world.matrix.set(m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8], m[9], m[10], m[11],
                          0, 0, 0, 1);
    this.scene.add(this.world);
    this.local = new THREE.Group();
    this.local.position.set(...this.origin);
    this.world.add(this.local);
    this.objects = {};

    if (d.mesh) {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(this.arrays[d.mesh.positions], 3));
      g.setIndex(new THREE.BufferAttribute(this.arrays[d.mesh.indices], 1));
      g.computeVertexNormals();
      g.setAttribute('color', new THREE.BufferAttribute(
          new Float32Array(this.arrays[d.mesh.positions].length), 3));
      const material = new THREE.MeshLambertMaterial({ vertexColors: true,
                                                       side: THREE.DoubleSide });
      this.objects.mesh = new THREE.Mesh(g, material);
      this.local.add(this.objects.mesh);
    }
    if (d.points) {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(this.arrays[d.points.positions], 3));
      g.setAttribute('color', new THREE.BufferAttribute(
          new Float32Array(this.arrays[d.points.positions].length), 3));
      const material = new THREE.PointsMaterial({ size: 2, sizeAttenuation: false,
                                                  vertexColors: true });
      this.objects.points = new THREE.Points(g, material);
      this.objects.points.visible = !d.mesh;
      this.local.add(this.objects.points);
    }
    const model = this.objects.mesh || this.objects.points;
    if (model) {
      model.geometry.computeBoundingSphere();
      this.modelSphere = model.geometry.boundingSphere.clone();
    } else {
      this.modelSphere = new THREE.Sphere(new THREE.Vector3(), 100);
    }
    if (d.markers?.length) this.buildMarkers(d.markers);
    if (d.views?.length) this.buildFrusta(d.views);
    if (d.boards?.length) this.buildBoards(d.boards);
    this.scene.updateMatrixWorld(true);

    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.requestRender());
    this.raycaster = new THREE.Raycaster();
    this.pickMark = new THREE.Mesh(new THREE.SphereGeometry(1, 12, 8),
                                   new THREE.MeshBasicMaterial({ color: 0xff00ff }));
    this.pickMark.visible = false;
    this.local.add(this.pickMark);
    // A click (not a drag) picks.
    let down = null;
    const canvas = this.renderer.domElement;
    canvas.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
    canvas.addEventListener('pointerup', (e) => {
      if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4 && e.button === 0) {
        this.pick(e.clientX, e.clientY);
      }
      down = null;
    });
  }

  toLocal(p) {
    return new THREE.Vector3(p[0] - this.origin[0], p[1] - this.origin[1], p[2] - this.origin[2]);
  }

  buildMarkers(markers) {
    const group = new THREE.Group();
    const geometry = new THREE.SphereGeometry(1, 16, 10);
    const colours = { 1: 0xdc0000, 2: 0xff8c00 };
    for (const mk of markers) {
      const material = new THREE.MeshBasicMaterial({ color: colours[mk.views] ?? 0x009600 });
      const s = new THREE.Mesh(geometry, material);
      s.scale.setScalar(Math.max(0.5, mk.radius_mm || 1));
      s.position.copy(this.toLocal(mk.centre));
      group.add(s);
      const label = element('div', 'fv-label', null, String(mk.id));
      label.title = `marker ${mk.id}, seen in ${mk.views} view(s)`;
      const l = new CSS2DObject(label);
      l.position.copy(s.position);
      l.center.set(-0.2, 1.2);
      group.add(l);
    }
    this.objects.markers = group;
    this.local.add(group);
  }

  // A camera's frustum: apex at its centre, the image's corners at depth_mm (sensor frame: x
  // right, y down, z forward; pixel (u, v) at depth z is ((u - cx) z / fx, (v - cy) z / fy, z)).
  frustumGeometry(v) {
    const z = v.depth_mm || 0.3 * this.modelSphere.radius;
    const corner = (u, w) => [((u - v.cx) * z) / v.fx, ((w - v.cy) * z) / v.fy, z];
    const c = [corner(0, 0), corner(v.width, 0), corner(v.width, v.height), corner(0, v.height)];
    const t = v.world_from_sensor;  // 3 x 4, row-major
    const apply = (p) => [
      t[0] * p[0] + t[1] * p[1] + t[2] * p[2] + t[3],
      t[4] * p[0] + t[5] * p[1] + t[6] * p[2] + t[7],
      t[8] * p[0] + t[9] * p[1] + t[10] * p[2] + t[11],
    ];
    const apex = this.toLocal(apply([0, 0, 0]));
    const w = c.map((p) => this.toLocal(apply(p)));
    const lines = [];
    for (let k = 0; k < 4; ++k) lines.push(apex, w[k], w[k], w[(k + 1) % 4]);
    // A tick on the image's top edge says which way is up in the camera.
    const top = w[0].clone().lerp(w[1], 0.5);
    lines.push(top, top.clone().lerp(apex, -0.15));
    return { geometry: new THREE.BufferGeometry().setFromPoints(lines), apex, corners: w };
  }

  buildFrusta(views) {
    const group = new THREE.Group();
    this.frusta = {};
    views.forEach((v, i) => {
      const { geometry, apex, corners } = this.frustumGeometry(v);
      const material = new THREE.LineBasicMaterial({ color: new THREE.Color(...categoryColour(i)) });
      const lines = new THREE.LineSegments(geometry, material);
      group.add(lines);
      const face = new THREE.Mesh(
          new THREE.BufferGeometry().setFromPoints(
              [corners[0], corners[1], corners[2], corners[0], corners[2], corners[3]]),
          new THREE.MeshBasicMaterial({ color: 0xff7f00, transparent: true, opacity: 0.35,
                                        side: THREE.DoubleSide, depthWrite: false }));
      face.visible = false;
      group.add(face);
      const label = element('div', 'fv-label fv-view', null, v.name);
      label.title = v.title || `view ${v.name}`;
      const l = new CSS2DObject(label);
      l.position.copy(apex);
      group.add(l);
      this.frusta[v.name] = { lines, face, label, colour: material.color.clone() };
    });
    this.objects.views = group;
    this.local.add(group);
  }

  // Calibration boards (one per pose): a quad through the outline's corners, its outline, and
  // its name; coloured by the colouring's per-board values when it has them (paintBoards).
  buildBoards(boards) {
    const group = new THREE.Group();
    this.boards = {};
    this.boardNames = boards.map((b) => b.name);
    for (const b of boards) {
      const c = b.corners.map((p) => this.toLocal(p));
      const g = new THREE.BufferGeometry().setFromPoints([c[0], c[1], c[2], c[0], c[2], c[3]]);
      g.computeVertexNormals();
      const face = new THREE.Mesh(g, new THREE.MeshLambertMaterial({
        color: new THREE.Color(...(b.colour || [0.8, 0.8, 0.8])), side: THREE.DoubleSide,
        transparent: true, opacity: 0.6, depthWrite: false }));
      group.add(face);
      const edge = new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints(c),
                                      new THREE.LineBasicMaterial({ color: 0x333333 }));
      group.add(edge);
      const label = element('div', 'fv-label', null, b.name);
      label.title = `board pose ${b.name}`;
      const l = new CSS2DObject(label);
      l.position.copy(c[0]);
      group.add(l);
      this.boards[b.name] = { face, edge, label, colour: face.material.color.clone() };
    }
    this.objects.boards = group;
    this.local.add(group);
  }

  paintBoards() {
    const k = this.colouring;
    const values = k.boards;
    const [lo, hi] = k.kind === 'category' || !values ? [0, 1] : this.range(k);
    this.boardNames.forEach((name, i) => {
      const b = this.boards[name];
      if (values && i < values.length) {
        const v = values[i];
        const c = k.kind === 'category' ? categoryColour(v)
                  : Number.isFinite(v) ? turbo((v - lo) / (hi - lo)) : kNoValue;
        b.colour.setRGB(c[0], c[1], c[2]);
      }
      const on = name === this.highlightedBoard;
      b.face.material.color.copy(b.colour);
      b.face.material.opacity = this.highlightedBoard && !on ? 0.2 : 0.6;
      b.edge.material.color.set(on ? 0xff5500 : 0x333333);
      b.label.style.background = on ? '#ff5500' : '';
    });
  }

  // --- Colours -----------------------------------------------------------------------------
  // Display-frame height of every vertex (or point): the colouring "height" needs no array.
  heights(positions) {
    const m = this.world.matrix.elements;  // column-major
    const out = new Float32Array(positions.length / 3);
    const [ox, oy, oz] = this.origin;
    for (let i = 0; i < out.length; ++i) {
      out[i] = m[2] * (positions[3 * i] + ox) + m[6] * (positions[3 * i + 1] + oy) +
               m[10] * (positions[3 * i + 2] + oz) + m[14];
    }
    return out;
  }

  values(colouring, what) {
    const d = this.description;
    if (colouring.kind === 'height') {
      const key = `height.${what}`;
      this.cache = this.cache || {};
      if (!this.cache[key]) this.cache[key] = this.heights(this.arrays[d[what].positions]);
      return this.cache[key];
    }
    return colouring[what] ? this.arrays[colouring[what]] : null;
  }

  range(colouring) {
    if (colouring.range) return colouring.range;
    if (!this.objects.mesh && !this.objects.points && colouring.boards) {
      colouring.range = quantiles(Float32Array.from(colouring.boards), 0, 1);
      return colouring.range;
    }
    const v = this.values(colouring, this.objects.mesh ? 'mesh' : 'points');
    colouring.range = v ? quantiles(v, 0.01, 0.99) : [0, 1];
    return colouring.range;
  }

  setColouring(id) {
    const colouring = this.colourings.find((k) => k.id === id) || this.colourings[0];
    if (!colouring) return;
    this.colouring = colouring;
    this.select.value = colouring.id;
    for (const what of ['mesh', 'points']) {
      if (this.objects[what]) this.paint(what);
    }
    if (this.boards) this.paintBoards();
    this.drawLegend();
    this.requestRender();
  }

  paint(what) {
    const k = this.colouring;
    const object = this.objects[what];
    const colour = object.geometry.getAttribute('color');
    const out = colour.array;
    const n = out.length / 3;
    const values = this.values(k, what);
    const viewOf = this.description[what].view ? this.arrays[this.description[what].view] : null;
    const highlight = this.highlighted === null ? -1 : this.viewNames.indexOf(this.highlighted);
    const [lo, hi] = k.kind === 'category' ? [0, 1] : this.range(k);
    for (let i = 0; i < n; ++i) {
      let c;
      const v = values ? values[i] : NaN;
      if (k.kind === 'category') {
        c = v === 65535 || v === 255 || !values ? kNoValue : categoryColour(v);
      } else {
        c = Number.isFinite(v) ? turbo((v - lo) / (hi - lo)) : kNoValue;
      }
      if (highlight >= 0 && viewOf && viewOf[i] !== highlight) {
        // Another view's: faded toward light grey, so the highlighted view's part stands out.
        c = [0.55 + 0.3 * c[0], 0.55 + 0.3 * c[1], 0.55 + 0.3 * c[2]];
      }
      out[3 * i] = c[0];
      out[3 * i + 1] = c[1];
      out[3 * i + 2] = c[2];
    }
    colour.needsUpdate = true;
  }

  drawLegend() {
    const k = this.colouring;
    this.legend.textContent = '';
    if (k.kind === 'category') {
      element('div', null, this.legend, k.title);
      const names = k.names || this.viewNames;
      const line = element('div', null, this.legend);
      names.forEach((name, i) => {
        const s = element('span', 'fv-swatch', line);
        s.style.background = categoryCss(i);
        line.appendChild(document.createTextNode(name));
      });
      return;
    }
    const canvas = element('canvas', 'fv-colour-bar', this.legend);
    canvas.width = 520;
    canvas.height = 48;
    const [lo, hi] = this.range(k);
    drawColourBar(canvas, lo, hi, k.label || k.title);
  }

  show(key, on) {
    if (this.objects[key]) this.objects[key].visible = on;
    if (this.toggles[key]) this.toggles[key].checked = on;
    this.requestRender();
  }

  // --- Views in the report's tables --------------------------------------------------------
  // Rows of the page's tables whose first cell names a view (or a board pose) select it here.
  connectTables() {
    const boardNames = this.boardNames || [];
    if (!this.viewNames.length && !boardNames.length) return;
    this.rows = [];
    for (const row of document.querySelectorAll('table tr')) {
      const first = row.querySelector('td');
      if (!first) continue;
      const name = first.textContent.trim();
      const isView = this.viewNames.includes(name);
      if (!isView && !boardNames.includes(name)) continue;
      row.classList.add('fringe-view-row');
      row.title = `show ${isView ? 'view' : 'board pose'} ${name} in the 3D view`;
      row.addEventListener('click', () => {
        if (isView) {
          this.highlightView(this.highlighted === name ? null : name);
        } else {
          this.highlightBoard(this.highlightedBoard === name ? null : name);
        }
        this.container.scrollIntoView({ behavior: 'smooth', block: 'start' });
      });
      this.rows.push({ row, name, isView });
    }
  }

  // Highlights board pose `name` (null: none): its outline and its table rows; the other boards
  // fade.
  highlightBoard(name) {
    this.highlightedBoard = name && this.boards?.[name] ? name : null;
    for (const { row, name: n, isView } of this.rows || []) {
      if (!isView) row.classList.toggle('fringe-view-selected', n === this.highlightedBoard);
    }
    if (this.boards) this.paintBoards();
    this.requestRender();
  }

  // Highlights view `name` (null: none): its frustum, its points and its table rows.
  highlightView(name) {
    this.highlighted = name && this.viewNames.includes(name) ? name : null;
    for (const [n, f] of Object.entries(this.frusta || {})) {
      const on = n === this.highlighted;
      f.lines.material.color.copy(on ? new THREE.Color(0xff5500) : f.colour);
      f.face.visible = on;
      f.label.style.background = on ? '#ff5500' : '';
    }
    for (const { row, name: n, isView } of this.rows || []) {
      if (isView) row.classList.toggle('fringe-view-selected', n === this.highlighted);
    }
    for (const what of ['mesh', 'points']) {
      if (this.objects[what]) this.paint(what);
    }
    this.requestRender();
  }

  // --- Camera ------------------------------------------------------------------------------
  // The home view: from the front, 45 degrees down, the whole model in the picture.
  reset() {
    const centre = this.modelSphere.center.clone().applyMatrix4(this.local.matrixWorld);
    const r = this.modelSphere.radius;
    const distance = r / Math.sin(THREE.MathUtils.degToRad(this.camera.fov / 2)) * 1.05;
    this.camera.position.copy(centre).add(new THREE.Vector3(0, -1, 1).normalize()
                                                .multiplyScalar(distance));
    this.camera.near = Math.max(0.01, distance / 100);
    this.camera.far = distance * 20;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.requestRender();
  }

  resize() {
    const w = this.port.clientWidth, h = this.port.clientHeight;
    if (!w || !h) return;
    this.renderer.setSize(w, h);
    this.labels.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.render();
    });
  }

  render() {
    this.renderer.render(this.scene, this.camera);
    this.labels.render(this.scene, this.camera);
    ++this.frames;
    if (this.firstFrameMs === null) {
      // The first frame is on screen at the next animation frame.
      requestAnimationFrame(() => {
        if (this.firstFrameMs === null) this.firstFrameMs = performance.now();
      });
    }
  }

  // --- Picking -----------------------------------------------------------------------------
  // The model's vertex (mesh) or point nearest the ray through client pixel (x, y), in the
  // world frame (mesh.ply's, mm) with its values; null when the ray misses. Shown below the
  // view and marked in it.
  pick(x, y) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((x - rect.left) / rect.width) * 2 - 1,
                                  -((y - rect.top) / rect.height) * 2 + 1);
    this.raycaster.setFromCamera(ndc, this.camera);
    let result = null;
    const d = this.description;
    if (this.objects.mesh?.visible) {
      const hit = this.raycaster.intersectObject(this.objects.mesh, false)[0];
      if (hit) {
        const p = this.arrays[d.mesh.positions];
        const local = this.objects.mesh.worldToLocal(hit.point.clone());
        let best = -1, bestD = Infinity;
        for (const v of [hit.face.a, hit.face.b, hit.face.c]) {
          const dd = (p[3 * v] - local.x) ** 2 + (p[3 * v + 1] - local.y) ** 2 +
                     (p[3 * v + 2] - local.z) ** 2;
          if (dd < bestD) { bestD = dd; best = v; }
        }
        result = { kind: 'mesh vertex', what: 'mesh', index: best };
      }
    }
    if (!result && this.objects.points?.visible) {
      this.raycaster.params.Points.threshold = Math.max(0.2, this.modelSphere.radius / 400);
      const hit = this.raycaster.intersectObject(this.objects.points, false)[0];
      if (hit) result = { kind: 'point', what: 'points', index: hit.index };
    }
    if (!result) {
      this.lastPick = null;
      this.pickMark.visible = false;
      this.info.textContent = 'No surface there.';
      this.requestRender();
      return null;
    }
    const p = this.arrays[d[result.what].positions];
    const i = result.index;
    result.local = [p[3 * i], p[3 * i + 1], p[3 * i + 2]];
    result.world = result.local.map((v, k) => v + this.origin[k]);
    const lines = [
      `${result.kind} ${i}: x ${result.world[0].toFixed(3)}  y ${result.world[1].toFixed(3)}  ` +
          `z ${result.world[2].toFixed(3)} mm (${d.frame || 'world frame'})`,
    ];
    for (const k of this.colourings) {
      if (k.kind === 'height' || !k[result.what]) continue;
      const v = this.arrays[k[result.what]][i];
      if (k.kind === 'category') {
        const names = k.names || this.viewNames;
        result[k.id] = v < names.length ? names[v] : null;
      } else {
        result[k.id] = Number.isFinite(v) ? v : null;
      }
      const shown = result[k.id] === null ? '—'
                    : k.kind === 'category' ? result[k.id]
                    : Number(result[k.id].toPrecision(4));
      lines.push(`${k.title}: ${shown}${k.unit && result[k.id] !== null ? ` ${k.unit}` : ''}`);
    }
    this.info.textContent = lines.join('\n');
    this.pickMark.position.set(...result.local);
    this.pickMark.scale.setScalar(Math.max(0.3, this.modelSphere.radius / 150));
    this.pickMark.visible = true;
    this.lastPick = result;
    this.requestRender();
    return result;
  }

  // --- Hooks for tests and benchmarks ------------------------------------------------------
  // Client pixel of a world point (mesh.ply's frame, mm).
  project(world) {
    const v = this.toLocal(world).applyMatrix4(this.local.matrixWorld).project(this.camera);
    const rect = this.renderer.domElement.getBoundingClientRect();
    return { x: rect.left + ((v.x + 1) / 2) * rect.width,
             y: rect.top + ((1 - v.y) / 2) * rect.height, depth: v.z };
  }

  // Turns the camera about the target by the given angles (radians), as a drag would.
  orbit(azimuth, polar = 0) {
    const offset = this.camera.position.clone().sub(this.controls.target);
    const s = new THREE.Spherical().setFromVector3(
        offset.clone().applyQuaternion(new THREE.Quaternion().setFromUnitVectors(
            this.camera.up, new THREE.Vector3(0, 1, 0))));
    s.theta += azimuth;
    s.phi = Math.min(Math.PI - 0.01, Math.max(0.01, s.phi + polar));
    offset.setFromSpherical(s).applyQuaternion(new THREE.Quaternion().setFromUnitVectors(
        new THREE.Vector3(0, 1, 0), this.camera.up));
    this.camera.position.copy(this.controls.target).add(offset);
    this.camera.lookAt(this.controls.target);
    this.requestRender();
  }

  // Renders `frames` frames, each turned a little, one per animation frame; resolves to the
  // mean frame time.
  benchOrbit(frames = 60) {
    return new Promise((resolve) => {
      let k = 0;
      const start = performance.now();
      const step = () => {
        this.orbit((2 * Math.PI) / frames);
        this.pending = false;
        this.render();
        if (++k < frames) {
          requestAnimationFrame(step);
        } else {
          requestAnimationFrame(() => {
            const ms = performance.now() - start;
            resolve({ frames, ms, frame_ms: ms / frames, fps: (1000 * frames) / ms });
          });
        }
      };
      requestAnimationFrame(step);
    });
  }
}

async function start() {
  const containers = document.querySelectorAll('.fringe-scene');
  if (!containers.length) return;
  const style = document.createElement('style');
  style.textContent = kStyle;
  document.head.appendChild(style);
  // Published together once every scene is read (reading is asynchronous: the arrays inflate).
  const viewers = [];
  const reason = webglUnavailableReason();
  for (const container of containers) {
    if (reason) {
      container.textContent = '';
      element('p', 'fv-message fv-no-webgl', container,
              `The interactive 3D view is not shown: ${reason}. The pictures below show the ` +
              'model; open this report in a browser with WebGL (any current desktop browser) ' +
              'to turn it in 3D.');
      continue;
    }
    try {
      const t0 = performance.now();
      const scene = await readScene(container);
      const t1 = performance.now();
      const viewer = new FringeViewer(container, scene);
      viewer.timings = { start_ms: t0, read_ms: t1 - t0, build_ms: performance.now() - t1 };
      viewers.push(viewer);
    } catch (e) {
      container.textContent = '';
      element('p', 'fv-message fv-failed', container,
              `The interactive 3D view could not be drawn: ${e.message}. The pictures below ` +
              'show the model.');
      console.error(e);
    }
  }
  window.fringeViewers = viewers;
  window.fringeViewer = viewers[0] || null;
  window.fringeViewerUnavailable = reason;
}

if (document.readyState === 'loading') {
  document.addEventListener('DOMContentLoaded', start);
} else {
  start();
}
