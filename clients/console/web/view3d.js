// The 3D view of the scene model: plane polygons as meshes in their colour, object and bowl boxes
// as wireframes, the operator's box, each with its id. three.js is y-up with the camera looking
// down -z; the API's camera frame is y-down, z-forward, so points are shown as (x, -y, -z).

import * as THREE from 'three';
import { OrbitControls } from 'three/orbit-controls';
import { BOX_EDGES, COLOURS, objectLabel } from './geometry.js';

const toView = (x, y, z) => new THREE.Vector3(x, -y, -z);

export class View3D {
  constructor(container) {
    this.container = container;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x101317);
    this.planes = new THREE.Group();
    this.objects = new THREE.Group();
    this.userBox = new THREE.Group();
    this.scene.add(this.planes, this.objects, this.userBox, new THREE.AxesHelper(0.2));
    this.camera = new THREE.PerspectiveCamera(50, 4 / 3, 0.01, 50);
    this.camera.position.set(0.45, 0.7, 0.35);  // above and behind the sensor, looking at the scene
    this.labels = new LabelTextures();
    this.materials = new Materials();
    this.renderer = this.makeRenderer();
    this.needsRender = true;
    this.pendingScene = null;  // built at the next animation frame: at most one build a frame
    if (this.renderer) {
      container.appendChild(this.renderer.domElement);
      this.controls = new OrbitControls(this.camera, this.renderer.domElement);
      this.controls.target.set(0, -0.1, -1.4);
      this.controls.addEventListener('change', () => { this.needsRender = true; });
      this.controls.update();
      new ResizeObserver(() => this.resize()).observe(container);
      this.resize();
      const loop = () => {
        if (this.pendingScene) this.build(this.pendingScene);
        this.pendingScene = null;
        if (this.needsRender) this.renderer.render(this.scene, this.camera);
        this.needsRender = false;
        requestAnimationFrame(loop);
      };
      loop();
    }
  }

  /// A WebGL renderer, or null where the browser has no WebGL (the model is still kept).
  makeRenderer() {
    try {
      return new THREE.WebGLRenderer({ antialias: false });
    } catch (error) {
      const note = document.createElement('div');
      note.className = 'muted';
      note.style.padding = '1em';
      note.textContent = 'This browser offers no WebGL: the 3D view is off.';
      this.container.appendChild(note);
      return null;
    }
  }

  resize() {
    const width = this.container.clientWidth, height = this.container.clientHeight;
    if (!width || !height) return;
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.needsRender = true;
  }

  /// Shows the things of a SceneState snapshot (replacing what was shown).
  show(scene) {
    if (this.renderer) this.pendingScene = scene; else this.build(scene);
  }

  build(scene) {
    clear(this.planes);
    clear(this.objects);
    for (const plane of scene.planes) this.planes.add(planeMesh(plane, this.materials, this.labels));
    for (const object of scene.objects) {
      const colour = object.kind === 'BOWL' ? COLOURS.bowl : COLOURS.object;
      this.objects.add(wireBox(object.corners, colour, objectLabel(object), this.materials,
                               this.labels));
    }
    for (const taught of scene.taughtObjects) {
      this.objects.add(wireBox(taught.box.corners, COLOURS.taught, taught.name, this.materials,
                               this.labels));
    }
    this.taughtShown = scene.taughtObjects.length;
    this.needsRender = true;
  }

  setUserBox(corners, label) {
    clear(this.userBox);
    if (corners) {
      this.userBox.add(wireBox(corners, COLOURS.userBox, label, this.materials, this.labels));
    }
    this.needsRender = true;
  }

  /// Plane meshes in the 3D scene.
  planeCount() {
    return this.planes.children.length;
  }

  /// Taught objects drawn by the last build.
  taughtCount() {
    return this.taughtShown || 0;
  }
}

/// The materials, made once and kept: three.js frees a shader program with the last material
/// that uses it, and compiling it again for every update would take most of the page's time.
class Materials {
  constructor() {
    // Plane colours are vertex colours, so every plane shares this one.
    this.plane = new THREE.MeshBasicMaterial({
      vertexColors: THREE.VertexColors, side: THREE.DoubleSide, transparent: true, opacity: 0.85 });
    this.lines = new Map();
  }

  line(colour) {
    if (!this.lines.has(colour)) this.lines.set(colour, new THREE.LineBasicMaterial({ color: colour }));
    return this.lines.get(colour);
  }
}

/// The label materials made so far: ids repeat from update to update, so each is drawn once.
class LabelTextures {
  constructor() {
    this.materials = new Map();
  }

  get(text, colour) {
    const key = `${text}/${colour}`;
    if (!this.materials.has(key)) {
      this.materials.set(key, new THREE.SpriteMaterial({
        map: labelTexture(text, colour), depthTest: false, sizeAttenuation: false }));
    }
    return this.materials.get(key);
  }
}

/// Removes what a group shows; geometries go, the shared materials stay.
function clear(group) {
  for (const child of [...group.children]) {
    child.traverse((node) => { if (node.geometry && !node.isSprite) node.geometry.dispose(); });
    group.remove(child);
  }
}

function planeMesh(plane, materials, labels) {
  const xyz = plane.polygon_xyz;
  const positions = new Float32Array(xyz.length);
  const colours = new Float32Array(xyz.length);
  const colour = new THREE.Color(plane.rgb);
  for (let i = 0; i + 2 < xyz.length; i += 3) {
    const v = toView(xyz[i], xyz[i + 1], xyz[i + 2]);
    positions.set([v.x, v.y, v.z], i);
    colours.set([colour.r, colour.g, colour.b], i);
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
  geometry.setIndex(plane.triangles);
  const group = new THREE.Group();
  group.userData.planeId = plane.id;
  group.add(new THREE.Mesh(geometry, materials.plane));
  const outline = new THREE.BufferGeometry();
  outline.setAttribute('position', new THREE.BufferAttribute(positions.slice(), 3));
  group.add(new THREE.LineLoop(outline, materials.line(0x7fd1ff)));
  if (xyz.length >= 3) {
    geometry.computeBoundingBox();
    const centre = new THREE.Vector3();
    geometry.boundingBox.getCenter(centre);
    group.add(label(labels, 'P' + plane.id, centre, 0x7fd1ff));
  }
  return group;
}

function wireBox(corners, colour, text, materials, labels) {
  const points = corners.map((c) => toView(c.x, c.y, c.z));
  const positions = [];
  for (const [a, b] of BOX_EDGES) positions.push(...points[a].toArray(), ...points[b].toArray());
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  const group = new THREE.Group();
  group.add(new THREE.LineSegments(geometry, materials.line(colour)));
  const top = points.reduce((best, p) => (p.y > best.y ? p : best), points[0]);
  group.add(label(labels, text, top.clone().add(new THREE.Vector3(0, 0.04, 0)), colour));
  return group;
}

/// A text sprite that keeps its size on screen.
function label(labels, text, position, colour) {
  const material = labels.get(text, colour);
  const sprite = new THREE.Sprite(material);
  const { width, height } = material.map.image;
  sprite.scale.set(0.025 * width / height, 0.025, 1);
  sprite.position.copy(position);
  sprite.renderOrder = 1;
  return sprite;
}

function labelTexture(text, colour) {
  const canvas = document.createElement('canvas');
  const g = canvas.getContext('2d');
  g.font = 'bold 40px system-ui, sans-serif';
  canvas.width = Math.ceil(g.measureText(text).width) + 16;
  canvas.height = 52;
  g.font = 'bold 40px system-ui, sans-serif';
  g.fillStyle = 'rgba(0, 0, 0, 0.55)';
  g.fillRect(0, 0, canvas.width, canvas.height);
  g.fillStyle = '#' + colour.toString(16).padStart(6, '0');
  g.fillText(text, 8, 40);
  const texture = new THREE.CanvasTexture(canvas);
  texture.minFilter = THREE.LinearFilter;  // no mipmaps: the label need not be a power of two
  return texture;
}
