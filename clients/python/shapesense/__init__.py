"""Python client of shapesensed, the RGB-D perception daemon.

    import shapesense
    with shapesense.Client("127.0.0.1:50551") as client:
        print(client.status().source)
        for plane in client.planes():
            print(plane.id, plane.normal, plane.d)
        box = client.estimate_box((280, 200), (360, 280))
        print([round(s * 100, 1) for s in box.size_m], "cm")

The API's generated modules are ``shapesense.v1.shapesense_pb2`` and ``..._pb2_grpc`` (built
from proto/shapesense/v1/shapesense.proto); the reference for every field is that file.
"""

from .client import DEFAULT_ADDRESS, Client, SceneState, box_mode, read_token
from .errors import ShapeSenseError
from .times import format_ns, parse_time
from .types import (Bowl, Box, CacheRange, CallLatency, DepthStats, DetectedBox, Frame, FrameInfo,
                    FrameSummary, Intrinsics, ObjectDetection, ObjectModelInfo, OrientedBox,
                    PixelBox, Plane, RecordProgress, ResultList, RoiDepthStats, SceneObject,
                    ScenePlane, SceneUpdate, Segment, Segments, StageLatency, StageTiming,
                    Status, TaughtObject, images_available)

__all__ = [
    "DEFAULT_ADDRESS", "Client", "SceneState", "ShapeSenseError", "box_mode", "read_token",
    "format_ns", "parse_time", "Bowl", "Box", "CacheRange", "CallLatency", "DepthStats", "DetectedBox", "Frame",
    "FrameInfo", "FrameSummary", "Intrinsics", "ObjectDetection", "ObjectModelInfo",
    "OrientedBox", "PixelBox", "Plane", "RecordProgress", "ResultList", "RoiDepthStats",
    "SceneObject", "ScenePlane", "SceneUpdate", "Segment", "Segments", "StageLatency",
    "StageTiming", "Status", "TaughtObject", "images_available",
]
