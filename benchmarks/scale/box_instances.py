#!/usr/bin/env python3
"""Writes a .glb of N instances of one unit box (12 triangles): in a row at equal spacing, or
all at one place. Both were worst cases of the BVH builder: its neighbours tie exactly.

    python3 benchmarks/scale/box_instances.py --count 50000 --spacing 2 --out row.glb
    python3 benchmarks/scale/box_instances.py --count 200000 --spacing 0 --out boxes.glb
    gi render row.glb --tier reference --width 16 --height 12 --spp 1 --out row.png

The file has a camera and no light (the render is black; what is measured is the load and
the first frame, which builds the BVH).
"""

from __future__ import annotations

import argparse
import json
import struct


def box_glb(count: int, spacing: float) -> bytes:
    corners = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    indices = [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
               2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3]
    positions = b"".join(struct.pack("<3f", *c) for c in corners)
    index_bytes = b"".join(struct.pack("<H", i) for i in indices)
    binary = positions + index_bytes
    binary += b"\0" * (-len(binary) % 4)
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": list(range(count + 1))}],
        "nodes": [{"mesh": 0, "translation": [spacing * i, 0, 0]} for i in range(count)]
        + [{"camera": 0, "translation": [0.5, 0.5, 5]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(positions)},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(index_bytes)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"},
        ],
    }
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return (struct.pack("<III", 0x46546C67, 2, total)
            + struct.pack("<II", len(text), 0x4E4F534A) + text
            + struct.pack("<II", len(binary), 0x004E4942) + binary)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, required=True, help="instances of the box")
    parser.add_argument("--spacing", type=float, default=2.0,
                        help="metres between instances along +x (0: all at one place)")
    parser.add_argument("--out", required=True, help="the .glb to write")
    args = parser.parse_args()
    with open(args.out, "wb") as out:
        out.write(box_glb(args.count, args.spacing))


if __name__ == "__main__":
    main()
