// The scene model as the daemon sends it: kept by applying SceneUpdates (a full update replaces
// everything, a delta adds or replaces things by id and names the ones that left).

export class SceneState {
  constructor() {
    this.sessionId = null;
    this.planes = new Map();   // id -> ScenePlane (JSON)
    this.objects = new Map();  // id -> SceneObject (JSON)
    this.taughtObjects = [];   // ObjectDetection (JSON) of the last update: each carries all
    this.info = null;          // FrameInfo of the last update applied
    this.intrinsics = null;
  }

  /// Applies one update; returns true when it came from another daemon session than the state
  /// held (the daemon restarted: track ids started over, so the old state was dropped).
  apply(update) {
    const restarted = this.sessionId !== null && update.session_id !== this.sessionId;
    if (restarted || update.full) {
      this.planes.clear();
      this.objects.clear();
    }
    this.sessionId = update.session_id;
    for (const plane of update.planes) this.planes.set(plane.id, plane);
    for (const object of update.objects) this.objects.set(object.id, object);
    for (const id of update.removed_plane_ids) this.planes.delete(id);
    for (const id of update.removed_object_ids) this.objects.delete(id);
    this.taughtObjects = update.taught_objects || [];
    this.info = update.info;
    this.intrinsics = update.intrinsics;
    return restarted;
  }

  /// Forgets everything: a new daemon session (seen in its status) sends a full update next.
  reset(sessionId) {
    this.sessionId = sessionId;
    this.planes.clear();
    this.objects.clear();
    this.taughtObjects = [];
  }

  /// A copy that later updates do not change: what one frame's overlays are drawn from.
  snapshot() {
    return {
      sessionId: this.sessionId,
      info: this.info,
      intrinsics: this.intrinsics,
      planes: [...this.planes.values()],
      objects: [...this.objects.values()],
      taughtObjects: this.taughtObjects,
    };
  }

  static fromFullUpdate(update) {
    const state = new SceneState();
    state.apply(update);
    return state;
  }
}
