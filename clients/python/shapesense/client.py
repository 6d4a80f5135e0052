"""shapesense.Client: the daemon's gRPC API behind typed helpers."""

from __future__ import annotations

import time
from typing import Any, Callable, Iterator, List, Optional, Sequence, Tuple, Union

import grpc

from . import types as t
from .errors import ShapeSenseError
from .v1 import shapesense_pb2 as pb
from .v1 import shapesense_pb2_grpc as pb_grpc

DEFAULT_ADDRESS = "127.0.0.1:50551"  # shapesensed's default --listen

BoxModeArg = Union[str, int]
_BOX_MODES = {
    "frustum_aligned": pb.BOX_MODE_FRUSTUM_ALIGNED,
    "axis_aligned_contained": pb.BOX_MODE_AXIS_ALIGNED_CONTAINED,
    "axis_aligned_front_face": pb.BOX_MODE_AXIS_ALIGNED_FRONT_FACE,
    "segments": pb.BOX_MODE_SEGMENTS,
}
_PREVIEW_KINDS = {"none": pb.PreviewRequest.NONE, "colour": pb.PreviewRequest.COLOUR,
                  "color": pb.PreviewRequest.COLOUR, "depth": pb.PreviewRequest.DEPTH}

# As `shapesense watch` (clients/cli/connection.cpp, freshStreamArguments): the smallest window
# gRPC allows for streams, never grown by bandwidth probing, so a slow reader gets fresh updates
# from the daemon's latest-wins queue instead of seconds of buffered ones.
_STREAM_OPTIONS = [("grpc.http2.bdp_probe", 0), ("grpc.http2.lookahead_bytes", 1)]


def box_mode(mode: BoxModeArg) -> int:
    """The BoxMode of a name ("frustum_aligned", "axis_aligned_contained",
    "axis_aligned_front_face", "segments") or of its mode number 1, 2, 3, 4."""
    if isinstance(mode, int):
        if mode in (1, 2, 3, 4):
            return mode
    elif mode.lower() in _BOX_MODES:
        return _BOX_MODES[mode.lower()]
    raise ValueError(f"box mode {mode!r} is not one of {', '.join(_BOX_MODES)} (or 1, 2, 3, 4)")


def read_token(path: str) -> str:
    """The bearer token of a token file: its first line that is not blank once a `#` comment
    is cut off (as the CLI's --token-file reads it)."""
    with open(path, encoding="utf-8") as f:
        for line in f:
            token = line.split("#", 1)[0].strip()
            if token:
                return token
    raise ValueError(f"token file {path} holds no token")


def _read_bytes(path: str, option: str) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as e:
        raise ValueError(f"cannot read {option} {path}: {e.strerror}") from e


class Client:
    """A connection to shapesensed.

    Options mirror the ``shapesense`` CLI's: ``address`` (--server), ``tls_ca`` (--tls-ca: PEM
    CA bundle; connect with TLS), ``tls_cert``/``tls_key`` (this client's certificate, for a
    daemon started with --tls-client-ca), ``token_file`` (--token-file: a bearer token sent as
    ``authorization: Bearer TOKEN`` with every call; needs TLS, a token never travels in clear
    text) and ``timeout`` (seconds each unary call may take). A unary call the daemon refuses
    with RESOURCE_EXHAUSTED (all its query workers busy: README "Load limits") is tried again
    up to ``busy_retries`` times after a short pause (50, 100, 200 ms ...) before it raises.

    Times are capture times in nanoseconds since the epoch; ``at_ns=0`` means the newest frame
    (for detector results: the newest frame the detectors have processed, as the CLI does).
    Every failed call raises :class:`ShapeSenseError`. Use it as a context manager or call
    :meth:`close`.
    """

    def __init__(self, address: str = DEFAULT_ADDRESS, tls_ca: Optional[str] = None,
                 token_file: Optional[str] = None, timeout: float = 5.0,
                 tls_cert: Optional[str] = None, tls_key: Optional[str] = None,
                 busy_retries: int = 3):
        self.address = address
        self.timeout = timeout
        self.busy_retries = busy_retries
        self._credentials = self._make_credentials(tls_ca, token_file, tls_cert, tls_key)
        self._channel = self._open_channel([])
        self._stub = pb_grpc.ShapeSenseStub(self._channel)
        self._stream_channel: Optional[grpc.Channel] = None

    # -- connection ------------------------------------------------------------------------

    @staticmethod
    def _make_credentials(tls_ca: Optional[str], token_file: Optional[str],
                          tls_cert: Optional[str],
                          tls_key: Optional[str]) -> Optional[grpc.ChannelCredentials]:
        if not tls_ca:
            if tls_cert:
                raise ValueError("tls_cert needs tls_ca (the CA of the daemon's certificate)")
            if token_file:
                raise ValueError("token_file needs tls_ca: a token is never sent in clear text "
                                 "(the daemon takes tokens only over TLS)")
            return None
        if bool(tls_cert) != bool(tls_key):
            raise ValueError("tls_cert and tls_key go together: give both or neither")
        credentials = grpc.ssl_channel_credentials(
            root_certificates=_read_bytes(tls_ca, "tls_ca"),
            private_key=_read_bytes(tls_key, "tls_key") if tls_key else None,
            certificate_chain=_read_bytes(tls_cert, "tls_cert") if tls_cert else None)
        if token_file:
            # gRPC sends it as `authorization: Bearer TOKEN`, what the daemon reads.
            credentials = grpc.composite_channel_credentials(
                credentials, grpc.access_token_call_credentials(read_token(token_file)))
        return credentials

    def _open_channel(self, options: List[Tuple[str, Any]]) -> grpc.Channel:
        if self._credentials is None:
            return grpc.insecure_channel(self.address, options=options)
        return grpc.secure_channel(self.address, self._credentials, options=options)

    def _stream_stub(self) -> pb_grpc.ShapeSenseStub:
        if self._stream_channel is None:
            self._stream_channel = self._open_channel(_STREAM_OPTIONS)
        return pb_grpc.ShapeSenseStub(self._stream_channel)

    def close(self) -> None:
        """Closes the connection (streams still open end)."""
        self._channel.close()
        if self._stream_channel is not None:
            self._stream_channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def _call(self, method: Callable[..., Any], request: Any) -> Any:
        for attempt in range(self.busy_retries + 1):
            try:
                return method(request, timeout=self.timeout)
            except grpc.RpcError as e:
                if e.code() != grpc.StatusCode.RESOURCE_EXHAUSTED or attempt == self.busy_retries:
                    raise ShapeSenseError.from_rpc_error(e) from None
            time.sleep(0.05 * 2**attempt)
        raise AssertionError("unreachable")

    def _stream(self, start: Callable[[], Any], convert: Callable[[Any], Any]) -> Iterator[Any]:
        """Runs the stream `start` opens once iterated; cancelled when the iteration stops."""
        call = start()
        try:
            for message in call:
                yield convert(message)
        except grpc.RpcError as e:
            if e.code() != grpc.StatusCode.CANCELLED:
                raise ShapeSenseError.from_rpc_error(e) from None
        finally:
            call.cancel()

    def wait_until_serving(self, timeout: float = 10.0) -> "t.Status":
        """Waits until the daemon answers GetStatus with a cached frame; its status."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                status = self.status()
                if status.cache.frames > 0:
                    return status
            except ShapeSenseError:
                if time.monotonic() > deadline:
                    raise
            if time.monotonic() > deadline:
                raise ShapeSenseError("UNAVAILABLE", f"{self.address} cached no frame within "
                                      f"{timeout} s", grpc.StatusCode.UNAVAILABLE)
            time.sleep(0.1)

    # -- status and frames -----------------------------------------------------------------

    def status(self) -> t.Status:
        """Source, its state, counters, cached time range, per-stage latency and the daemon's
        own call latencies by method."""
        m = self._call(self._stub.GetStatus, pb.GetStatusRequest())
        stages = [t.StageLatency(s.stage, s.runs, s.last_ms, s.median_ms, s.p95_ms)
                  for s in m.stages]
        state = pb.GetStatusResponse.SourceState.Name(m.source_state)
        calls = [t.CallLatency(c.method, c.answered, c.refused, c.failed,
                               list(c.bucket_upper_ms), list(c.answered_by_bucket))
                 for c in m.calls]
        return t.Status(m.version, m.source, state, m.source_message, m.frames_received,
                        m.frames_processed, m.frames_skipped, m.source_errors,
                        t.cache_range(m.cache), stages, m.uptime_s, list(m.detectors),
                        m.source_live, m.source_connected, m.source_reconnects,
                        m.source_dropped_frames, m.frames_out_of_order, m.source_disconnects,
                        m.session_id, calls)

    def frames(self, from_ns: int = 0, to_ns: int = 0, limit: int = 0) -> List[t.FrameInfo]:
        """The cached frames captured in [from_ns, to_ns] (0: open end), oldest first; with
        ``limit`` the newest ``limit`` of them."""
        m = self._call(self._stub.ListFrames,
                       pb.ListFramesRequest(from_ns=from_ns, to_ns=to_ns, limit=limit))
        return [t.frame_info(f) for f in m.frames]

    def newest_processed_ns(self) -> int:
        """Capture time of the newest cached frame the detectors have processed (0 if none)."""
        for f in reversed(self.frames()):
            if f.processed:
                return f.timestamp_ns
        return 0

    def _processed(self, at_ns: int) -> int:
        return at_ns if at_ns else self.newest_processed_ns()

    def frame(self, at_ns: int = 0, depth: bool = True, colour: bool = True) -> t.Frame:
        """The frame at ``at_ns`` (the latest cached frame captured at or before it; 0: the
        newest): depth in metres (float32, H x W, 0 = no reading), colour as H x W x 3 RGB."""
        m = self._call(self._stub.GetFrame,
                       pb.GetFrameRequest(at_ns=at_ns, skip_depth=not depth,
                                          skip_rgb=not colour))
        return t.Frame(t.frame_info(m.info), t.intrinsics(m.intrinsics),
                       t.depth_stats(m.depth_stats), t.depth_metres(m.depth_png),
                       t.decode_png(m.rgb_png, colour=True), m.depth_png, m.rgb_png)

    def watch(self, max_pending: int = 1) -> Iterator[t.FrameSummary]:
        """A summary of every new frame once its detectors have run, until the caller stops
        iterating (a slow reader gets the newest ones; ``dropped_before`` counts the rest)."""
        request = pb.WatchRequest(max_pending=max_pending)
        return self._stream(lambda: self._stream_stub().Watch(request), t.frame_summary)

    # -- detector results ------------------------------------------------------------------

    def planes(self, at_ns: int = 0, accumulated: bool = False, polygons: bool = True,
               labels: bool = False) -> "t.ResultList[t.Plane]":
        """The planes of the frame at ``at_ns`` (0: the newest processed frame), or with
        ``accumulated`` the stable planes accumulated up to it (ids are then track ids).

        A list of :class:`Plane` with ``frame_timestamp_ns``; ``extra`` holds ``detector``,
        ``compute_ms`` and, with ``labels``, ``labels`` (uint16 plane ids per pixel).
        """
        view = pb.GetPlanesRequest.ACCUMULATED if accumulated else pb.GetPlanesRequest.FRAME
        m = self._call(self._stub.GetPlanes,
                       pb.GetPlanesRequest(at_ns=self._processed(at_ns), view=view,
                                           skip_labels=not labels, skip_polygons=not polygons))
        extra = {"detector": m.detector, "compute_ms": m.compute_ms}
        if labels:
            extra["labels"] = t.decode_png(m.labels_png)
        return t.ResultList([t.plane(p) for p in m.planes], m.frame_timestamp_ns, **extra)

    def estimate_box(self, p1: t.Pixel, p2: t.Pixel, at_ns: int = 0,
                     mode: BoxModeArg = "frustum_aligned") -> t.Box:
        """The 3D box behind the ROI with opposite corners ``p1`` and ``p2`` ((x, y) pixels,
        inclusive) in the frame at ``at_ns`` (0: the newest).

        ``mode``: "frustum_aligned" (1: the ROI is the box's front face, box turned to the
        view), "axis_aligned_contained" (2: the ROI contains an axis-aligned box) or
        "axis_aligned_front_face" (3: the ROI is an axis-aligned box's front face) or
        "segments" (4: the box of the segments the ROI covers, upright on their support; it
        needs a frame the detectors processed, so pass a processed frame's ``at_ns``).
        INVALID_ARGUMENT for an ROI outside the image, FAILED_PRECONDITION when it holds no
        depth (mode 4: no segment, or no detector results), OUT_OF_RANGE when ``at_ns`` is
        older than the cache.
        """
        request = pb.EstimateBoxRequest(at_ns=at_ns, p1=pb.Pixel(x=int(p1[0]), y=int(p1[1])),
                                        p2=pb.Pixel(x=int(p2[0]), y=int(p2[1])),
                                        mode=box_mode(mode))
        m = self._call(self._stub.EstimateBox, request)
        box = t.box_from_corners(m.corners, m.frame_timestamp_ns)
        box.frame_sequence = m.frame_sequence
        box.mode = pb.BoxMode.Name(m.mode).replace("BOX_MODE_", "").lower()
        box.stats = t.roi_depth_stats(m.stats)
        box.collapsed_x, box.collapsed_y = m.collapsed_x, m.collapsed_y
        return box

    def detected_boxes(self, at_ns: int = 0) -> "t.ResultList[t.DetectedBox]":
        """The boxes the daemon derived from its own detections (segments standing on a plane,
        then bowls) in the frame at ``at_ns`` (0: the newest processed frame)."""
        m = self._call(self._stub.GetDetectedBoxes,
                       pb.GetDetectedBoxesRequest(at_ns=self._processed(at_ns)))
        boxes = [t.DetectedBox(b.source, b.source_id, (b.p1.x, b.p1.y), (b.p2.x, b.p2.y),
                               t.box_from_corners(b.corners, m.frame_timestamp_ns), b.score,
                               b.view) for b in m.boxes]
        return t.ResultList(boxes, m.frame_timestamp_ns)

    def segments(self, at_ns: int = 0, method: str = "", labels: bool = False) -> t.Segments:
        """The depth segmentation of the frame at ``at_ns`` (0: the newest processed frame):
        the daemon's own method, or ``method`` ("depth_step", "normal_edges", "fused",
        "plane_prediction", "tiled_ransac", "planes_objects") computed on request. With
        ``labels`` the region image too."""
        m = self._call(self._stub.GetSegments,
                       pb.GetSegmentsRequest(at_ns=self._processed(at_ns), method=method,
                                             skip_labels=not labels))
        return t.Segments(m.frame_timestamp_ns, m.method, m.computed_on_request,
                          [t.segment(s) for s in m.segments], m.compute_ms,
                          t.decode_png(m.labels_png), m.labels_png)

    def bowls(self, at_ns: int = 0) -> "t.ResultList[t.Bowl]":
        """The bowls of the frame at ``at_ns`` (0: the newest processed frame), highest score
        first. FAILED_PRECONDITION when the daemon runs with --bowls off."""
        m = self._call(self._stub.GetBowls, pb.GetBowlsRequest(at_ns=self._processed(at_ns)))
        stamp = m.info.timestamp_ns
        bowls = [t.Bowl(t.pixel_box(b.box), b.score, b.view,
                        t.box_from_corners(b.corners, stamp) if b.corners else None,
                        b.rim_diameter_m, b.height_m, b.support_plane_id) for b in m.bowls]
        return t.ResultList(bowls, stamp, info=t.frame_info(m.info), compute_ms=m.compute_ms)

    # -- recording -------------------------------------------------------------------------

    # -- taught objects --------------------------------------------------------------------

    def teach_object(self, name: str, p1: t.Pixel, p2: t.Pixel, at_ns: int = 0,
                     replace: bool = False) -> t.TaughtObject:
        """Teaches the object the ROI with opposite corners ``p1`` and ``p2`` ((x, y) pixels,
        inclusive) marks in the frame at ``at_ns`` (0: the newest processed frame) as
        ``name``; the daemon saves it and finds it from then on (:meth:`find_objects`).

        The object is what ``estimate_box(..., mode="segments")`` boxes. ``name``: 1-64
        letters, digits, '-', '_' or '.'. Raises with ALREADY_EXISTS when that name is taught
        (pass ``replace``), RESOURCE_EXHAUSTED when the daemon holds its most models,
        FAILED_PRECONDITION when the ROI holds no object or it cannot be taught (the message
        says why), PERMISSION_DENIED for a token without the ``record`` role.
        """
        request = pb.TeachObjectRequest(at_ns=self._processed(at_ns),
                                        p1=pb.Pixel(x=int(p1[0]), y=int(p1[1])),
                                        p2=pb.Pixel(x=int(p2[0]), y=int(p2[1])), name=name,
                                        replace=replace)
        m = self._call(self._stub.TeachObject, request)
        return t.TaughtObject(t.object_model_info(m.model), m.frame_timestamp_ns,
                              m.frame_sequence, m.replaced)

    def list_object_models(self) -> List[t.ObjectModelInfo]:
        """The taught objects, by name."""
        m = self._call(self._stub.ListObjectModels, pb.ListObjectModelsRequest())
        return [t.object_model_info(model) for model in m.models]

    def find_objects(self, at_ns: int = 0,
                     names: Sequence[str] = ()) -> "t.ResultList[t.ObjectDetection]":
        """The taught objects ``names`` (empty: all) found in the frame at ``at_ns`` (0: the
        newest), highest score first; those not found are left out. NOT_FOUND for a name that
        is not taught. ``extra`` holds ``frame_sequence`` and ``compute_ms``."""
        m = self._call(self._stub.FindObjects,
                       pb.FindObjectsRequest(at_ns=at_ns, names=list(names)))
        return t.ResultList([t.object_detection(d) for d in m.detections], m.frame_timestamp_ns,
                            frame_sequence=m.frame_sequence, compute_ms=m.compute_ms)

    def record(self, dir: str, seconds: float) -> Iterator[t.RecordProgress]:
        """Has the daemon record its source for ``seconds`` into ``dir`` (relative to its
        --record-root; a TUM recording). Yields progress at most every 100 ms, the last with
        ``done``; stopping the iteration early ends the recording (what was written stays
        valid). Needs a token with role ``record`` when the daemon takes tokens."""
        request = pb.RecordRequest(dir=dir, seconds=seconds)

        def progress(m: Any) -> t.RecordProgress:
            return t.RecordProgress(m.frames_written, m.frames_dropped, m.seconds, m.done, m.dir)

        return self._stream(lambda: self._stream_stub().Record(request), progress)

    # -- scene model -----------------------------------------------------------------------

    @staticmethod
    def _preview(preview: Optional[str], width: int, quality: int,
                 rate_hz: float = 0.0) -> pb.PreviewRequest:
        kind = (preview or "none").lower()
        if kind not in _PREVIEW_KINDS:
            raise ValueError(f"preview {preview!r} is not one of None, 'colour', 'depth'")
        return pb.PreviewRequest(kind=_PREVIEW_KINDS[kind], width=width, quality=quality,
                                 rate_hz=rate_hz)

    def scene(self, at_ns: int = 0, preview: Optional[str] = None, preview_width: int = 0,
              preview_quality: int = 0) -> t.SceneUpdate:
        """The scene model (stable planes, tracked objects and bowls) of the frame at ``at_ns``
        (0: the newest processed frame); with ``preview`` "colour" or "depth" a JPEG preview of
        ``preview_width`` pixels (0: 320) at ``preview_quality`` (0: 70)."""
        request = pb.GetSceneRequest(at_ns=at_ns,
                                     preview=self._preview(preview, preview_width,
                                                           preview_quality))
        return _scene_update(self._call(self._stub.GetScene, request))

    def watch_scene(self, max_rate_hz: float = 0.0, preview: Optional[str] = None,
                    preview_width: int = 0, preview_quality: int = 0,
                    preview_rate_hz: float = 0.0,
                    full_every_s: float = 0.0) -> Iterator[t.SceneUpdate]:
        """Scene model updates of the processed frames, at most ``max_rate_hz`` a second (0:
        every frame), until the caller stops iterating. The first is full, later ones carry
        what changed (see :class:`SceneUpdate`; :class:`SceneState` applies them)."""
        request = pb.WatchSceneRequest(
            max_rate_hz=max_rate_hz, full_every_s=full_every_s,
            preview=self._preview(preview, preview_width, preview_quality, preview_rate_hz))
        return self._stream(lambda: self._stream_stub().WatchScene(request), _scene_update)


def _scene_update(m: Any) -> t.SceneUpdate:
    stamp = m.info.timestamp_ns
    planes = [t.ScenePlane(p.id, t.vec3(p.normal), p.d, t.triangles(p.polygon_xyz),
                           t.triangles(p.triangles), p.rgb, t.pixel_box(p.box)) for p in m.planes]
    objects = []
    for o in m.objects:
        box = t.box_from_corners(o.corners, stamp)
        if o.width_m or o.height_m or o.depth_m:
            box.size_m = (o.width_m, o.height_m, o.depth_m)
        objects.append(t.SceneObject(o.id, pb.SceneObject.Kind.Name(o.kind), box,
                                     t.pixel_box(o.box), o.score, o.frames_seen,
                                     o.frames_missed))
    return t.SceneUpdate(m.session_id, t.frame_info(m.info), t.intrinsics(m.intrinsics), m.full,
                         planes, objects, list(m.removed_plane_ids), list(m.removed_object_ids),
                         m.dropped_before, t.timings(m.timings),
                         t.decode_png(m.preview_jpeg, colour=True), m.preview_jpeg,
                         m.preview_width, m.preview_height,
                         [t.object_detection(d) for d in m.taught_objects])


class SceneState:
    """The whole scene as a WatchScene subscriber sees it: apply every update in order.

    ``planes`` and ``objects`` map track ids to the newest :class:`ScenePlane` and
    :class:`SceneObject`; ``taught_objects`` are those of the last update (each carries all);
    ``session_id`` changes (and the state starts over) when the daemon restarted.
    """

    def __init__(self) -> None:
        self.session_id = ""
        self.planes: dict = {}
        self.objects: dict = {}
        self.taught_objects: List[t.ObjectDetection] = []
        self.info: Optional[t.FrameInfo] = None

    def apply(self, update: t.SceneUpdate) -> None:
        """Brings the state to ``update``'s frame."""
        if update.full or update.session_id != self.session_id:
            self.planes, self.objects = {}, {}
        self.session_id = update.session_id
        self.info = update.info
        self.taught_objects = list(update.taught_objects)
        for plane_id in update.removed_plane_ids:
            self.planes.pop(plane_id, None)
        for object_id in update.removed_object_ids:
            self.objects.pop(object_id, None)
        self.planes.update((p.id, p) for p in update.planes)
        self.objects.update((o.id, o) for o in update.objects)
