#!/usr/bin/python3
"""Saves the planes of the newest processed frame to a JSON file: id, normal, d, polygon.

    PYTHONPATH=build/clients/python clients/python/examples/save_planes.py --out planes.json
"""

import argparse
import json
import sys

import shapesense


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("--server", default=shapesense.DEFAULT_ADDRESS, help="daemon address")
    parser.add_argument("--tls-ca", help="connect with TLS, trusting this PEM CA bundle")
    parser.add_argument("--token-file", help="bearer token file (needs --tls-ca)")
    parser.add_argument("--at", default="latest",
                        help="frame time in seconds, e.g. 1600000000.05 (default: the newest "
                             "processed frame)")
    parser.add_argument("--accumulated", action="store_true",
                        help="the stable planes accumulated up to that frame")
    parser.add_argument("--out", default="planes.json", help="JSON file to write")
    args = parser.parse_args()

    try:
        with shapesense.Client(args.server, tls_ca=args.tls_ca,
                               token_file=args.token_file) as client:
            planes = client.planes(at_ns=shapesense.parse_time(args.at),
                                   accumulated=args.accumulated)
    except (shapesense.ShapeSenseError, ValueError) as e:
        print(f"save_planes: {e}", file=sys.stderr)
        return 1
    document = {
        "frame_timestamp_ns": planes.frame_timestamp_ns,
        "frame_time_s": shapesense.format_ns(planes.frame_timestamp_ns),
        "planes": [{"id": p.id, "normal": list(p.normal), "d": p.d,
                    "polygon": [list(v) for v in p.polygon]} for p in planes],
    }
    with open(args.out, "w", encoding="utf-8") as f:
        json.dump(document, f, indent=1)
    print(f"{len(planes)} planes of frame {document['frame_time_s']} written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
