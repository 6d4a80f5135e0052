// The camera view: the preview image of one frame with the overlays computed on that same frame,
// and the rectangle the operator draws. The canvas works in full-resolution image pixels (the
// frame's intrinsics), so projections and the drawn rectangle need no rescaling; the preview is
// scaled up to it.

import { BOX_EDGES, COLOURS, cssColour, objectLabel, project } from './geometry.js';

export class View2D {
  /// onRectangle({p1, p2}): a rectangle was drawn, corners in full-resolution pixels.
  constructor(canvas, onRectangle) {
    this.canvas = canvas;
    this.context = canvas.getContext('2d');
    this.onRectangle = onRectangle;
    this.frame = null;      // {timestampNs, image, scene}
    this.segments = null;   // {timestampNs, image}
    this.userBox = null;    // {timestampNs, corners, p1, p2}
    this.overlays = { planes: true, segments: false, boxes: true, bowls: true };
    this.dragging = null;   // {start, end} in image pixels
    this.listenForRectangles();
  }

  /// Shows `image` (an ImageBitmap of the preview) with the things of `scene` (a SceneState
  /// snapshot of the same frame).
  show(image, scene) {
    const { width, height } = scene.intrinsics;
    if (this.canvas.width !== width || this.canvas.height !== height) {
      this.canvas.width = width;
      this.canvas.height = height;
    }
    this.frame = { timestampNs: scene.info.timestamp_ns, image, scene };
    this.redraw();
  }

  shownTimestampNs() {
    return this.frame ? this.frame.timestampNs : null;
  }

  /// The coloured segments image of frame `timestampNs`; drawn only over that frame.
  setSegments(timestampNs, image) {
    this.segments = { timestampNs, image };
    this.redraw();
  }

  setUserBox(box) {
    this.userBox = box;
    this.redraw();
  }

  setOverlay(name, on) {
    this.overlays[name] = on;
    this.redraw();
  }

  redraw() {
    const g = this.context;
    g.fillStyle = '#000';
    g.fillRect(0, 0, this.canvas.width, this.canvas.height);
    if (!this.frame) return;
    const { image, scene, timestampNs } = this.frame;
    g.drawImage(image, 0, 0, this.canvas.width, this.canvas.height);
    const sameFrame = (thing) => thing && thing.timestampNs === timestampNs;
    if (this.overlays.segments && sameFrame(this.segments)) {
      g.globalAlpha = 0.45;
      g.drawImage(this.segments.image, 0, 0, this.canvas.width, this.canvas.height);
      g.globalAlpha = 1;
    }
    if (this.overlays.planes) for (const plane of scene.planes) this.drawPlane(plane, scene);
    for (const object of scene.objects) {
      const bowl = object.kind === 'BOWL';
      if (bowl ? !this.overlays.bowls : !this.overlays.boxes) continue;
      const colour = bowl ? COLOURS.bowl : COLOURS.object;
      this.drawBox(object.corners, scene.intrinsics, colour, objectLabel(object),
                   object.frames_missed > 0);
    }
    if (this.overlays.boxes) {
      for (const taught of scene.taughtObjects) {
        this.drawBox(taught.box.corners, scene.intrinsics, COLOURS.taught, taught.name);
      }
    }
    if (sameFrame(this.userBox)) {
      this.drawRectangle(this.userBox.p1, this.userBox.p2, '#ffffff');
      this.drawBox(this.userBox.corners, scene.intrinsics, COLOURS.userBox, this.userBox.label);
    }
    if (this.dragging) this.drawRectangle(this.dragging.start, this.dragging.end, '#ffffff');
  }

  drawPlane(plane, scene) {
    const xyz = plane.polygon_xyz;
    const g = this.context;
    g.beginPath();
    let sumX = 0, sumY = 0, count = 0;
    for (let i = 0; i + 2 < xyz.length; i += 3) {
      const pixel = project(scene.intrinsics, xyz[i], xyz[i + 1], xyz[i + 2]);
      if (!pixel) continue;
      if (count === 0) g.moveTo(pixel[0], pixel[1]); else g.lineTo(pixel[0], pixel[1]);
      sumX += pixel[0]; sumY += pixel[1]; ++count;
    }
    if (count < 3) return;
    g.closePath();
    g.fillStyle = cssColour(plane.rgb, 0.25);
    g.fill();
    g.strokeStyle = '#7fd1ff';
    g.lineWidth = 1.5;
    g.stroke();
    this.drawLabel('P' + plane.id, sumX / count, sumY / count, '#7fd1ff');
  }

  drawBox(corners, intrinsics, colour, label, dashed = false) {
    const pixels = corners.map((c) => project(intrinsics, c.x, c.y, c.z));
    const g = this.context;
    g.strokeStyle = cssColour(colour);
    g.lineWidth = 2;
    g.setLineDash(dashed ? [4, 4] : []);
    g.beginPath();
    for (const [a, b] of BOX_EDGES) {
      if (!pixels[a] || !pixels[b]) continue;
      g.moveTo(pixels[a][0], pixels[a][1]);
      g.lineTo(pixels[b][0], pixels[b][1]);
    }
    g.stroke();
    g.setLineDash([]);
    const top = pixels.filter(Boolean).reduce((best, p) => (!best || p[1] < best[1] ? p : best), null);
    if (top && label) this.drawLabel(label, top[0], top[1] - 6, cssColour(colour));
  }

  drawRectangle(p1, p2, colour) {
    const g = this.context;
    g.strokeStyle = colour;
    g.lineWidth = 1;
    g.setLineDash([5, 3]);
    g.strokeRect(Math.min(p1.x, p2.x), Math.min(p1.y, p2.y), Math.abs(p2.x - p1.x),
                 Math.abs(p2.y - p1.y));
    g.setLineDash([]);
  }

  drawLabel(text, x, y, colour) {
    const g = this.context;
    g.font = 'bold 13px system-ui, sans-serif';
    const width = g.measureText(text).width;
    g.fillStyle = 'rgba(0, 0, 0, 0.6)';
    g.fillRect(x - width / 2 - 3, y - 13, width + 6, 17);
    g.fillStyle = colour;
    g.fillText(text, x - width / 2, y);
  }

  /// The image pixel under a pointer event, clamped into the image.
  pixelAt(event) {
    const rect = this.canvas.getBoundingClientRect();
    const x = (event.clientX - rect.left) * this.canvas.width / rect.width;
    const y = (event.clientY - rect.top) * this.canvas.height / rect.height;
    const clamp = (v, max) => Math.min(Math.max(Math.round(v), 0), max - 1);
    return { x: clamp(x, this.canvas.width), y: clamp(y, this.canvas.height) };
  }

  listenForRectangles() {
    this.canvas.addEventListener('pointerdown', (event) => {
      if (!this.frame || event.button !== 0) return;
      this.canvas.setPointerCapture(event.pointerId);
      const start = this.pixelAt(event);
      this.dragging = { start, end: start };
    });
    this.canvas.addEventListener('pointermove', (event) => {
      if (!this.dragging) return;
      this.dragging.end = this.pixelAt(event);
      this.redraw();
    });
    const finish = (event) => {
      if (!this.dragging) return;
      const { start } = this.dragging;
      const end = this.pixelAt(event);
      this.dragging = null;
      this.redraw();
      if (Math.abs(end.x - start.x) < 2 || Math.abs(end.y - start.y) < 2) return;  // a click
      this.onRectangle({
        p1: { x: Math.min(start.x, end.x), y: Math.min(start.y, end.y) },
        p2: { x: Math.max(start.x, end.x), y: Math.max(start.y, end.y) },
      });
    };
    this.canvas.addEventListener('pointerup', finish);
    this.canvas.addEventListener('pointercancel', () => { this.dragging = null; this.redraw(); });
  }
}
