"""Small dataclasses for what the daemon answers, and their conversion from the API's messages.

Conventions are the API's (proto/shapesense/v1/shapesense.proto): times are capture times in
nanoseconds since the Unix epoch; 3D points are (x, y, z) in metres in the camera frame (OpenCV:
x right, y down, z forward); pixels are (x = column, y = row) from the top-left pixel. Images
are NumPy arrays when numpy and OpenCV (cv2) are importable, else None beside the PNG or JPEG
bytes the daemon sent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Generic, List, Optional, Sequence, Tuple, TypeVar


Vec3 = Tuple[float, float, float]
Pixel = Tuple[int, int]

T = TypeVar("T")


class ResultList(List[T], Generic[T]):
    """A list of results of one frame, with that frame's capture time.

    ``frame_timestamp_ns`` names the cached frame the results belong to; ``extra`` holds what
    else the answer said (e.g. the plane detector's name and its time on that frame).
    """

    def __init__(self, items: Sequence[T] = (), frame_timestamp_ns: int = 0, **extra: Any):
        super().__init__(items)
        self.frame_timestamp_ns = frame_timestamp_ns
        self.extra = extra


@dataclass
class FrameInfo:
    """One cached frame: capture time, delivery counter, size, colour, processed or not."""

    timestamp_ns: int
    sequence: int
    width: int
    height: int
    has_rgb: bool
    processed: bool


@dataclass
class Intrinsics:
    """Pinhole camera of a frame: focal lengths and principal point in pixels, image size."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def project(self, point: Vec3) -> Tuple[float, float]:
        """The pixel (x, y) a camera-frame point projects to."""
        x, y, z = point
        return (self.fx * x / z + self.cx, self.fy * y / z + self.cy)


@dataclass
class DepthStats:
    """The per-frame depth statistic: share of pixels with a reading; min, median, max metres."""

    valid_fraction: float
    min_m: float
    median_m: float
    max_m: float


@dataclass
class CacheRange:
    """Frames the daemon's cache holds now and at most, and their time range (0 when empty)."""

    frames: int
    capacity: int
    oldest_ns: int
    newest_ns: int


@dataclass
class StageLatency:
    """Runs and times of one pipeline stage (median and p95 over the last 256 runs)."""

    stage: str
    runs: int
    last_ms: float
    median_ms: float
    p95_ms: float


@dataclass
class CallLatency:
    """How long the daemon took to answer one method's calls since it started, from arrival to
    answer (the network and the client not included). ``answered_by_bucket[i]`` counts answered
    calls up to ``bucket_upper_ms[i]``; its last entry counts those above the last bound."""

    method: str
    answered: int
    refused: int
    failed: int
    bucket_upper_ms: List[float]
    answered_by_bucket: List[int]


@dataclass
class Status:
    """What ``shapesense status`` shows: source, its state, counters, cache, stage latency.

    ``source_state`` is the state's name: ``"STREAMING"``, ``"ENDED"``, ``"FAILED"``,
    ``"STOPPED"`` or ``"RECONNECTING"``.
    """

    version: str
    source: str
    source_state: str
    source_message: str
    frames_received: int
    frames_processed: int
    frames_skipped: int
    source_errors: int
    cache: CacheRange
    stages: List[StageLatency]
    uptime_s: float
    detectors: List[str]
    source_live: bool
    source_connected: bool
    source_reconnects: int
    source_dropped_frames: int
    frames_out_of_order: int
    source_disconnects: int
    session_id: str
    calls: List[CallLatency]


@dataclass
class Frame:
    """Depth and colour of one cached frame.

    ``depth``: float32 array (height x width) in metres, 0 where there is no reading.
    ``colour``: uint8 array (height x width x 3) in RGB order; None when the source has no
    colour. Both are None when numpy or cv2 is missing: the PNGs are in ``depth_png`` (16-bit
    millimetres) and ``rgb_png`` (8-bit RGB) either way.
    """

    info: FrameInfo
    intrinsics: Intrinsics
    depth_stats: DepthStats
    depth: Optional[Any]
    colour: Optional[Any]
    depth_png: bytes = field(repr=False)
    rgb_png: bytes = field(repr=False)


@dataclass
class PixelBox:
    """A 2D box in pixels: top-left corner, width and height."""

    x: int
    y: int
    width: int
    height: int


@dataclass
class Plane:
    """A plane of one frame (or, accumulated, a plane track stable while it stays in view).

    ``normal`` is unit and points towards the camera; ``n . X + d = 0`` (``d`` > 0 is the
    plane's distance in metres). ``polygon``: the region's boundary on the plane, camera frame;
    ``triangles``: its triangulation, three vertex indices each. ``colour``: mean (r, g, b) of
    the inliers, None when the source has no colour.
    """

    id: int
    group: int
    normal: Vec3
    d: float
    inliers: int
    rms_m: float
    box: PixelBox
    polygon: List[Vec3]
    triangles: List[Tuple[int, int, int]]
    colour: Optional[Tuple[int, int, int]]


@dataclass
class RoiDepthStats:
    """The depth statistics behind an estimated box (see RoiDepthStats in the proto)."""

    valid_pixels: int
    used_pixels: int
    mean_m: float
    std_m: float
    median_m: float
    min_m: float
    max_m: float
    near_m: float
    far_m: float
    moved_back_m: float
    range_from_origin: bool


@dataclass
class Box:
    """A 3D box: 8 corners in the camera frame, metres.

    Corner order: front face top-left, top-right, bottom-right, bottom-left, then the back face
    in the same order (``numpy.asarray(box.corners)`` is 8 x 3). ``size_m`` is (width, height,
    depth): the front face's mean edge lengths across and up, and the front-to-back distance.
    """

    corners: List[Vec3]
    size_m: Vec3
    frame_timestamp_ns: int
    frame_sequence: int = 0
    mode: str = ""
    stats: Optional[RoiDepthStats] = None
    collapsed_x: bool = False
    collapsed_y: bool = False


@dataclass
class DetectedBox:
    """A box the daemon derived from its own detections: ``source`` "bowl" or "segment"."""

    source: str
    source_id: int
    p1: Pixel
    p2: Pixel
    box: Box
    score: float
    view: str


@dataclass
class Segment:
    """A region of the depth segmentation (its id is its value in the label image)."""

    id: int
    pixels: int
    centroid: Vec3
    normal: Vec3
    plane_rms_m: float
    box: PixelBox


@dataclass
class Segments:
    """The segmentation of one frame. ``labels``: uint16 region ids (0 = unassigned) when asked
    for and numpy and cv2 are there; ``labels_png`` holds the PNG either way."""

    frame_timestamp_ns: int
    method: str
    computed_on_request: bool
    segments: List[Segment]
    compute_ms: float
    labels: Optional[Any] = None
    labels_png: bytes = field(default=b"", repr=False)


@dataclass
class Bowl:
    """A bowl of the bowl stage: image box, score, view class ("top", "middle", "side"), the 3D
    box behind the image box (None when the box holds no depth), rim and height in metres (0
    when the depth could not settle them), and the id of the plane it stands on (0: none)."""

    box: PixelBox
    score: float
    view: str
    box3d: Optional[Box]
    rim_diameter_m: float
    height_m: float
    support_plane_id: int


@dataclass
class ObjectModelInfo:
    """A taught object: its name, how many shape features and surface points describe it, the
    full extent of its box along the box's axes (metres) and when its file was written
    (``taught_at_ns``, wall clock)."""

    name: str
    feature_count: int
    surface_points: int
    box_size_m: Vec3
    taught_at_ns: int


@dataclass
class TaughtObject:
    """What TeachObject answered: the model and the frame it was taught from; ``replaced``
    says a model of that name was replaced."""

    model: ObjectModelInfo
    frame_timestamp_ns: int
    frame_sequence: int
    replaced: bool


@dataclass
class OrientedBox:
    """A box with its own axes, camera frame: ``orientation`` (w, x, y, z) turns the box's
    axes into the camera's; ``size_m`` is its full extent along them; ``corners`` the 8
    corners (a face loop at -z, then the same loop at +z)."""

    centre: Vec3
    orientation: Tuple[float, float, float, float]
    size_m: Vec3
    corners: List[Vec3]


@dataclass
class ObjectDetection:
    """A taught object found in a frame: the pose ``camera_from_model`` as ``translation``
    (metres) and ``rotation`` (w, x, y, z) (about the identity in the frame it was taught
    from), ``score`` (share of its visible points the depth confirms), its box in this frame
    and that box's projection into the image (``image_box``, clipped)."""

    name: str
    translation: Vec3
    rotation: Tuple[float, float, float, float]
    score: float
    confirmed_points: int
    feature_inliers: int
    box: OrientedBox
    image_box: PixelBox


@dataclass
class StageTiming:
    """Time of one pipeline stage on one frame."""

    stage: str
    ms: float


@dataclass
class FrameSummary:
    """What ``watch()`` yields for every processed frame."""

    info: FrameInfo
    depth_stats: DepthStats
    timings: List[StageTiming]
    dropped_before: int
    segments: int
    planes: int
    bowls: int
    taught_objects: int = 0


@dataclass
class RecordProgress:
    """Progress of a recording the daemon writes: frames written and dropped so far, seconds
    since the start, the recording's path on the daemon's machine, ``done`` on the last."""

    frames_written: int
    frames_dropped: int
    seconds: float
    done: bool
    dir: str


@dataclass
class ScenePlane:
    """A stable plane of the scene model: track id, plane, boundary polygon and its
    triangulation, mean colour 0xRRGGBB and image box of the last sighting."""

    id: int
    normal: Vec3
    d: float
    polygon: List[Vec3]
    triangles: List[Tuple[int, int, int]]
    rgb: int
    box: PixelBox


@dataclass
class SceneObject:
    """A tracked thing with a 3D box: ``kind`` "OBJECT" (a segment on a plane) or "BOWL"."""

    id: int
    kind: str
    box: Box
    image_box: PixelBox
    score: float
    frames_seen: int
    frames_missed: int


@dataclass
class SceneUpdate:
    """One scene model update (GetScene, WatchScene).

    ``full``: planes and objects are the whole scene; otherwise they are what was added or
    changed since the previous update and ``removed_*`` name what left. ``preview``: the preview
    image as an RGB uint8 array when one was sent and cv2 is there (``preview_jpeg`` either
    way). A changed ``session_id`` means the daemon restarted (track ids start over).
    """

    session_id: str
    info: FrameInfo
    intrinsics: Intrinsics
    full: bool
    planes: List[ScenePlane]
    objects: List[SceneObject]
    removed_plane_ids: List[int]
    removed_object_ids: List[int]
    dropped_before: int
    timings: List[StageTiming]
    preview: Optional[Any] = None
    preview_jpeg: bytes = field(default=b"", repr=False)
    preview_width: int = 0
    preview_height: int = 0
    #: The taught objects the daemon's taught-object stage found in this frame (every update
    #: carries all of them; empty when the stage is off).
    taught_objects: List[ObjectDetection] = field(default_factory=list)


# ---------------------------------------------------------------------------------------------
# Conversion from the generated messages.


def vec3(p: Any) -> Vec3:
    return (p.x, p.y, p.z)


def frame_info(m: Any) -> FrameInfo:
    return FrameInfo(m.timestamp_ns, m.sequence, m.width, m.height, m.has_rgb, m.processed)


def intrinsics(m: Any) -> Intrinsics:
    return Intrinsics(m.fx, m.fy, m.cx, m.cy, m.width, m.height)


def depth_stats(m: Any) -> DepthStats:
    return DepthStats(m.valid_fraction, m.min_m, m.median_m, m.max_m)


def cache_range(m: Any) -> CacheRange:
    return CacheRange(m.frames, m.capacity, m.oldest_ns, m.newest_ns)


def pixel_box(m: Any) -> PixelBox:
    return PixelBox(m.x, m.y, m.width, m.height)


def triangles(values: Sequence[Any]) -> List[Tuple[Any, Any, Any]]:
    """A flat list in threes: triangle indices, or packed x, y, z vertices."""
    return [tuple(values[i : i + 3]) for i in range(0, len(values) - 2, 3)]  # type: ignore


def _distance(a: Vec3, b: Vec3) -> float:
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def box_size(corners: Sequence[Vec3]) -> Vec3:
    """(width, height, depth) of a box in EstimateBoxResponse corner order, metres."""
    if len(corners) != 8:
        return (0.0, 0.0, 0.0)
    c = corners
    width = (_distance(c[0], c[1]) + _distance(c[3], c[2])) / 2
    height = (_distance(c[0], c[3]) + _distance(c[1], c[2])) / 2
    depth = sum(_distance(c[i], c[i + 4]) for i in range(4)) / 4
    return (width, height, depth)


def box_from_corners(points: Sequence[Any], frame_timestamp_ns: int) -> Box:
    corners = [vec3(p) for p in points]
    return Box(corners, box_size(corners), frame_timestamp_ns)


def roi_depth_stats(m: Any) -> RoiDepthStats:
    return RoiDepthStats(m.valid_pixels, m.used_pixels, m.mean_m, m.std_m, m.median_m, m.min_m,
                         m.max_m, m.near_m, m.far_m, m.moved_back_m, m.range_from_origin)


def plane(m: Any) -> Plane:
    colour = (m.mean_r, m.mean_g, m.mean_b) if m.has_colour else None
    return Plane(m.id, m.group, vec3(m.normal), m.d, m.inliers, m.rms_m, pixel_box(m.box),
                 [vec3(p) for p in m.polygon], triangles(m.triangles), colour)


def segment(m: Any) -> Segment:
    return Segment(m.id, m.pixels, vec3(m.centroid), vec3(m.normal), m.plane_rms_m,
                   pixel_box(m.box))


def timings(items: Sequence[Any]) -> List[StageTiming]:
    return [StageTiming(t.stage, t.ms) for t in items]


def frame_summary(m: Any) -> FrameSummary:
    return FrameSummary(frame_info(m.info), depth_stats(m.depth_stats), timings(m.timings),
                        m.dropped_before, m.segments, m.planes, m.bowls, m.taught_objects)


# ---------------------------------------------------------------------------------------------
# Images.


_imaging: Optional[Tuple[Any, Any]] = None


def _numpy_and_cv2() -> Optional[Tuple[Any, Any]]:
    """(numpy, cv2), imported on first use (cv2 takes a second to import: scripts that never
    look at an image do not pay for it); None when either is missing."""
    global _imaging
    if _imaging is None:
        try:
            import cv2
            import numpy
        except ImportError:
            _imaging = (None, None)
        else:
            _imaging = (numpy, cv2)
    return None if _imaging[0] is None else _imaging


def images_available() -> bool:
    """True when images are decoded into arrays (numpy and cv2 importable)."""
    return _numpy_and_cv2() is not None


def decode_png(data: bytes, colour: bool = False) -> Optional[Any]:
    """A PNG (or JPEG) as an array: 16-bit or 8-bit grey as is, colour as RGB; None when empty
    or when numpy or cv2 is missing."""
    modules = _numpy_and_cv2() if data else None
    if modules is None:
        return None
    np, cv2 = modules
    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        return None
    if colour and image.ndim == 3:
        image = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    return image


def depth_metres(depth_png: bytes) -> Optional[Any]:
    """The daemon's 16-bit millimetre depth PNG as float32 metres (0 = no reading)."""
    millimetres = decode_png(depth_png)
    if millimetres is None:
        return None
    np = _numpy_and_cv2()[0]  # type: ignore[index]
    return millimetres.astype(np.float32) * np.float32(0.001)


def quaternion(m: Any) -> Tuple[float, float, float, float]:
    return (m.w, m.x, m.y, m.z)


def object_model_info(m: Any) -> ObjectModelInfo:
    return ObjectModelInfo(m.name, m.feature_count, m.surface_points, vec3(m.box_size),
                           m.taught_at_ns)


def object_detection(m: Any) -> ObjectDetection:
    box = OrientedBox(vec3(m.box.centre), quaternion(m.box.orientation), vec3(m.box.size),
                      [vec3(c) for c in m.box.corners])
    return ObjectDetection(m.name, vec3(m.translation), quaternion(m.rotation), m.score,
                           m.confirmed_points, m.feature_inliers, box, pixel_box(m.image_box))
