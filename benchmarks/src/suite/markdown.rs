//! `results.md`: the suite's tables in the form of the HSGI comparison, ready to paste into a
//! results page, and the scene x tier table printed at the end of a run.

use std::fmt::Write;

use super::{
    regress::{self, Comparison},
    results::{Cell, Results, Stat},
};

/// Bytes per MB in the tables (10^6, the unit of the memory bars).
const MB: f64 = 1e6;

/// The scene x tier table: rmse_srgb8, mean FLIP, gain_vs_direct, ms per frame, GI ms and
/// memory, each as mean ± sample standard deviation over the repeats.
pub fn scene_tier_table(results: &Results) -> String {
    let mut out = String::from(
        "| scene | tier | rmse_srgb8 | flip | gain_vs_direct | ms/frame | GI ms | memory MB |\n\
         |---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for cell in &results.cells {
        let stat = |s: &Option<Stat>, decimals: usize| {
            s.as_ref().map_or("-".to_owned(), |s| s.format(decimals))
        };
        let memory = cell
            .memory_bytes
            .as_ref()
            .map_or("-".to_owned(), |m| format!("{:.2}", m.mean / MB));
        let ms = match (&cell.ms_per_frame, cell.on_cpu) {
            (Some(ms), Some(true)) => format!("{} (CPU)", ms.format(2)),
            (ms, _) => stat(ms, 3),
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {ms} | {} | {memory} |",
            cell.scene,
            tier_label(cell),
            stat(&cell.rmse_srgb8, 2),
            stat(&cell.flip, 4),
            stat(&cell.gain_vs_direct, 3),
            stat(&cell.gi_ms, 3),
        );
    }
    out
}

/// `mobile`, or `mobile (failed)` / `mobile (2 of 3 repeats)` when not every repeat finished.
fn tier_label(cell: &Cell) -> String {
    match (&cell.error, cell.repeats) {
        (None, _) => cell.tier.clone(),
        (Some(_), 0) => format!("{} (failed)", cell.tier),
        (Some(_), done) => format!("{} ({done} repeats finished, then failed)", cell.tier),
    }
}

/// The per-pass table of `tier`: a row per pass (in first-seen order over the scenes), a
/// column per scene, each the mean over the repeats of the pass's median ms.
pub fn pass_table(results: &Results, tier: &str) -> Option<String> {
    let (cells, passes) = results.pass_cells(tier)?;
    let mut out = String::from("| pass |");
    let mut rule = String::from("|---|");
    for cell in &cells {
        let _ = write!(out, " {} |", cell.scene);
        rule += "---:|";
    }
    out += "\n";
    out += &rule;
    out += "\n";
    for pass in passes {
        let _ = write!(out, "| {pass} |");
        for cell in &cells {
            match cell.passes_ms.iter().find(|p| p.name == pass) {
                Some(p) => {
                    let _ = write!(out, " {:.3} |", p.ms.mean);
                }
                None => out += " - |",
            }
        }
        out += "\n";
    }
    out += "| **frame** |";
    for cell in &cells {
        let ms = cell.ms_per_frame.as_ref().map_or(0.0, |s| s.mean);
        let _ = write!(out, " **{ms:.3}** |");
    }
    out += "\n";
    Some(out)
}

/// The whole results.md.
pub fn document(results: &Results) -> String {
    let o = &results.options;
    let adapter = results
        .adapter
        .as_ref()
        .map_or("no GPU adapter".to_owned(), |a| a.describe());
    let warmup = o
        .warmup
        .map_or("each tier's default still warm-up".to_owned(), |w| {
            format!("{w} still warm-up frames")
        });
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Benchmark suite\n\n\
         Commit `{}`, {adapter}, {} CPUs, {}.\n\n\
         Command: `{}`\n\n\
         {}x{}, default camera; per tier {warmup}, then {} measured frames ({} for tiers on \
         the CPU, which keep no history) at {} spp per frame; each cell is the mean ± sample \
         standard deviation over {} repeats (a fresh renderer each, seed = repeat + 1) of the \
         last frame's error and of the median over the measured frames of the time. Errors \
         are against a path-traced reference of {} spp at the last frame's time (rendered by \
         `--reference-engine {}`: the table of references says on what); rmse_srgb8 is in \
         8-bit sRGB levels (0..255), flip is NVIDIA's mean FLIP (LDR, 67 pixels per degree: \
         how visible the difference is, 0..1) on the same 8-bit images; gain_vs_direct = \
         rmse_srgb8 / the direct-only rmse_srgb8 of the same repeat (lower is better). GI ms \
         is the sum of the tier's GI passes (`cache/*` with `mobile/*` or `pc/*`); tiers that \
         compute the whole image as one transport have none. Memory: bytes the tier owns \
         after the last frame, in MB of 10^6 bytes.\n",
        results.commit,
        results.cpu_count,
        results.date,
        results.command.join(" "),
        o.width,
        o.height,
        o.frames,
        o.cpu_frames.min(o.frames),
        o.spp,
        o.repeats,
        o.reference_spp,
        o.reference_engine,
    );
    out += "## Scenes x tiers\n\n";
    out += &scene_tier_table(results);
    out += "\n## Per-pass cost (median ms per frame)\n\n";
    for tier in &o.tiers {
        if let Some(table) = pass_table(results, tier) {
            let _ = writeln!(out, "### {tier}\n\n{table}");
        }
    }
    out += "## References\n\n| scene | spp | scene time s | render s | cached | engine |\n\
            |---|---:|---:|---:|---|---|\n";
    for r in &results.references {
        let _ = writeln!(
            out,
            "| {} | {} | {:.3} | {:.1} | {} | {} |",
            r.scene, r.spp, r.time_s, r.seconds, r.cached, r.engine
        );
    }
    if let Some(comparison) = &results.regressions {
        out += "\n";
        out += &regression_section(comparison);
    }
    if !results.failures.is_empty() {
        out += "\n## Failures\n\n";
        for f in &results.failures {
            let what = match &f.tier {
                Some(tier) => format!("{}/{tier}", f.scene),
                None => f.scene.clone(),
            };
            let _ = writeln!(out, "- {what}: {}", f.error.replace('\n', " "));
        }
    }
    out
}

/// The regression section: the rule, the baseline, the flagged metrics.
pub fn regression_section(c: &Comparison) -> String {
    let mut out = format!(
        "## Regressions against `{}`\n\nBaseline: commit `{}`, {}. Rule: {}.\n\n",
        c.baseline,
        c.baseline_commit,
        c.baseline_date,
        regress::RULE
    );
    if !c.option_differences.is_empty() {
        let _ = writeln!(
            out,
            "The runs differ in: {}; the comparison means less.\n",
            c.option_differences.join("; ")
        );
    }
    if c.flagged.is_empty() {
        let _ = writeln!(out, "No regression in {} metric comparisons.", c.compared);
    } else {
        let _ = writeln!(
            out,
            "{} of {} metric comparisons regressed:\n",
            c.flagged.len(),
            c.compared
        );
        for r in &c.flagged {
            let _ = writeln!(out, "- {}", r.line());
        }
    }
    if !c.not_compared.is_empty() {
        let _ = writeln!(out, "\nNot compared: {}.", c.not_compared.join("; "));
    }
    out
}
