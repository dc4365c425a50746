#!/usr/bin/env python3
"""Fits the directional albedo of the product's GGX specular layer and writes it as code.

The BRDF (`gi_reference::brdf`, `shaders/common/brdf.wgsl`) weighs its Lambert base by what the
dielectric's specular layer does not reflect, and the split-sum tiers multiply pre-integrated
light by the layer's albedo. Both read the albedo

    E(mu, alpha) = f0 * A + f90 * B = M * (f0 + (f90 - f0) * R)

of the GGX lobe (height-correlated Smith) with Schlick's Fresnel term, where `M = A + B` is
the lobe's albedo without Fresnel and `R = B / M` the share of its Fresnel weight
`(1 - wo.h)^5`. This script integrates `M` and `R` by stratified visible-normal sampling
(Heitz 2018) on a grid of Chebyshev nodes, fits each as a bivariate Chebyshev series
(`M` in `1 - 2 mu / (mu + alpha)`, which straightens the masking ridge at `mu ~ alpha`, and
`R` in `1 - 2 mu^(1/4)`; both in `2 sqrt(alpha) - 1`), checks them on random points off the
grid, and shifts each up by its largest deficit there, so the fit never under-states the
layer's albedo (the BRDF's energy bound relies on it). One definition, two outputs:

    crates/gi-reference/src/brdf/albedo_fit.rs   (the CPU reference)
    shaders/common/brdf_albedo.wgsl              (`gi::brdf_albedo`, every GPU tier)

Run from the repository root (numpy needed; about 5 minutes on 2 cores):

    python3 benchmarks/brdf/fit_albedo.py
"""
import sys
from pathlib import Path

import numpy as np
from numpy.polynomial import chebyshev as cheb

MIN_ALPHA = 1e-3  # gi_reference::brdf::MIN_ALPHA
GRID = 48  # Chebyshev nodes per axis
SAMPLES = 256  # stratified visible-normal samples per axis and point
DEGREE_M = 11  # total degree of M's series
DEGREE_R = 15  # total degree of R's series
VALIDATION = 400  # random check points
MARGIN = 2e-4  # added to each shift: the quadrature's own error (256 vs 768 samples: < 1e-4)


def lobe_terms(mu, alpha, n=SAMPLES):
    """(M, R) at cos(theta_o) `mu` and GGX `alpha`, by stratified visible-normal sampling."""
    a2 = alpha * alpha
    v = np.array([np.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu])
    u1, u2 = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n, indexing="ij")
    u1, u2 = u1.ravel(), u2.ravel()
    vh = np.array([alpha * v[0], alpha * v[1], v[2]])
    vh /= np.linalg.norm(vh)
    len_sq = vh[0] ** 2 + vh[1] ** 2
    t1 = np.array([-vh[1], vh[0], 0.0]) / np.sqrt(len_sq) if len_sq > 0 else np.array([1.0, 0, 0])
    t2 = np.cross(vh, t1)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    p1 = r * np.cos(phi)
    s = 0.5 * (1 + vh[2])
    p2 = (1 - s) * np.sqrt(np.maximum(1 - p1 * p1, 0)) + s * r * np.sin(phi)
    nh = p1[:, None] * t1 + p2[:, None] * t2 + np.sqrt(np.maximum(1 - p1 * p1 - p2 * p2, 0))[:, None] * vh
    h = np.stack([alpha * nh[:, 0], alpha * nh[:, 1], np.maximum(nh[:, 2], 0)], -1)
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    v_dot_h = np.clip(h @ v, 0, 1)
    cos_i = (2 * v_dot_h[:, None] * h - v)[:, 2]
    smith = lambda c: np.sqrt(a2 + (1 - a2) * c * c)
    ci = np.maximum(cos_i, 0)
    g2 = np.where(cos_i > 0, 2 * mu * ci / np.maximum(smith(mu) * ci + smith(ci) * mu, 1e-30), 0)
    g1 = 2 * mu / (mu + smith(mu))
    weight = g2 / g1
    m = weight.mean()
    b = (weight * (1 - v_dot_h) ** 5).mean()
    return m, (b / m if m > 0 else 0.0)


def coords(mu, alpha):
    """(u_M, u_R, s): the series' variables."""
    q = mu / (mu + alpha)
    return 1 - 2 * q, 1 - 2 * mu**0.25, 2 * np.sqrt(alpha) - 1


def design(u, s, degree):
    tu, ts = cheb.chebvander(u, degree), cheb.chebvander(s, degree)
    return np.stack([ts[:, i] * tu[:, j] for i in range(degree + 1) for j in range(degree + 1 - i)], -1)


def triangle(c, degree):
    """Coefficients as rows i (T_i of s) of columns j (T_j of u), j < degree + 1 - i."""
    rows, k = [], 0
    for i in range(degree + 1):
        rows.append(list(c[k : k + degree + 1 - i]))
        k += degree + 1 - i
    return rows


def sample_points(mu, alpha):
    terms = np.array([lobe_terms(m, a) for m, a in zip(mu, alpha)])
    return terms[:, 0], terms[:, 1]


def main():
    root = Path(__file__).resolve().parents[2]
    nodes = (1 - np.cos(np.pi * (np.arange(GRID) + 0.5) / GRID)) / 2
    sqrt_mu, sqrt_alpha = np.meshgrid(nodes, nodes, indexing="ij")
    mu = np.maximum(sqrt_mu.ravel() ** 2, 1e-4)
    alpha = np.maximum(sqrt_alpha.ravel() ** 2, MIN_ALPHA)
    print(f"integrating {mu.size} grid points ...", file=sys.stderr)
    m, r = sample_points(mu, alpha)
    u_m, u_r, s = coords(mu, alpha)
    c_m, *_ = np.linalg.lstsq(design(u_m, s, DEGREE_M), m, rcond=None)
    c_r, *_ = np.linalg.lstsq(design(u_r, s, DEGREE_R), r, rcond=None)

    rng = np.random.default_rng(7)
    check_mu = np.concatenate([rng.uniform(0, 1, VALIDATION) ** 2, mu])
    check_alpha = np.concatenate([np.maximum(rng.uniform(0, 1, VALIDATION) ** 2, MIN_ALPHA), alpha])
    print(f"checking {VALIDATION} random points ...", file=sys.stderr)
    vm, vr = sample_points(check_mu[:VALIDATION], check_alpha[:VALIDATION])
    vm, vr = np.concatenate([vm, m]), np.concatenate([vr, r])
    cu_m, cu_r, cs = coords(np.maximum(check_mu, 1e-4), check_alpha)
    fm = design(cu_m, cs, DEGREE_M) @ c_m
    fr = design(cu_r, cs, DEGREE_R) @ c_r
    shift_m = max(float((vm - fm).max()), 0.0) + MARGIN
    shift_r = max(float((vr - fr).max()), 0.0) + MARGIN
    c_m[0] += shift_m
    c_r[0] += shift_r
    fm, fr = fm + shift_m, fr + shift_r
    e_true = lambda f0, mm, rr: mm * (f0 + (1 - f0) * rr)
    for f0 in (0.04, 1.0):
        excess = e_true(f0, np.clip(fm, 0, 1), np.clip(fr, 0, 1)) - e_true(f0, vm, vr)
        print(f"f0 {f0}: fit - quadrature in [{excess.min():.5f}, {excess.max():.5f}],"
              f" mean {excess.mean():.5f}", file=sys.stderr)
    print(f"shifts: M {shift_m:.5f}, R {shift_r:.5f}", file=sys.stderr)

    write_rust(root / "crates/gi-reference/src/brdf/albedo_fit.rs", c_m, c_r, shift_m, shift_r)
    write_wgsl(root / "shaders/common/brdf_albedo.wgsl", c_m, c_r)


HEADER = """Generated by `benchmarks/brdf/fit_albedo.py`; do not edit. The GGX specular layer's
directional albedo `E = M * (f0 + (f90 - f0) * R)` as two bivariate Chebyshev series:
`M` (the lobe's albedo without Fresnel) of total degree {dm} in `u_m = 1 - 2 mu / (mu + alpha)`
and `s = 2 sqrt(alpha) - 1`, `R` (the share of the Fresnel weight `(1 - wo.h)^5`) of total
degree {dr} in `u_r = 1 - 2 mu^(1/4)` and `s`; `mu = n.v`. Each series was shifted up by its
largest deficit against the quadrature plus a margin (M {sm:.5f}, R {sr:.5f}) so that it never
under-states the layer's albedo."""


def f32(x):
    """The shortest decimal that reads back as the same f32, as Rust and WGSL literals."""
    text = np.format_float_positional(np.float32(x), unique=True, trim="0")
    if len(text) > 14:
        text = np.format_float_scientific(np.float32(x), unique=True, trim="0")
    return text


def write_rust(path, c_m, c_r, shift_m, shift_r):
    doc = HEADER.format(dm=DEGREE_M, dr=DEGREE_R, sm=shift_m, sr=shift_r)
    out = ["//! " + line if line else "//!" for line in doc.splitlines()]
    out.append("")
    for name, c, degree, what in (("M", c_m, DEGREE_M, "`M`"), ("R", c_r, DEGREE_R, "`R`")):
        rows = triangle(c, degree)
        out.append(f"/// Coefficients of {what}: row `i` multiplies `T_i(s)`, entry `j` `T_j(u)`.")
        out.append("#[rustfmt::skip]")
        out.append(f"pub(super) const {name}: [&[f32]; {degree + 1}] = [")
        for row in rows:
            out.append("    &[" + ", ".join(f32(x) for x in row) + "],")
        out.append("];")
        out.append("")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(out).rstrip() + "\n")


def write_wgsl(path, c_m, c_r):
    doc = HEADER.format(dm=DEGREE_M, dr=DEGREE_R, sm=0, sr=0).split(" (M ")[0] + "."
    out = ["// " + line if line else "//" for line in doc.splitlines()]
    out += ["// The same numbers as `gi_reference::brdf`'s fit, summed in the same order.",
            "#define_import_path gi::brdf_albedo", ""]
    for name, c, degree, var in (("m", c_m, DEGREE_M, "u_m"), ("r", c_r, DEGREE_R, "u_r")):
        rows = triangle(c, degree)
        out.append(f"// `{name.upper()}` at its variables `{var}` and `s` (the header).")
        out.append(f"fn albedo_series_{name}(u: f32, s: f32) -> f32 {{")
        for axis in ("u", "s"):
            out.append(f"    let {axis}0 = 1.0;")
            out.append(f"    let {axis}1 = {axis};")
            for k in range(2, degree + 1):
                out.append(f"    let {axis}{k} = 2.0 * {axis} * {axis}{k - 1} - {axis}{k - 2};")
        terms = []
        for i, row in enumerate(rows):
            inner = " + ".join(f"{f32(x)} * u{j}" for j, x in enumerate(row))
            terms.append(f"s{i} * ({inner})")
        out.append("    return " + "\n        + ".join(terms) + ";")
        out.append("}")
        out.append("")
    path.write_text("\n".join(out).rstrip() + "\n")


if __name__ == "__main__":
    main()
