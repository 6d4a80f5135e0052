#!/usr/bin/python3
"""The operator's console in a real browser (headless Debian chromium, driven by selenium).

Starts shapesensed on the synthetic scene and `shapesense console` in front of it, opens the page
and checks what an operator relies on: frames appear, the 3D view holds the planes GetScene
returns, a rectangle dragged over an object gives the box EstimateBox gives for that frame,
ROI and mode (asked of the daemon through `shapesense bbox`, not through the console), and the
browser logged no error. Leaves a screenshot in <build>/console-screenshot.png.

Usage: console_browser_test.py BUILD_DIR. Exits 77 (ctest SKIP_RETURN_CODE) only when chromium or
chromedriver is not installed.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

SKIP = 77
CHROMEDRIVER = "/usr/bin/chromedriver"


def find_chromium():
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


class Process:
    """A child whose output is read on a thread, so a line can be waited for."""

    def __init__(self, argv, name):
        self.name = name
        self.lines = []
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True)
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, pattern, timeout_s):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for line in list(self.lines):
                match = re.search(pattern, line)
                if match:
                    return match
            if self.proc.poll() is not None:
                break
            time.sleep(0.05)
        raise AssertionError(f"{self.name} never printed /{pattern}/; its output:\n" +
                             "\n".join(self.lines))

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def http_json(url, body=None):
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(url, data=data,
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=10) as answer:
        return json.load(answer)


def wait_until(what, condition, timeout_s, context=lambda: ""):
    deadline = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < deadline:
        last = condition()
        if last:
            return last
        time.sleep(0.1)
    raise AssertionError(f"{what} within {timeout_s} s (last: {last!r}) {context()}")


def run_cli_retrying_when_busy(argv):
    """The CLI's output; RESOURCE_EXHAUSTED (the daemon asks for a retry after a pause) is
    retried a few times, any other failure fails the test."""
    for _ in range(5):
        done = subprocess.run(argv, capture_output=True, text=True)
        if done.returncode == 0:
            return done.stdout
        if "RESOURCE_EXHAUSTED" not in done.stderr:
            break
        time.sleep(0.2)
    raise AssertionError(f"{' '.join(argv)} failed: {done.stderr}")


def ns_to_seconds_text(ns):
    ns = int(ns)
    return f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}"


def run(build_dir, chromium):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select

    scratch = tempfile.mkdtemp(prefix="console-browser-")
    cli = os.path.join(build_dir, "clients", "shapesense")
    daemon = Process([os.path.join(build_dir, "server", "shapesensed"), "--source", "synthetic",
                      "--listen", "127.0.0.1:0", "--record-root", os.path.join(scratch, "rec"),
                      "--object-models", os.path.join(scratch, "object-models"),
                      # This machine also runs chromium: let a query wait for the daemon's
                      # worker rather than be refused (the load limits have tests of their own).
                      "--query-max-wait-ms", "500", "--taught-objects", "on",
                      # Ten seconds of frames: a frame the test names stays cached while it
                      # makes several calls about it.
                      "--cache-frames", "300"],
                     "shapesensed")
    console = driver = None
    try:
        daemon_port = daemon.wait_for(r"\(port (\d+)", 20).group(1)
        server = f"127.0.0.1:{daemon_port}"
        console = Process([cli, "--server", server, "console", "--listen", "127.0.0.1:0"],
                          "shapesense console")
        url = console.wait_for(r"at (http://\S+)", 10).group(1)

        options = webdriver.ChromeOptions()
        options.binary_location = chromium
        for argument in ("--headless=new", "--no-sandbox", "--disable-gpu",
                         "--enable-unsafe-swiftshader", "--window-size=1500,980",
                         f"--user-data-dir={os.path.join(scratch, 'profile')}"):
            options.add_argument(argument)
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
        driver.get(url)
        hook = "return window.shapesenseConsole && window.shapesenseConsole."

        link_state = lambda: "; the page's link: " + driver.find_element(By.ID, "link-state").text
        wait_until("the page shows frames",
                   lambda: driver.execute_script(hook + "frameCount()") or 0, 20, link_state)

        # The 3D view is kept from the stream's deltas; GetScene answers the newest frame whole.
        def planes_match():
            shown = driver.execute_script(hook + "planeCount3d()")
            scene = http_json(url + "api/scene?preview=none")
            return (shown, len(scene["planes"])) if shown == len(scene["planes"]) else None
        shown, expected = wait_until("the 3D view holds GetScene's planes", planes_match, 10)
        assert expected > 0, "the synthetic scene has a table and a floor, GetScene found no plane"

        # An object of the scene to draw a rectangle round, in full-resolution pixels.
        scene = http_json(url + "api/scene?preview=none")
        width, height = scene["intrinsics"]["width"], scene["intrinsics"]["height"]

        def drawable(o):  # seen now, well inside the image, not the table
            b = o["box"]
            return (o["kind"] == "OBJECT" and o["frames_missed"] == 0 and b["x"] > 4 and
                    b["y"] > 4 and b["x"] + b["width"] < width - 4 and
                    b["y"] + b["height"] < height - 4 and b["width"] * b["height"] < width * height / 8
                    and b["width"] > 12 and b["height"] > 12)
        objects = [o for o in scene["objects"] if drawable(o)]
        assert objects, f"GetScene holds no object to draw round: {scene['objects']}"
        box = max(objects, key=lambda o: o["box"]["width"] * o["box"]["height"])["box"]
        x1, y1 = box["x"] + 2, box["y"] + 2
        x2, y2 = box["x"] + box["width"] - 3, box["y"] + box["height"] - 3

        Select(driver.find_element(By.ID, "box-mode")).select_by_value(
            "BOX_MODE_AXIS_ALIGNED_CONTAINED")
        canvas = driver.find_element(By.ID, "view2d")
        geometry = driver.execute_script(
            "const c = arguments[0], r = c.getBoundingClientRect();"
            "return [r.width, r.height, c.width, c.height];", canvas)
        css_w, css_h, image_w, image_h = geometry
        to_css = lambda x, y: (x * css_w / image_w - css_w / 2, y * css_h / image_h - css_h / 2)
        start, end = to_css(x1 + 0.5, y1 + 0.5), to_css(x2 + 0.5, y2 + 0.5)
        (ActionChains(driver)
         .move_to_element_with_offset(canvas, round(start[0]), round(start[1]))
         .click_and_hold()
         .move_by_offset(round((end[0] - start[0]) / 2), round((end[1] - start[1]) / 2))
         .move_to_element_with_offset(canvas, round(end[0]), round(end[1]))
         .release()
         .perform())
        drawn = wait_until("the page shows a box", lambda: driver.execute_script(
            hook + "lastBox()"), 10)
        assert "response" in drawn, f"the page's box failed: {drawn}"
        request, response = drawn["request"], drawn["response"]
        assert request["at_ns"] == driver.execute_script(hook + "shownTimestampNs()")
        assert response["frame_timestamp_ns"] == request["at_ns"], drawn
        scale = image_w / css_w
        for got, want in ((request["p1"]["x"], x1), (request["p1"]["y"], y1),
                          (request["p2"]["x"], x2), (request["p2"]["y"], y2)):
            assert abs(got - want) <= 1 + scale, f"ROI {request} is not the rectangle dragged " \
                                                 f"({x1},{y1})-({x2},{y2})"

        direct = json.loads(run_cli_retrying_when_busy(
            [cli, "--server", server, "bbox", "--at", ns_to_seconds_text(request["at_ns"]),
             "--roi", f"{request['p1']['x']},{request['p1']['y']},"
                      f"{request['p2']['x']},{request['p2']['y']}",
             "--mode", "2", "--json"]))
        assert direct["frame_timestamp_ns"] == response["frame_timestamp_ns"], (direct, response)
        for got, want in zip(response["corners"], direct["corners"], strict=True):
            for axis in "xyz":
                assert abs(got[axis] - want[axis]) <= 0.001, \
                    f"corner {got} differs from EstimateBox's {want} by more than 1 mm"

        # Teach an object of the scene: the taught-object stage follows it from then on, and
        # both views draw it from the stream.
        taught = None
        fresh = http_json(url + "api/scene?preview=none")
        candidates = [o for o in fresh["objects"] if drawable(o)]
        for o in sorted(candidates, key=lambda o: -o["box"]["width"] * o["box"]["height"]):
            b = o["box"]
            done = subprocess.run(
                [cli, "--server", server, "teach", "--at", ns_to_seconds_text(fresh["info"]["timestamp_ns"]),
                 "--roi", f"{b['x']},{b['y']},{b['x'] + b['width'] - 1},{b['y'] + b['height'] - 1}",
                 "--name", "console-object"], capture_output=True, text=True, timeout=30)
            if done.returncode == 0:
                taught = o
                break
        assert taught, f"no object of the scene could be taught: {done.stderr}"

        driver.find_element(By.ID, "btn-live").click()  # drawing the box paused the page
        seen = {}

        def taught_drawn():
            seen["drawn"] = driver.execute_script(hook + "taughtCount3d()")
            seen["served"] = [d["name"] for d in http_json(url + "api/scene?preview=none").get(
                "taught_objects", [])]
            seen["label"] = driver.find_element(By.ID, "scene-label").text
            return seen["drawn"] if (seen["drawn"] >= 1 and "console-object" in seen["served"]
                                     and "console-object" in seen["label"]) else None
        wait_until("the 3D view draws the taught object and the label names it", taught_drawn, 15,
                   lambda: str(seen))

        time.sleep(0.5)  # let the box settle in both views before the picture
        screenshot = os.path.join(build_dir, "console-screenshot.png")
        driver.save_screenshot(screenshot)

        errors = [entry for entry in driver.get_log("browser") if entry["level"] == "SEVERE"]
        assert not errors, f"the browser logged errors: {errors}"
        print(f"ok: {expected} planes in both views, box at {ns_to_seconds_text(request['at_ns'])} "
              f"s matches EstimateBox, the taught object drawn; screenshot {screenshot}")
    finally:
        if driver:
            driver.quit()
        if console:
            console.stop()
        daemon.stop()
        shutil.rmtree(scratch, ignore_errors=True)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    chromium = find_chromium()
    if not chromium or not os.access(CHROMEDRIVER, os.X_OK):
        print("SKIP: chromium and chromium-driver are needed (scripts/deps installs them)")
        return SKIP
    run(os.path.abspath(sys.argv[1]), chromium)
    return 0


if __name__ == "__main__":
    sys.exit(main())
