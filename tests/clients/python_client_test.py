"""The Python client (clients/python) against a daemon on the synthetic scene.

Run by ctest (label `clients`) with Debian's python3 and PYTHONPATH at the built package
(build/clients/python); SHAPESENSE_BINARY_DIR and SHAPESENSE_SOURCE_DIR name the build and
source trees. By hand:
    PYTHONPATH=build/clients/python SHAPESENSE_BINARY_DIR=build SHAPESENSE_SOURCE_DIR=. \
        /usr/bin/python3 tests/clients/python_client_test.py -v
"""

import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
import unittest

import shapesense

BINARY_DIR = os.environ.get("SHAPESENSE_BINARY_DIR", "build")
SOURCE_DIR = os.environ.get("SHAPESENSE_SOURCE_DIR", ".")
EXAMPLES = os.path.join(SOURCE_DIR, "clients", "python", "examples")
ROI = ((280, 200), (360, 280))  # the middle of the 640x480 image: the table and what stands on it


def rotate_by_inverse(q, v):
    """v turned by the inverse of the unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q[0], -q[1], -q[2], -q[3]
    # v' = v + 2 u x (u x v + w v), u = (x, y, z)
    u = (x, y, z)

    def cross(a, b):
        return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

    inner = [c + w * vi for c, vi in zip(cross(u, v), v)]
    outer = cross(u, inner)
    return [vi + 2.0 * o for vi, o in zip(v, outer)]


class Daemon:
    """build/server/shapesensed --source synthetic on a port the system picks (--listen
    127.0.0.1:0), read back from its "serving ... (port N" log line; SIGTERM at the end."""

    def __init__(self, scratch: str, *options: str):
        self.log_path = os.path.join(scratch, "shapesensed.log")
        self.log = open(self.log_path, "w")
        self.process = subprocess.Popen(
            [os.path.join(BINARY_DIR, "server", "shapesensed"), "--source", "synthetic",
             "--listen", "127.0.0.1:0", "--record-root", os.path.join(scratch, "recordings"),
             "--object-models", os.path.join(scratch, "object-models"), *options], stdout=self.log, stderr=subprocess.STDOUT)
        self.port = self._wait_for_port(20.0)
        self.address = f"127.0.0.1:{self.port}"

    def _wait_for_port(self, seconds: float) -> int:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            with open(self.log_path) as f:
                found = re.search(r"\(port (\d+)", f.read())
            if found:
                return int(found.group(1))
            if self.process.poll() is not None:
                break
            time.sleep(0.05)
        self.stop()
        with open(self.log_path) as f:
            raise RuntimeError("shapesensed did not start serving:\n" + f.read())

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()
        return self.process.returncode


class PythonClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory(prefix="shapesense-python-")
        # A query waits as long as it takes for a worker: the suite runs beside other tests
        # on busy machines, and these tests are about the client, not the load limits.
        # Ten seconds of frames, so a frame a test names stays cached while it makes several
        # calls, even when the machine is slow.
        cls.daemon = Daemon(cls.scratch.name, "--query-max-wait-ms", "5000",
                            "--taught-objects", "on", "--cache-frames", "300")
        cls.client = shapesense.Client(cls.daemon.address, timeout=10.0)
        cls.client.wait_until_serving(10.0)
        # Detector queries want a processed frame.
        deadline = time.monotonic() + 10
        while not cls.client.newest_processed_ns() and time.monotonic() < deadline:
            time.sleep(0.05)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        code = cls.daemon.stop()
        cls.scratch.cleanup()
        assert code == 0, f"shapesensed exited with {code}"

    def run_example(self, name, *arguments):
        env = dict(os.environ)
        return subprocess.run([sys.executable, os.path.join(EXAMPLES, name), "--server",
                               self.daemon.address, *arguments], env=env, capture_output=True,
                              text=True, timeout=30)

    def test_status(self):
        status = self.client.status()
        self.assertIn("synthetic", status.source)
        self.assertEqual(status.source_state, "STREAMING")
        self.assertTrue(status.version)
        self.assertTrue(status.session_id)
        self.assertGreater(status.frames_received, 0)
        self.assertGreater(status.cache.frames, 0)
        self.assertLessEqual(status.cache.frames, status.cache.capacity)
        self.assertLessEqual(status.cache.oldest_ns, status.cache.newest_ns)
        self.assertFalse(status.source_live)
        self.assertTrue(status.source_connected)
        self.assertIn("planes", " ".join(status.detectors))
        self.assertTrue(all(s.stage and s.runs >= 0 for s in status.stages))
        # The first status call is counted once answered: the second one reports it.
        calls = {c.method: c for c in self.client.status().calls}
        self.assertIn("GetStatus", calls)
        self.assertGreaterEqual(calls["GetStatus"].answered, 1)
        self.assertEqual(len(calls["GetStatus"].answered_by_bucket),
                         len(calls["GetStatus"].bucket_upper_ms) + 1)
        self.assertEqual(sum(calls["GetStatus"].answered_by_bucket), calls["GetStatus"].answered)

    def test_frames_are_in_order(self):
        frames = self.client.frames()
        self.assertGreater(len(frames), 0)
        stamps = [f.timestamp_ns for f in frames]
        self.assertEqual(stamps, sorted(stamps))
        self.assertEqual(len(self.client.frames(limit=2)), 2)
        self.assertTrue(all((f.width, f.height) == (640, 480) for f in frames))

    @unittest.skipUnless(shapesense.images_available(), "numpy and cv2 decode the images")
    def test_frame_depth_in_metres_and_colour(self):
        stamp = self.client.newest_processed_ns()  # its depth statistic is computed
        frame = self.client.frame(at_ns=stamp)
        self.assertEqual(frame.info.timestamp_ns, stamp)
        self.assertEqual(frame.depth.shape, (480, 640))
        self.assertEqual(str(frame.depth.dtype), "float32")
        valid = frame.depth[frame.depth > 0]
        self.assertGreater(valid.size, 0.5 * frame.depth.size)
        self.assertGreater(float(valid.min()), 0.3)  # a Kinect reads from ~0.4 m
        self.assertLess(float(valid.max()), 10.0)
        self.assertAlmostEqual(float(sorted(valid.tolist())[valid.size // 2]),
                               frame.depth_stats.median_m, delta=0.01)
        self.assertEqual(frame.colour.shape, (480, 640, 3))
        self.assertEqual((frame.intrinsics.width, frame.intrinsics.height), (640, 480))

    def test_frame_without_opencv_gives_the_pngs(self):
        script = ("import sys; sys.modules['cv2'] = None\n"  # import cv2 raises ImportError
                  "import shapesense\n"
                  f"frame = shapesense.Client('{self.daemon.address}').frame()\n"
                  "assert not shapesense.images_available()\n"
                  "assert frame.depth is None and frame.colour is None\n"
                  "assert frame.depth_png[:8] == b'\\x89PNG\\r\\n\\x1a\\n'\n"
                  "assert frame.rgb_png[:8] == b'\\x89PNG\\r\\n\\x1a\\n'\n")
        result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                                timeout=30)
        self.assertEqual(result.returncode, 0, result.stderr)

    def test_estimate_box_matches_the_cli(self):
        stamp = self.client.frames()[-1].timestamp_ns
        for mode, number in (("frustum_aligned", 1), ("axis_aligned_contained", 2)):
            box = self.client.estimate_box(ROI[0], ROI[1], at_ns=stamp, mode=mode)
            self.assertEqual(box.frame_timestamp_ns, stamp)
            self.assertEqual(len(box.corners), 8)
            cli = subprocess.run(
                [os.path.join(BINARY_DIR, "clients", "shapesense"), "--server",
                 self.daemon.address, "bbox", "--at", shapesense.format_ns(stamp), "--roi",
                 "%d,%d,%d,%d" % (*ROI[0], *ROI[1]), "--mode", str(number), "--json"],
                capture_output=True, text=True, timeout=20)
            self.assertEqual(cli.returncode, 0, cli.stderr)
            expected = json.loads(cli.stdout)
            self.assertEqual(int(expected["frame_timestamp_ns"]), stamp)
            for got, want in zip(box.corners, expected["corners"]):
                for g, w in zip(got, (want["x"], want["y"], want["z"])):
                    self.assertAlmostEqual(g, w, delta=1e-9)
            self.assertTrue(all(0 < s < 2 for s in box.size_m), box.size_m)

    def test_teach_list_and_find_an_object(self):
        # An object the detectors boxed; not every one has the shape to be taught.
        stamp = self.client.newest_processed_ns()
        boxes = [b for b in self.client.detected_boxes(at_ns=stamp) if b.source == "segment"]
        self.assertGreater(len(boxes), 0)
        taught = None
        for box in boxes:
            try:
                taught = self.client.teach_object("py-object", box.p1, box.p2, at_ns=stamp)
                break
            except shapesense.ShapeSenseError as e:
                self.assertEqual(e.code, "FAILED_PRECONDITION", e.message)
        self.assertIsNotNone(taught, "no segment box of the frame could be taught")
        self.assertEqual(taught.model.name, "py-object")
        self.assertEqual(taught.frame_timestamp_ns, stamp)
        self.assertGreater(taught.model.feature_count, 0)
        self.assertTrue(all(s > 0 for s in taught.model.box_size_m))
        self.assertTrue(os.path.isfile(
            os.path.join(self.scratch.name, "object-models", "py-object.json")))
        self.assertIn("py-object", [m.name for m in self.client.list_object_models()])
        found = self.client.find_objects(at_ns=stamp, names=["py-object"])
        self.assertEqual(found.frame_timestamp_ns, stamp)
        self.assertEqual([d.name for d in found], ["py-object"])
        detection = found[0]
        self.assertGreaterEqual(detection.score, 0.85)
        # Found in the frame it was taught from, where it was: the pose carries the model's
        # box centre (in model coordinates, which are the taught frame's camera coordinates)
        # less than 2 cm, the bound TeachObject itself holds every model it accepts to. A round
        # object may come back turned about its own axis, so the pose itself need not be the
        # identity. The bound is the client's check, not the recognizer's accuracy
        # (RecognitionQuality asserts that on the test split).
        found_centre = detection.box.centre
        taught_centre = rotate_by_inverse(detection.rotation,
                                          [f - t for f, t in zip(found_centre,
                                                                 detection.translation)])
        self.assertLess(math.dist(found_centre, taught_centre), 0.02)
        self.assertEqual(len(detection.box.corners), 8)
        self.assertGreater(detection.image_box.width, 0)
        # The taught-object stage (--taught-objects on) looks for it from the next frame on, and
        # the scene model carries it.
        deadline = time.monotonic() + 15
        followed = []
        while not followed and time.monotonic() < deadline:
            scene = self.client.scene()
            followed = [d for d in scene.taught_objects if d.name == "py-object"]
            time.sleep(0.05)
        self.assertEqual(len(followed), 1, "the stage never reported the taught object")
        state = shapesense.SceneState()
        state.apply(scene)
        self.assertEqual([d.name for d in state.taught_objects],
                         [d.name for d in scene.taught_objects])
        self.assertGreaterEqual(followed[0].score, 0.95)
        self.assertEqual(len(followed[0].box.corners), 8)
        with self.assertRaises(shapesense.ShapeSenseError) as caught:
            self.client.teach_object("py-object", boxes[0].p1, boxes[0].p2, at_ns=stamp)
        self.assertEqual(caught.exception.code, "ALREADY_EXISTS")
        with self.assertRaises(shapesense.ShapeSenseError) as caught:
            self.client.find_objects(names=["no-such-object"])
        self.assertEqual(caught.exception.code, "NOT_FOUND")
        self.assertIn("no-such-object", caught.exception.message)

    def test_roi_outside_the_image_is_invalid_argument(self):
        with self.assertRaises(shapesense.ShapeSenseError) as caught:
            self.client.estimate_box((600, 400), (700, 500))
        self.assertEqual(caught.exception.code, "INVALID_ARGUMENT")
        self.assertTrue(caught.exception.message)
        self.assertTrue(str(caught.exception).startswith("INVALID_ARGUMENT: "))

    def test_time_before_the_cache_is_out_of_range(self):
        with self.assertRaises(shapesense.ShapeSenseError) as caught:
            self.client.frame(at_ns=1)
        self.assertEqual(caught.exception.code, "OUT_OF_RANGE")

    def test_unknown_box_mode_is_refused_before_the_call(self):
        with self.assertRaises(ValueError):
            self.client.estimate_box(ROI[0], ROI[1], mode="sideways")

    def test_planes_are_unit_and_positive_distance(self):
        planes = self.client.planes()
        self.assertGreater(planes.frame_timestamp_ns, 0)
        self.assertGreater(len(planes), 0)
        for plane in planes:
            self.assertAlmostEqual(math.sqrt(sum(c * c for c in plane.normal)), 1.0, delta=1e-6)
            self.assertGreater(plane.d, 0)
            # Empty for a degenerate region (core/planes/plane_polygon.h).
            self.assertNotIn(len(plane.polygon), (1, 2))
            self.assertTrue(all(max(t) < len(plane.polygon) for t in plane.triangles))
        self.assertTrue(any(plane.polygon for plane in planes))
        accumulated = self.client.planes(accumulated=True, polygons=False)
        self.assertTrue(all(not p.polygon for p in accumulated))

    def test_segments_detected_boxes_and_bowls(self):
        stamp = self.client.newest_processed_ns()
        segments = self.client.segments(at_ns=stamp, labels=True)
        self.assertEqual(segments.frame_timestamp_ns, stamp)
        self.assertGreater(len(segments.segments), 0)
        if shapesense.images_available():
            self.assertEqual(segments.labels.shape, (480, 640))
            self.assertEqual(int(segments.labels.max()), max(s.id for s in segments.segments))
        boxes = self.client.detected_boxes(at_ns=stamp)
        self.assertEqual(boxes.frame_timestamp_ns, stamp)
        self.assertTrue(all(len(b.box.corners) == 8 for b in boxes))
        bowls = self.client.bowls(at_ns=stamp)
        self.assertEqual(bowls.frame_timestamp_ns, stamp)
        self.assertTrue(all(b.view in ("top", "middle", "side") for b in bowls))

    def test_watch_yields_new_processed_frames(self):
        stream = self.client.watch()
        summaries = [next(stream) for _ in range(3)]
        stream.close()
        stamps = [s.info.timestamp_ns for s in summaries]
        self.assertEqual(stamps, sorted(set(stamps)))
        self.assertTrue(all(s.info.processed for s in summaries))

    def test_record_writes_a_recording_under_the_root(self):
        # Long enough for a frame from the synthetic source under a sanitizer on a busy machine.
        progress = list(self.client.record("python/take-1", 2.0))
        self.assertTrue(progress[-1].done)
        self.assertGreater(progress[-1].frames_written, 0)
        root = os.path.join(self.scratch.name, "recordings")
        self.assertEqual(os.path.realpath(progress[-1].dir),
                         os.path.realpath(os.path.join(root, "python", "take-1")))
        self.assertTrue(os.path.isfile(os.path.join(progress[-1].dir, "depth.txt")))
        with self.assertRaises(shapesense.ShapeSenseError) as caught:
            list(self.client.record("/absolute", 0.4))
        self.assertEqual(caught.exception.code, "INVALID_ARGUMENT")

    def test_scene_and_its_stream(self):
        scene = self.client.scene(preview="colour")
        self.assertTrue(scene.full)
        self.assertTrue(scene.session_id)
        self.assertEqual(scene.session_id, self.client.status().session_id)
        self.assertGreater(len(scene.planes), 0)
        for plane in scene.planes:
            self.assertAlmostEqual(math.hypot(*plane.normal), 1.0, delta=1e-6)
            self.assertTrue(all(max(t) < len(plane.polygon) for t in plane.triangles))
        for thing in scene.objects:
            self.assertIn(thing.kind, ("OBJECT", "BOWL"))
            self.assertEqual(len(thing.box.corners), 8)
        self.assertTrue(scene.preview_jpeg)
        self.assertEqual((scene.preview_width, scene.preview_height), (320, 240))
        if shapesense.images_available():
            self.assertEqual(scene.preview.shape, (240, 320, 3))
        stream = self.client.watch_scene(max_rate_hz=10)
        state = shapesense.SceneState()
        first = next(stream)
        self.assertTrue(first.full)
        state.apply(first)
        later = next(stream)
        self.assertGreater(later.info.timestamp_ns, first.info.timestamp_ns)
        state.apply(later)
        stream.close()
        self.assertEqual(state.session_id, scene.session_id)
        self.assertEqual(state.info, later.info)
        self.assertGreater(len(state.planes), 0)

    def test_save_planes_example(self):
        out = os.path.join(self.scratch.name, "planes.json")
        result = self.run_example("save_planes.py", "--out", out)
        self.assertEqual(result.returncode, 0, result.stderr)
        with open(out) as f:
            document = json.load(f)
        self.assertGreater(document["frame_timestamp_ns"], 0)
        self.assertGreater(len(document["planes"]), 0)
        for plane in document["planes"]:
            self.assertEqual(set(plane), {"id", "normal", "d", "polygon"})
            self.assertAlmostEqual(math.hypot(*plane["normal"]), 1.0, delta=1e-6)
            self.assertTrue(all(len(v) == 3 for v in plane["polygon"]))

    def test_box_at_example(self):
        stamp = self.client.frames()[-1].timestamp_ns
        result = self.run_example("box_at.py", "--at", shapesense.format_ns(stamp), "--roi",
                                  "%d,%d,%d,%d" % (*ROI[0], *ROI[1]), "--mode",
                                  "axis_aligned_front_face")
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertIn(shapesense.format_ns(stamp), result.stdout)
        size = re.search(r"size ([\d.]+) x ([\d.]+) x ([\d.]+) cm", result.stdout)
        self.assertIsNotNone(size, result.stdout)
        box = self.client.estimate_box(ROI[0], ROI[1], at_ns=stamp, mode=3)
        self.assertAlmostEqual(float(size.group(1)), 100 * box.size_m[0], delta=0.051)
        bad = self.run_example("box_at.py", "--roi", "600,400,700,500")
        self.assertEqual(bad.returncode, 1)
        self.assertIn("INVALID_ARGUMENT", bad.stderr)


def openssl(directory: str, *arguments: str) -> None:
    subprocess.run(["openssl", *arguments], cwd=directory, check=True, capture_output=True)


class SecureClientTest(unittest.TestCase):
    """TLS and a bearer token, as the CLI's --tls-ca and --token-file: a daemon with
    --tls-cert, --tls-key and --token-file (its PKI made here with openssl, as
    tests/support/test_pki.cpp does)."""

    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory(prefix="shapesense-python-tls-")
        d = cls.scratch.name
        openssl(d, "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256",
                "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2", "-subj",
                "/CN=shapesense-python-ca")
        with open(os.path.join(d, "server.ext"), "w") as f:
            f.write("subjectAltName=DNS:localhost,IP:127.0.0.1\nextendedKeyUsage=serverAuth\n")
        openssl(d, "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes",
                "-keyout", "server.key", "-out", "server.csr", "-subj", "/CN=localhost")
        openssl(d, "x509", "-req", "-in", "server.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
                "-CAcreateserial", "-days", "2", "-extfile", "server.ext", "-out", "server.pem")
        tokens = os.path.join(d, "tokens")
        with open(tokens, "w") as f:
            f.write("# NAME ROLE TOKEN\nrobot read read-token-0123456789abcdef\n")
        os.chmod(tokens, 0o600)
        cls.token_file = os.path.join(d, "robot.token")
        with open(cls.token_file, "w") as f:
            f.write("read-token-0123456789abcdef  # robot\n")
        cls.wrong_token_file = os.path.join(d, "wrong.token")
        with open(cls.wrong_token_file, "w") as f:
            f.write("\nnot-the-token-0123456789abcdef\n")
        cls.ca = os.path.join(d, "ca.pem")
        cls.daemon = Daemon(d, "--bowls", "off", "--tls-cert", os.path.join(d, "server.pem"),
                            "--tls-key", os.path.join(d, "server.key"), "--token-file", tokens)

    @classmethod
    def tearDownClass(cls):
        code = cls.daemon.stop()
        cls.scratch.cleanup()
        assert code == 0, f"shapesensed exited with {code}"

    def test_token_over_tls_is_accepted(self):
        with shapesense.Client(self.daemon.address, tls_ca=self.ca,
                               token_file=self.token_file) as client:
            self.assertIn("synthetic", client.wait_until_serving(10.0).source)

    def test_missing_or_wrong_token_is_unauthenticated(self):
        for token_file in (None, self.wrong_token_file):
            with shapesense.Client(self.daemon.address, tls_ca=self.ca,
                                   token_file=token_file) as client:
                with self.assertRaises(shapesense.ShapeSenseError) as caught:
                    client.status()
                self.assertEqual(caught.exception.code, "UNAUTHENTICATED")

    def test_a_token_is_never_sent_in_clear_text(self):
        with self.assertRaises(ValueError) as caught:
            shapesense.Client(self.daemon.address, token_file=self.token_file)
        self.assertIn("tls_ca", str(caught.exception))


if __name__ == "__main__":
    unittest.main()
