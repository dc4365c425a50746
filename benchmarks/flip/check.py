#!/usr/bin/env python3
"""Recomputes the FLIP known answer of `crates/gi-image/tests/flip.rs` with NVIDIA's reference.

The test pair is defined by integer formulas on 8-bit sRGB codes (96x64: a red/green gradient
over a blue checkerboard with a bright square; the test image moves the square 3 pixels right
and adds hashed noise of -16..15 codes), so this script and the Rust test build the very same
pixels. NVIDIA's Python package `flip-evaluator` then evaluates them in its LDR mode at its
default 67 pixels per degree, and the script prints the numbers the Rust test records: the
mean, the largest error, and the error at a few pixels.

Run from anywhere (numpy comes with flip-evaluator):

    python3 -m venv /tmp/flipvenv && /tmp/flipvenv/bin/pip install flip-evaluator
    /tmp/flipvenv/bin/python benchmarks/flip/check.py
"""
import flip_evaluator as flip
import numpy as np

WIDTH, HEIGHT = 96, 64
# (x, y) of the pixels whose error the test records.
PROBES = [(0, 0), (21, 28), (37, 30), (60, 10)]
MASK = 0xFFFFFFFF


def base(x, y, c, square_x):
    """The reference's code at (x, y), channel c, with the square's left edge at square_x."""
    if square_x <= x < square_x + 16 and 20 <= y < 36:
        return 240
    if c == 0:
        return x * 255 // (WIDTH - 1)
    if c == 1:
        return y * 255 // (HEIGHT - 1)
    return 200 if (x // 8 + y // 8) % 2 == 0 else 40


def noise(x, y, c):
    """Hashed noise in -16..15 codes (32-bit wrapping arithmetic, as the Rust test's)."""
    h = ((x * 73856093) ^ (y * 19349663) ^ (c * 83492791)) & MASK
    h = (h * 2654435761) & MASK
    return (h >> 27) - 16


def image(test):
    codes = np.zeros((HEIGHT, WIDTH, 3), dtype=np.uint8)
    for y in range(HEIGHT):
        for x in range(WIDTH):
            for c in range(3):
                if test:
                    codes[y, x, c] = min(max(base(x, y, c, 23) + noise(x, y, c), 0), 255)
                else:
                    codes[y, x, c] = base(x, y, c, 20)
    return codes


def main():
    reference = image(test=False).astype(np.float32) / 255.0
    test = image(test=True).astype(np.float32) / 255.0
    error_map, mean, parameters = flip.evaluate(reference, test, "LDR", applyMagma=False)
    error_map = np.asarray(error_map).reshape(HEIGHT, WIDTH)
    print(f"flip-evaluator, LDR, {parameters.get('ppd')} pixels per degree")
    print(f"mean {mean:.7f}")
    print(f"mean of the map in float64 {error_map.astype(np.float64).mean():.7f}")
    print(f"max {error_map.max():.7f}")
    for x, y in PROBES:
        print(f"({x}, {y}) {error_map[y, x]:.7f}")


if __name__ == "__main__":
    main()
