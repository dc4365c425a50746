//! Regression check against a previous `results.json` (`--baseline`).
//!
//! A metric of a (scene, tier) regressed when it got worse by more than the run-to-run spread
//! both runs measured: with mean m and sample standard deviation s over each run's repeats,
//! `m_new - m_old > 3 * sqrt(s_old^2 + s_new^2)` for `rmse_srgb8`, `flip` and `ms_per_frame` (3
//! standard deviations of the difference of two means; lower is better for all), and any
//! increase of
//! `memory_bytes` (deterministic: a tier's allocations do not vary between runs). A metric
//! without a spread on either side (a run with one repeat) is not compared: without one, noise
//! cannot be told from a change.

use serde::{Deserialize, Serialize};

use super::results::{Cell, Results, Stat};

/// How many standard deviations of the difference a change must exceed.
pub const SIGMAS: f64 = 3.0;

/// The rule, as results.md and results.json state it.
pub const RULE: &str = "a metric regressed when new_mean - old_mean > 3 * sqrt(sd_old^2 + \
    sd_new^2) (sample standard deviations over each run's repeats) for rmse_srgb8, flip and \
    ms_per_frame, and on any increase of memory_bytes (deterministic); metrics without a \
    spread on either side (one repeat) are not compared";

/// The outcome of comparing a run with its baseline.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Comparison {
    /// The baseline file as given.
    pub baseline: String,
    pub baseline_commit: String,
    pub baseline_date: String,
    pub rule: String,
    /// Option differences (size, frames, samples...) that make the comparison less meaningful.
    pub option_differences: Vec<String>,
    /// Metric comparisons made.
    pub compared: usize,
    /// `scene/tier metric: why` for each comparison that could not be made.
    pub not_compared: Vec<String>,
    pub flagged: Vec<Regression>,
}

/// One metric that got worse.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Regression {
    pub scene: String,
    pub tier: String,
    /// `rmse_srgb8`, `flip`, `ms_per_frame` or `memory_bytes`.
    pub metric: String,
    pub old_mean: f64,
    pub old_sd: Option<f64>,
    pub new_mean: f64,
    pub new_sd: Option<f64>,
    /// The increase allowed: 3 * sqrt(sd_old^2 + sd_new^2), 0 for memory.
    pub threshold: f64,
}

impl Regression {
    /// One line for stdout and results.md.
    pub fn line(&self) -> String {
        let decimals = if self.metric == "memory_bytes" { 0 } else { 3 };
        let sd = |sd: Option<f64>| sd.map_or(String::new(), |sd| format!(" ± {sd:.decimals$}"));
        format!(
            "{}/{} {}: {:.decimals$}{} -> {:.decimals$}{} (+{:.decimals$}, allowed +{:.decimals$})",
            self.scene,
            self.tier,
            self.metric,
            self.old_mean,
            sd(self.old_sd),
            self.new_mean,
            sd(self.new_sd),
            self.new_mean - self.old_mean,
            self.threshold,
        )
    }
}

/// The verdict on one metric of one cell.
#[derive(Debug, PartialEq)]
pub enum Verdict {
    Fine,
    /// Worse by more than the allowed increase (which it carries).
    Regressed(f64),
    /// Not comparable, and why.
    NoSpread,
}

/// Applies the rule to one metric: `deterministic` metrics regress on any increase.
pub fn judge(old: &Stat, new: &Stat, deterministic: bool) -> Verdict {
    let threshold = if deterministic {
        0.0
    } else {
        match (old.sd, new.sd) {
            (Some(old_sd), Some(new_sd)) => SIGMAS * old_sd.hypot(new_sd),
            _ => return Verdict::NoSpread,
        }
    };
    if new.mean - old.mean > threshold {
        Verdict::Regressed(threshold)
    } else {
        Verdict::Fine
    }
}

/// A compared metric: its name, where a cell keeps it, and whether it is deterministic.
type Metric = (&'static str, fn(&Cell) -> Option<&Stat>, bool);

/// Compares every cell both runs finished.
pub fn compare(baseline_path: &str, old: &Results, new: &Results) -> Comparison {
    let mut comparison = Comparison {
        baseline: baseline_path.to_owned(),
        baseline_commit: old.commit.clone(),
        baseline_date: old.date.clone(),
        rule: RULE.to_owned(),
        option_differences: option_differences(old, new),
        compared: 0,
        not_compared: Vec::new(),
        flagged: Vec::new(),
    };
    for cell in new.cells.iter().filter(|c| c.is_complete()) {
        let Some(old_cell) = old
            .cells
            .iter()
            .find(|c| c.scene == cell.scene && c.tier == cell.tier && c.is_complete())
        else {
            comparison.not_compared.push(format!(
                "{}/{}: not in the baseline (or failed there)",
                cell.scene, cell.tier
            ));
            continue;
        };
        let metrics: [Metric; 4] = [
            ("rmse_srgb8", |c| c.rmse_srgb8.as_ref(), false),
            ("flip", |c| c.flip.as_ref(), false),
            ("ms_per_frame", |c| c.ms_per_frame.as_ref(), false),
            ("memory_bytes", |c| c.memory_bytes.as_ref(), true),
        ];
        for (metric, get, deterministic) in metrics {
            let (Some(old_stat), Some(new_stat)) = (get(old_cell), get(cell)) else {
                continue;
            };
            match judge(old_stat, new_stat, deterministic) {
                Verdict::Fine => comparison.compared += 1,
                Verdict::Regressed(threshold) => {
                    comparison.compared += 1;
                    comparison.flagged.push(Regression {
                        scene: cell.scene.clone(),
                        tier: cell.tier.clone(),
                        metric: metric.to_owned(),
                        old_mean: old_stat.mean,
                        old_sd: old_stat.sd,
                        new_mean: new_stat.mean,
                        new_sd: new_stat.sd,
                        threshold,
                    });
                }
                Verdict::NoSpread => comparison.not_compared.push(format!(
                    "{}/{} {metric}: one repeat on one side, no spread to judge by",
                    cell.scene, cell.tier
                )),
            }
        }
    }
    comparison
}

/// The options that differ between the runs and change what a metric means.
fn option_differences(old: &Results, new: &Results) -> Vec<String> {
    let (o, n) = (&old.options, &new.options);
    let mut differences = Vec::new();
    let mut check = |name: &str, old: String, new: String| {
        if old != new {
            differences.push(format!("{name}: {old} -> {new}"));
        }
    };
    check(
        "size",
        format!("{}x{}", o.width, o.height),
        format!("{}x{}", n.width, n.height),
    );
    check("frames", o.frames.to_string(), n.frames.to_string());
    check(
        "cpu_frames",
        o.cpu_frames.to_string(),
        n.cpu_frames.to_string(),
    );
    check(
        "warmup",
        format!("{:?}", o.warmup),
        format!("{:?}", n.warmup),
    );
    check("spp", o.spp.to_string(), n.spp.to_string());
    check(
        "reference_spp",
        o.reference_spp.to_string(),
        n.reference_spp.to_string(),
    );
    let adapter = |r: &Results| r.adapter.as_ref().map_or("none".into(), |a| a.describe());
    check("adapter", adapter(old), adapter(new));
    differences
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stat(values: &[f64]) -> Stat {
        Stat::of(values.to_vec()).unwrap()
    }

    #[test]
    fn a_change_within_three_sigma_of_the_difference_is_fine() {
        // sd 1 on both sides: the allowed increase is 3 * sqrt(2) = 4.24.
        let old = stat(&[9.0, 10.0, 11.0]);
        assert_eq!(
            judge(&old, &stat(&[13.0, 14.0, 15.0]), false),
            Verdict::Fine
        );
        let Verdict::Regressed(threshold) = judge(&old, &stat(&[14.0, 15.0, 16.0]), false) else {
            panic!("an increase of 5 > 4.24 regresses");
        };
        assert!((threshold - 3.0 * 2f64.sqrt()).abs() < 1e-12);
        // Getting better by any amount is fine.
        assert_eq!(judge(&old, &stat(&[0.0, 1.0, 2.0]), false), Verdict::Fine);
    }

    #[test]
    fn memory_regresses_on_any_increase_and_one_repeat_has_no_spread() {
        let old = stat(&[1000.0, 1000.0]);
        assert_eq!(
            judge(&old, &stat(&[1001.0, 1001.0]), true),
            Verdict::Regressed(0.0)
        );
        assert_eq!(judge(&old, &stat(&[1000.0, 1000.0]), true), Verdict::Fine);
        assert_eq!(
            judge(&stat(&[5.0]), &stat(&[50.0, 51.0]), false),
            Verdict::NoSpread
        );
    }
}
