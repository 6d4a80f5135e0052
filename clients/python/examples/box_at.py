#!/usr/bin/python3
"""Prints the 3D box behind a rectangle (ROI) of the frame at time T, with its size in cm.

    PYTHONPATH=build/clients/python clients/python/examples/box_at.py --roi 280,200,360,280 \
        --at 1600000000.1 --mode axis_aligned_contained
"""

import argparse
import sys

import shapesense

CORNERS = ["front top-left", "front top-right", "front bottom-right", "front bottom-left",
           "back top-left", "back top-right", "back bottom-right", "back bottom-left"]


def roi(text: str):
    values = text.split(",")
    if len(values) != 4 or not all(v.strip().lstrip("-").isdigit() for v in values):
        raise argparse.ArgumentTypeError(f"'{text}' is not x1,y1,x2,y2 (four whole pixel numbers)")
    x1, y1, x2, y2 = (int(v) for v in values)
    return (x1, y1), (x2, y2)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("--server", default=shapesense.DEFAULT_ADDRESS, help="daemon address")
    parser.add_argument("--tls-ca", help="connect with TLS, trusting this PEM CA bundle")
    parser.add_argument("--token-file", help="bearer token file (needs --tls-ca)")
    parser.add_argument("--at", default="latest",
                        help="T in seconds, e.g. 1600000000.05 (default: the newest frame)")
    parser.add_argument("--roi", type=roi, required=True,
                        help="two opposite corners x1,y1,x2,y2 in pixels (inclusive)")
    parser.add_argument("--mode", default="frustum_aligned",
                        choices=["frustum_aligned", "axis_aligned_contained",
                                 "axis_aligned_front_face"], help="how the ROI is read")
    args = parser.parse_args()

    p1, p2 = args.roi
    try:
        with shapesense.Client(args.server, tls_ca=args.tls_ca,
                               token_file=args.token_file) as client:
            box = client.estimate_box(p1, p2, at_ns=shapesense.parse_time(args.at),
                                      mode=args.mode)
    except (shapesense.ShapeSenseError, ValueError) as e:
        print(f"box_at: {e}", file=sys.stderr)
        return 1
    width, height, depth = (100 * s for s in box.size_m)
    print(f"frame {shapesense.format_ns(box.frame_timestamp_ns)}, mode {box.mode}")
    print(f"size {width:.1f} x {height:.1f} x {depth:.1f} cm (width x height x depth)")
    for name, (x, y, z) in zip(CORNERS, box.corners):
        print(f"  {name:19} {x:8.3f} {y:8.3f} {z:8.3f} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
