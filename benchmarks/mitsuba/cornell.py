#!/usr/bin/env python3
"""Cross-check of our renderers against an independent one, Mitsuba 3, on Mitsuba's Cornell box.

What it does:
  1. Sets itself up: a virtual environment in `.venv/` beside this file with the packages of
     `requirements.txt` (mitsuba, numpy), then runs again inside it.
  2. Renders Mitsuba's own Cornell box (`mitsuba.cornell_box()`: diffuse walls and blocks, a
     rectangle area light, a perspective camera) with Mitsuba's `path` integrator at the same
     path depth and Russian roulette start as our reference, a box pixel filter, two seeds, to
     linear RGB EXR.
  3. Writes the same scene as glTF 2.0 (`mitsuba_gltf.py`): world-space triangles, the camera,
     the light as a single-sided emitter of the same radiance, Lambert materials
     (`KHR_materials_specular` with `specularFactor` 0), a black sky and exposure 1.
  4. Renders that glTF with `gi render` at the `reference` tier (CPU) and the `path` tier
     (GPU; on a machine without one, Mesa's lavapipe), two seeds each.
  5. Tests agreement within the noise measured from the seed pairs (`agreement.py` states the
     statistics and the rule): per pair of renderers, the RMSE between their seed means against
     the RMSE that noise alone gives, and the ratio of their mean brightness, overall and per
     channel. Prints a table, writes `summary.json`, and exits 1 when a pair disagrees.
  6. Compares speed: Mitsuba's samples per second (pixel samples / wall time of the timed
     renders, after a first render that compiles its kernels) against our reference's own
     throughput figure (`gi render --stats`), on the same scene, size and machine.

How to run (from the repository root; the defaults take about 40 s on 2 CPU cores once `gi`
is built, and the first run spends some seconds more creating the environment):

    python3 benchmarks/mitsuba/cornell.py              # defaults: 128x128, both tiers
    python3 benchmarks/mitsuba/cornell.py --tiers reference --size 256 --spp 512

It builds `gi` with `cargo build --release -p gi-cli` unless `--gi PATH` names a binary. The
fast Mitsuba variant, `llvm_ad_rgb`, needs the LLVM shared library (Debian: `libllvm19`);
without it the script falls back to `scalar_rgb` and says so (the same image up to noise,
rendered more slowly; the speed figure is then the scalar one).

What "agreement" means: the two renderers converge to the same image. Their seed means may
then differ only by noise, whose size is measured, not assumed; see `agreement.py`.

Exit status: 0 all pairs agree, 1 some pair disagrees, 2 the set-up or a render failed.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
VENV = HERE / ".venv"
REQUIREMENTS = HERE / "requirements.txt"

# Our reference's path length, mirrored on Mitsuba's side (gi_reference's
# RenderSettings::default().max_depth and RUSSIAN_ROULETTE_START, which `gi render` uses).
OUR_MAX_SCATTERINGS = 64
OUR_RR_START = 3

MITSUBA_SEEDS = (1, 2)
REFERENCE_SEEDS = (1, 2)
# The path tier gets seeds of its own, so that its noise cannot be correlated with the
# reference's should the two share a random sequence.
PATH_SEEDS = (3, 4)

ANSI_ESCAPE = re.compile(r"\x1b\[[0-9;]*m")


class SetupError(RuntimeError):
    """Something this script needs is missing; the message says how to get it."""


# ---------------------------------------------------------------------------------------------
# Set-up: the virtual environment and the imports it provides


def ensure_venv() -> None:
    """Re-runs this script inside `.venv`, creating or updating it first."""
    if Path(sys.prefix).resolve() == VENV.resolve():
        return
    python = VENV / "bin" / "python"
    stamp = VENV / "requirements.sha256"
    wanted = hashlib.sha256(REQUIREMENTS.read_bytes()).hexdigest()
    if not python.exists():
        print(f"setting up {VENV.relative_to(REPO)} (once)", file=sys.stderr)
        if subprocess.run([sys.executable, "-m", "venv", str(VENV)]).returncode != 0:
            raise SetupError("could not create the virtual environment "
                             "(on Debian: apt-get install python3-venv)")
    if not stamp.exists() or stamp.read_text().strip() != wanted:
        print(f"installing {REQUIREMENTS.name} into {VENV.relative_to(REPO)}", file=sys.stderr)
        pip = [str(python), "-m", "pip", "install", "--quiet", "-r", str(REQUIREMENTS)]
        if subprocess.run(pip).returncode != 0:
            raise SetupError(f"pip could not install {REQUIREMENTS} (it needs PyPI access); "
                             f"fix that, or delete {VENV} and run again")
        stamp.write_text(wanted + "\n")
    os.execv(str(python), [str(python), str(Path(__file__).resolve()), *sys.argv[1:]])


def import_mitsuba(variant: str):
    """Mitsuba with `variant` set, or the scalar fallback when LLVM is missing."""
    try:
        import mitsuba as mi
    except ImportError as e:
        raise SetupError(f"mitsuba is not importable ({e}); delete {VENV} and run again") from e
    try:
        mi.set_variant(variant)
    except Exception as e:  # drjit raises various types when its LLVM backend is missing
        if variant == "scalar_rgb":
            raise SetupError(f"mitsuba variant scalar_rgb failed: {e}") from e
        print(f"warning: mitsuba variant {variant} unavailable ({e}); using scalar_rgb "
              "(Debian: apt-get install libllvm19 for the fast one)", file=sys.stderr)
        mi.set_variant("scalar_rgb")
    return mi


# ---------------------------------------------------------------------------------------------
# Mitsuba


def mitsuba_scene(mi, width: int, height: int) -> dict:
    """`mitsuba.cornell_box()` at our image size, with a box pixel filter (ours is a box: a
    wider filter would blur Mitsuba's edges and make per-pixel differences that are not noise)
    and the path integrator at our path depth."""
    scene = mi.cornell_box()
    scene["sensor"]["film"].update(width=width, height=height, rfilter={"type": "box"})
    scene["sensor"]["sampler"] = {"type": "independent"}
    scene["integrator"] = {
        "type": "path",
        # Mitsuba counts path segments (1: emitters seen directly), we count scatterings.
        "max_depth": OUR_MAX_SCATTERINGS + 1,
        # Both start the roulette after this many scatterings, and both survive with
        # min(max throughput component, 0.95).
        "rr_depth": OUR_RR_START,
    }
    return scene


def render_mitsuba(mi, scene_dict: dict, spp: int, out_dir: Path) -> tuple[list, dict]:
    """Two seeds of Mitsuba's image (as numpy arrays, also written as EXR) and its speed."""
    import numpy as np

    scene = mi.load_dict(scene_dict)
    width, height = scene_dict["sensor"]["film"]["width"], scene_dict["sensor"]["film"]["height"]
    jit = mi.variant().startswith(("llvm", "cuda"))
    warmup_s = 0.0
    if jit:
        # The first render compiles the kernels (or loads them from Dr.Jit's cache); later
        # ones reuse them whatever their sample count, so one sample per pixel warms up.
        start = time.perf_counter()
        np.array(mi.render(scene, spp=1, seed=1000))
        warmup_s = time.perf_counter() - start
    images, seconds = [], 0.0
    for seed in MITSUBA_SEEDS:
        start = time.perf_counter()
        image = mi.render(scene, spp=spp, seed=seed)
        pixels = np.array(image, dtype=np.float32)  # waits for the render to finish
        seconds += time.perf_counter() - start
        mi.Bitmap(pixels).write(str(out_dir / f"mitsuba_seed{seed}.exr"))
        images.append(pixels[..., :3])
    samples = width * height * spp * len(MITSUBA_SEEDS)
    speed = {
        "variant": mi.variant(),
        "samples": samples,
        "seconds": seconds,
        "samples_per_second": samples / seconds,
        "first_render_s": warmup_s,
    }
    return images, speed


# ---------------------------------------------------------------------------------------------
# Ours


def gi_binary(path: str | None) -> Path:
    """The `gi` binary: the given one, or a release build of this checkout."""
    if path:
        binary = Path(path)
        if not binary.is_file():
            raise SetupError(f"--gi {path}: no such file")
        return binary
    print("cargo build --release -p gi-cli", file=sys.stderr)
    if subprocess.run(["cargo", "build", "--release", "-p", "gi-cli"], cwd=REPO).returncode != 0:
        raise SetupError("cargo build --release -p gi-cli failed")
    metadata = subprocess.run(["cargo", "metadata", "--format-version", "1", "--no-deps"],
                              cwd=REPO, capture_output=True, text=True, check=True)
    return Path(json.loads(metadata.stdout)["target_directory"]) / "release" / "gi"


def render_ours(mi, gi: Path, gltf: Path, tier: str, seeds, args,
                out_dir: Path) -> tuple[list, dict]:
    """Two seeds of `gi render` at `tier` (images read with Mitsuba's EXR reader), their stats,
    and the importer's warnings."""
    import numpy as np

    env = dict(os.environ)
    # Vulkan loaders (lavapipe among them) warn without it.
    env.setdefault("XDG_RUNTIME_DIR", tempfile.gettempdir())
    images, stats, warnings, wall_s = [], [], set(), 0.0
    for seed in seeds:
        exr = out_dir / f"{tier}_seed{seed}.exr"
        stats_path = out_dir / f"{tier}_seed{seed}.json"
        command = [str(gi), "render", str(gltf), "--tier", tier, "--spp", str(args.spp_of(tier)),
                   "--width", str(args.size), "--height", str(args.size), "--seed", str(seed),
                   "--out", str(exr), "--stats", str(stats_path)]
        start = time.perf_counter()
        done = subprocess.run(command, env=env, capture_output=True, text=True)
        wall_s += time.perf_counter() - start
        if done.returncode != 0:
            raise SetupError(f"{' '.join(command)} failed:\n{done.stderr.strip()}")
        print("  " + done.stdout.strip(), file=sys.stderr)
        # Log lines read "<time> WARN <message>": keep the message, once.
        warnings.update(ANSI_ESCAPE.sub("", line).split("WARN", 1)[1].strip()
                        for line in done.stderr.splitlines() if "WARN" in line)
        stats.append(json.loads(stats_path.read_text()))
        images.append(np.array(mi.Bitmap(str(exr)), dtype=np.float32)[..., :3])
    return images, {"stats": stats, "warnings": sorted(warnings), "wall_s": wall_s}


# ---------------------------------------------------------------------------------------------


def compare_speed(mitsuba_speed: dict, runs: dict, size: int) -> dict:
    """Prints and returns Mitsuba's throughput against each of our tiers' that ran."""
    speed = {"mitsuba": mitsuba_speed}
    rows = []
    for tier, run in runs.items():
        stats = run["stats"]
        samples = sum(s["width"] * s["height"] * s["spp"] for s in stats)
        # gi's figure counts the path tracing itself (CPU time for the reference, the GPU
        # passes' time for the path tier), not the scene load and BVH build, as the Mitsuba
        # figure leaves out the scene load and kernel compilation.
        seconds = sum(s["width"] * s["height"] * s["spp"] / s["samples_per_second"]
                      for s in stats)
        speed[tier] = {"samples": samples, "seconds": seconds,
                       "samples_per_second": samples / seconds}
        ratio = mitsuba_speed["samples_per_second"] / speed[tier]["samples_per_second"]
        speed[f"mitsuba_over_{tier}"] = ratio
        rows.append((tier, samples, seconds, ratio))
    if not rows:
        return speed
    print(f"\nSpeed on this machine ({os.cpu_count()} cores), {size}x{size}:\n")
    print("| renderer | samples | seconds | Msamples/s | mitsuba / this |")
    print("|---|---:|---:|---:|---:|")
    print(f"| mitsuba {mitsuba_speed['variant']} | {mitsuba_speed['samples']} | "
          f"{mitsuba_speed['seconds']:.3f} | {mitsuba_speed['samples_per_second'] / 1e6:.3f} | |")
    for tier, samples, seconds, ratio in rows:
        print(f"| gi {tier} | {samples} | {seconds:.3f} | {samples / seconds / 1e6:.3f} | "
              f"{ratio:.2f}x |")
    if mitsuba_speed["first_render_s"] > 0:
        print(f"(not timed: mitsuba's first render, 1 spp, which compiles its kernels or "
              f"loads them from Dr.Jit's cache: {mitsuba_speed['first_render_s']:.2f} s)")
    return speed


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=128, help="image width and height")
    parser.add_argument("--spp", type=int, default=256,
                        help="samples per pixel of our reference tier")
    parser.add_argument("--path-spp", type=int, default=64,
                        help="samples per pixel of our path tier (slow on lavapipe)")
    parser.add_argument("--mitsuba-spp", type=int, default=512,
                        help="samples per pixel of Mitsuba")
    parser.add_argument("--tiers", default="reference,path",
                        help="our tiers to check, comma-separated (reference, path)")
    parser.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant")
    parser.add_argument("--gi", help="the gi binary (default: build this checkout's)")
    parser.add_argument("--no-venv", action="store_true",
                        help="use this Python's own mitsuba and numpy (a machine without PyPI)")
    parser.add_argument("--out", type=Path, default=REPO / "bench-out" / "mitsuba",
                        help="folder for the scene, images and summary.json")
    args = parser.parse_args()
    args.tiers = [t for t in args.tiers.split(",") if t]
    unknown = set(args.tiers) - {"reference", "path"}
    if unknown or not args.tiers:
        parser.error(f"--tiers: expected reference and/or path, got {args.tiers}")
    args.spp_of = lambda tier: args.spp if tier == "reference" else args.path_spp
    return args


def main() -> int:
    started = time.perf_counter()
    args = parse_args()
    if not args.no_venv:
        ensure_venv()
    mi = import_mitsuba(args.variant)
    from agreement import BIAS_ALLOWANCE, K_SIGMA, compare, table
    from mitsuba_gltf import UnsupportedScene, export_gltf

    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    scene = mitsuba_scene(mi, args.size, args.size)
    gltf = out / "mitsuba-cornell-box.gltf"
    try:
        exported = export_gltf(scene, args.size, args.size, gltf)
    except UnsupportedScene as e:
        raise SetupError(f"cannot export the scene to glTF: {e}") from e
    print(f"wrote {gltf}: {exported['shapes']} shapes, {exported['triangles']} triangles, "
          f"yfov {exported['yfov_deg']:.3f} deg", file=sys.stderr)

    gi = gi_binary(args.gi)
    print(f"mitsuba {mi.__version__} {mi.variant()}: {args.size}x{args.size}, "
          f"{args.mitsuba_spp} spp, seeds {MITSUBA_SEEDS}", file=sys.stderr)
    images = {}
    images["mitsuba"], mitsuba_speed = render_mitsuba(mi, scene, args.mitsuba_spp, out)
    runs = {}
    for tier in args.tiers:
        seeds = REFERENCE_SEEDS if tier == "reference" else PATH_SEEDS
        print(f"gi {tier}: {args.size}x{args.size}, {args.spp_of(tier)} spp, seeds {seeds}",
              file=sys.stderr)
        images[tier], runs[tier] = render_ours(mi, gi, gltf, tier, seeds, args, out)

    pairs = [(tier, "mitsuba") for tier in args.tiers]
    if len(args.tiers) == 2:
        pairs.append(("path", "reference"))
    rows = [compare(a, images[a], b, images[b]) for a, b in pairs]

    print(f"\nAgreement ({args.size}x{args.size}; seed means of two seeds each; "
          f"bounds at {K_SIGMA:g} sigma of the measured noise, means also "
          f"{BIAS_ALLOWANCE:.1%} apart):\n")
    print(table(rows))
    specular_ignored = any("KHR_materials_specular" in w
                           for run in runs.values() for w in run["warnings"])
    if specular_ignored:
        print("\nnote: this gi build ignores KHR_materials_specular (it warns so), so its walls "
              "keep a GGX layer\n      (F0 = 0.04) on top of the Lambert base: ours is then "
              "expected brighter than Mitsuba's\n      pure Lambert walls, by the mean ratio "
              "above.")

    speed = compare_speed(mitsuba_speed, runs, args.size)

    total_s = time.perf_counter() - started
    agree = all(r.ok for r in rows)
    summary = {
        "scene": "mitsuba.cornell_box()",
        "size": [args.size, args.size],
        "spp": {"mitsuba": args.mitsuba_spp, "reference": args.spp, "path": args.path_spp},
        "seeds": {"mitsuba": MITSUBA_SEEDS, "reference": REFERENCE_SEEDS, "path": PATH_SEEDS},
        "mitsuba": {"version": mi.__version__, "variant": mi.variant(),
                    "integrator": scene["integrator"]},
        "k_sigma": K_SIGMA,
        "agreement": [r.as_dict() for r in rows],
        "agree": agree,
        "specular_extension_ignored_by_gi": specular_ignored,
        "gi_warnings": sorted({w for run in runs.values() for w in run["warnings"]}),
        "speed": speed,
        "gi_wall_s": {tier: run["wall_s"] for tier, run in runs.items()},
        "total_s": total_s,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"\n{'agree' if agree else 'DISAGREE'}; total {total_s:.0f} s; "
          f"summary in {out / 'summary.json'}")
    return 0 if agree else 1


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SetupError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
