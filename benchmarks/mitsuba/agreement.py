"""Agreement of two Monte Carlo renderers within their noise, measured from two seeds of each.

For renderer A with images `a1`, `a2` (two seeds) and renderer B with `b1`, `b2`, compare the
seed means `a = (a1 + a2) / 2` and `b = (b1 + b2) / 2`. Per pixel i (channels summed where a
scalar is needed), with `var_a` the variance of one seed's pixel:

- the difference of two seeds has variance `2 var_a`, so `(a1 - a2)^2 / 4` estimates the
  variance `var_a / 2` of the mean `a`, without bias and independently of `a` (the sum and the
  difference of two independent draws are uncorrelated);
- if A and B converge to the same image, `E[(a - b)^2] = var_a / 2 + var_b / 2`, which
  `noise_i = ((a1 - a2)^2 + (b1 - b2)^2) / 4` estimates. Any difference of expectations (a bias)
  adds its square on top.

**RMSE test.** `mse_ratio = mean_i (a - b)^2 / mean_i noise_i` is 1 for agreement. Its
uncertainty comes from the per-pixel terms `d_i = (a - b)_i^2 - noise_i`, which are independent
across pixels (each pixel's samples are its own, and both renderers use a box pixel filter):
`sigma = std(d) / sqrt(N) / mean(noise)`. This is the chi-square expectation `E = 1` with its
spread taken from the data rather than from a Gaussian formula, so fireflies widen the bound
instead of failing the test. Agreement: `mse_ratio <= 1 + K_SIGMA * sigma`. The table shows
`rmse_ratio = sqrt(mse_ratio)` (RMSE over its noise-only expectation) and its bound.

**Mean ratio.** `mean(a) / mean(b)` over the image, per channel and over all channels, with
the uncertainty of each mean from the same per-pixel variance estimates
(`var(mean a) = sum_i (a1 - a2)_i^2 / 4 / N^2`). Agreement:
`|ratio - 1| <= K_SIGMA * sigma + BIAS_ALLOWANCE`: noise, plus a bias bounded apart from it.
A per-pixel median of `a / b` (channel sums, pixels where b is not black) is reported, not
tested: a median of ratios of noisy values is itself slightly biased by the noise.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

BIAS_ALLOWANCE = 1e-3
"""The largest difference of mean brightness two correct renderers may have, apart from noise:
0.1%. Two renderers of the same scene still differ by their geometry's rounding, ray offsets
and which side of a surface reflects (Mitsuba's `diffuse` is one-sided, ours two-sided): with
2 billion samples a pixel on a GPU, where the noise allowance is 0.01%, the means differed by
0.02% (red 0.03%). A mistake in the BRDF or the emission is far larger (the Lambert base
without its specular layer's weight: 3.9%)."""

K_SIGMA = 4.0
"""How many standard deviations a statistic may stray before the renderers are said to
disagree: at 4 sigma a correct pair fails about once in 30,000 runs per test (Gaussian tails),
while an 8% brightness difference at the default sizes stands at dozens of sigma."""


@dataclass
class Agreement:
    """One renderer pair's statistics (A over B)."""

    a: str
    b: str
    rmse: float
    rmse_noise: float
    """Noise-only expectation of `rmse`: sqrt(mean(var_a / 2 + var_b / 2))."""
    rmse_ratio: float
    rmse_ratio_bound: float
    bias_rmse: float
    """The part of `rmse` noise does not explain, sqrt(max(0, rmse^2 - rmse_noise^2)): the RMS of
    the difference between the two converged images (0 within noise when they agree)."""
    mse_ratio: float
    mse_ratio_sigma: float
    mean_ratio: float
    mean_ratio_sigma: float
    mean_ratio_rgb: list[float]
    mean_ratio_rgb_sigma: list[float]
    median_pixel_ratio: float
    rmse_ok: bool
    mean_ok: bool

    @property
    def ok(self) -> bool:
        return self.rmse_ok and self.mean_ok

    def as_dict(self) -> dict:
        return asdict(self) | {"ok": self.ok}


def _ratio(a_mean: float, b_mean: float, a_var: float, b_var: float) -> tuple[float, float]:
    """a/b and its standard deviation (first-order propagation of the two means' variances)."""
    ratio = a_mean / b_mean
    return ratio, abs(ratio) * np.sqrt(a_var / a_mean**2 + b_var / b_mean**2)


def compare(a_name: str, a_seeds: list[np.ndarray],
            b_name: str, b_seeds: list[np.ndarray]) -> Agreement:
    """Statistics of renderer A against renderer B from two (H, W, 3) images of each."""
    a1, a2 = (np.asarray(x, np.float64) for x in a_seeds)
    b1, b2 = (np.asarray(x, np.float64) for x in b_seeds)
    if a1.shape != b1.shape:
        raise ValueError(f"{a_name} is {a1.shape[:2]} but {b_name} is {b1.shape[:2]}")
    a, b = (a1 + a2) / 2, (b1 + b2) / 2
    # Per pixel and channel: variance estimates of the seed means.
    var_a, var_b = (a1 - a2) ** 2 / 4, (b1 - b2) ** 2 / 4
    pixels = a.shape[0] * a.shape[1]

    # RMSE test over all pixels, channels summed per pixel (they share a path, so they are
    # correlated within a pixel but not across pixels).
    sq = ((a - b) ** 2).sum(axis=2).ravel()
    noise = (var_a + var_b).sum(axis=2).ravel()
    mse_ratio = sq.mean() / noise.mean()
    mse_sigma = (sq - noise).std(ddof=1) / np.sqrt(pixels) / noise.mean()
    bound = 1 + K_SIGMA * mse_sigma

    # Mean ratios: per channel, then all channels together.
    rgb, rgb_sigma = [], []
    for c in range(3):
        r, s = _ratio(a[..., c].mean(), b[..., c].mean(),
                      var_a[..., c].sum() / pixels**2, var_b[..., c].sum() / pixels**2)
        rgb.append(float(r))
        rgb_sigma.append(float(s))
    # The variance of a pixel's channel sum is estimated from the channel sums' differences.
    var_a_sum = ((a1 - a2).sum(axis=2) ** 2 / 4).sum() / pixels**2
    var_b_sum = ((b1 - b2).sum(axis=2) ** 2 / 4).sum() / pixels**2
    mean_ratio, mean_sigma = _ratio(a.sum(axis=2).mean(), b.sum(axis=2).mean(),
                                    var_a_sum, var_b_sum)

    a_sum, b_sum = a.sum(axis=2), b.sum(axis=2)
    lit = b_sum > 0
    median = float(np.median(a_sum[lit] / b_sum[lit])) if lit.any() else float("nan")

    return Agreement(
        a=a_name,
        b=b_name,
        rmse=float(np.sqrt(((a - b) ** 2).mean())),
        rmse_noise=float(np.sqrt((var_a + var_b).mean())),
        rmse_ratio=float(np.sqrt(mse_ratio)),
        rmse_ratio_bound=float(np.sqrt(bound)),
        bias_rmse=float(np.sqrt(max(0.0, ((a - b) ** 2).mean() - (var_a + var_b).mean()))),
        mse_ratio=float(mse_ratio),
        mse_ratio_sigma=float(mse_sigma),
        mean_ratio=float(mean_ratio),
        mean_ratio_sigma=float(mean_sigma),
        mean_ratio_rgb=rgb,
        mean_ratio_rgb_sigma=rgb_sigma,
        median_pixel_ratio=median,
        rmse_ok=bool(mse_ratio <= bound),
        mean_ok=bool(abs(mean_ratio - 1) <= K_SIGMA * mean_sigma + BIAS_ALLOWANCE),
    )


def table(rows: list[Agreement]) -> str:
    """A markdown table of the statistics, one row per pair."""
    lines = [
        "| A / B | rmse | noise-only rmse | rmse ratio (bound) | bias rmse | mean ratio "
        "| mean ratio R, G, B | median pixel ratio | agree |",
        "|---|---:|---:|---:|---:|---:|---|---:|---|",
    ]
    for r in rows:
        rgb = ", ".join(f"{v:.4f}" for v in r.mean_ratio_rgb)
        verdict = "yes" if r.ok else "NO (" + ", ".join(
            name for name, ok in (("rmse", r.rmse_ok), ("mean", r.mean_ok)) if not ok) + ")"
        lines.append(
            f"| {r.a} / {r.b} | {r.rmse:.5f} | {r.rmse_noise:.5f} | {r.rmse_ratio:.4f} "
            f"(<= {r.rmse_ratio_bound:.4f}) | {r.bias_rmse:.5f} "
            f"| {r.mean_ratio:.4f} ± {r.mean_ratio_sigma:.4f} "
            f"| {rgb} | {r.median_pixel_ratio:.4f} | {verdict} |"
        )
    return "\n".join(lines)
