#!/usr/bin/env python3
"""Writes a glTF that places a scene's node trees N times on a square grid, for scale sweeps.

The copies share the original's meshes, materials, buffers and images (glTF instancing: many
nodes, one mesh), so the written file is small and sits beside the original, whose relative
URIs it keeps. Each copy is the original scene's node trees under one new root node translated
by the grid step; copy 0 stays where the original is, so the original's cameras (which belong
to copy 0) and a lighting file beside it see the same view.

    python3 benchmarks/scale/tile_gltf.py Sponza.gltf --copies 16 --step 40 --out Sponza-x16.gltf

With `--fly SPEED` the scene also gets a camera path (the product's `gi.camera_path` scene
extras): from the first camera node's place in copy 0 straight along +x through the first row
of copies at SPEED meters per second, looking ahead, for `gi-bench cache-update`.

The output must be in the same folder as the input (the URIs are kept as they are). A
`<stem>.lighting.json` beside the input is copied beside the output under the output's stem.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import shutil
import sys
from pathlib import Path


def tile(gltf: dict, copies: int, step: float, fly_speed: float | None = None) -> dict:
    """The document with the default scene's node trees repeated `copies` times on a grid of
    `ceil(sqrt(copies))` columns along x and rows along z, `step` meters apart."""
    out = copy.deepcopy(gltf)
    nodes = gltf.get("nodes", [])
    scene_index = gltf.get("scene", 0)
    roots = gltf["scenes"][scene_index]["nodes"]
    columns = math.ceil(math.sqrt(copies))
    new_roots = []
    for c in range(copies):
        # Copy 0 is the original's nodes as they are; later copies are renumbered duplicates
        # (a glTF node has at most one parent, so trees cannot be shared).
        offset = 0 if c == 0 else len(out["nodes"])
        if c > 0:
            for node in nodes:
                dup = copy.deepcopy(node)
                if "children" in dup:
                    dup["children"] = [i + offset for i in dup["children"]]
                # One camera view and one set of punctual lights: the first copy's.
                dup.pop("camera", None)
                if "KHR_lights_punctual" in dup.get("extensions", {}):
                    del dup["extensions"]["KHR_lights_punctual"]
                if "name" in dup:
                    dup["name"] = f"{dup['name']} (copy {c})"
                out["nodes"].append(dup)
        row, column = divmod(c, columns)
        out["nodes"].append({
            "name": f"copy {c}",
            "translation": [column * step, 0.0, row * step],
            "children": [r + offset for r in roots],
        })
        new_roots.append(len(out["nodes"]) - 1)
    out["scenes"][scene_index]["nodes"] = new_roots
    if fly_speed is not None:
        camera_nodes = [n for n in nodes if "camera" in n]
        start = camera_nodes[0].get("translation", [0.0, 0.0, 0.0]) if camera_nodes else [0.0] * 3
        duration = (columns * step) / fly_speed
        keys = [
            {
                "time_s": t,
                "position": [start[0] + fly_speed * t, start[1], start[2]],
                "target": [start[0] + fly_speed * t + 1.0, start[1], start[2]],
            }
            for t in (0.0, duration)
        ]
        scene = out["scenes"][scene_index]
        extras = scene.setdefault("extras", {})
        extras.setdefault("gi", {})["camera_path"] = {"keys": keys}
    # Skins and animations name nodes of copy 0 only; copies keep their skin index, whose
    # joints then stay those of copy 0 (the sweep's scenes have none).
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", type=Path, help="a .gltf file (JSON with external buffers)")
    parser.add_argument("--copies", type=int, required=True, help="how many copies (1..4096)")
    parser.add_argument("--step", type=float, required=True, help="grid step in meters")
    parser.add_argument("--fly", type=float, metavar="SPEED",
                        help="add a camera path along +x at SPEED m/s")
    parser.add_argument("--out", type=Path, required=True, help="the .gltf to write")
    args = parser.parse_args()
    if not 1 <= args.copies <= 4096:
        print("error: --copies must be within 1..4096", file=sys.stderr)
        return 2
    if args.fly is not None and not args.fly > 0:
        print("error: --fly must be a positive speed", file=sys.stderr)
        return 2
    if args.scene.resolve().parent != args.out.resolve().parent:
        print("error: --out must be in the folder of the scene (its URIs are kept)", file=sys.stderr)
        return 2
    gltf = json.loads(args.scene.read_text())
    args.out.write_text(json.dumps(tile(gltf, args.copies, args.step, args.fly)))
    lighting = args.scene.with_name(args.scene.stem + ".lighting.json")
    if lighting.exists():
        shutil.copyfile(lighting, args.out.with_name(args.out.stem + ".lighting.json"))
    print(f"{args.out}: {args.copies} copies of {args.scene.name}, {args.step} m apart")
    return 0


if __name__ == "__main__":
    sys.exit(main())
