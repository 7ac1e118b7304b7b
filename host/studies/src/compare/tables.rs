//! The comparison's markdown tables: one row per configuration over the seeds, and every
//! row as a ratio to the oracle's when the oracle has a row.

use super::{Row, Summary};
use crate::study::stats::Spread;
use trn_bench::format::px;

/// The markdown table of `rows`: each cell the mean ± the standard deviation over the seeds
/// and, in brackets, the worst seed; the last column the per-target tail.
pub fn table(rows: &[Row]) -> String {
    let mut out = String::new();
    out.push_str("| configuration | training trials | combined true px: coarse | after 1 fine | after 2 fine | after 6 fine | measured after 6 / noise floor px | fine moves to 2 px | fine moves, stop rule | true px where the stop rule stopped | simulated s per target, stop rule | grasp success % | failed trials | measured after 6 per target: p50 / p90 / max px | measured after 6, each seed's p95 / its floor |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let s = &r.summary;
        let at = |m: usize| s.combined_true_px.get(m).map_or("n/a".into(), Spread::cell);
        let last = s.combined_true_px.last().map_or("n/a".into(), Spread::cell);
        let mut grasp = s.grasp_success;
        for v in [&mut grasp.mean, &mut grasp.sd, &mut grasp.worst] {
            *v *= 100.0;
        }
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.name,
            r.seeds.first().map_or(0, |s| s.training_trials),
            at(0),
            at(1),
            at(2),
            last,
            s.measured_after_budget_px.cell(),
            px(s.noise_floor_px.mean),
            s.moves_to_2px.cell(),
            s.fine_moves_stop_rule.cell(),
            s.final_true_px_stop_rule.cell(),
            s.sim_s_per_target_stop_rule.cell(),
            grasp.cell(),
            s.failed_trials,
            s.measured_after_budget_by_target_px.cell(),
            s.measured_p95_over_floor.cell(),
        ));
    }
    if let Some(oracle) = rows.iter().find(|r| r.law == "oracle") {
        out.push('\n');
        out.push_str(&ratio_table(rows, oracle));
    }
    out
}

/// Every row's means as a ratio to the oracle's (the physical limit): 1.00 is as good as
/// possible on this plant; errors and moves above 1 are worse, grasp success below 1.
pub fn ratio_table(rows: &[Row], oracle: &Row) -> String {
    let o = &oracle.summary;
    let ratio = |a: f32, b: f32| {
        if a.is_finite() && b.is_finite() && b > 0.0 {
            format!("{:.2}", a / b)
        } else {
            "n/a".into()
        }
    };
    let at = |s: &Summary, m: usize| s.combined_true_px.get(m).map_or(f32::NAN, |v| v.mean);
    let last = |s: &Summary| s.combined_true_px.last().map_or(f32::NAN, |v| v.mean);
    let mut out = String::from("As a ratio to the oracle's mean (the physical limit on this plant; worst seed's value over the oracle's worst in brackets for the measured error):\n\n");
    out.push_str("| configuration | combined true: coarse | after 2 fine | after 6 fine | measured after 6 | measured after 6 per target p90 | fine moves, stop rule | true px where the stop rule stopped | simulated s per target | grasp success |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let s = &r.summary;
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} ({}) | {} | {} | {} | {} | {} |\n",
            r.name,
            ratio(at(s, 0), at(o, 0)),
            ratio(at(s, 2), at(o, 2)),
            ratio(last(s), last(o)),
            ratio(
                s.measured_after_budget_px.mean,
                o.measured_after_budget_px.mean
            ),
            ratio(
                s.measured_after_budget_px.worst,
                o.measured_after_budget_px.worst
            ),
            ratio(
                s.measured_after_budget_by_target_px.p90,
                o.measured_after_budget_by_target_px.p90
            ),
            ratio(s.fine_moves_stop_rule.mean, o.fine_moves_stop_rule.mean),
            ratio(
                s.final_true_px_stop_rule.mean,
                o.final_true_px_stop_rule.mean
            ),
            ratio(
                s.sim_s_per_target_stop_rule.mean,
                o.sim_s_per_target_stop_rule.mean
            ),
            ratio(s.grasp_success.mean, o.grasp_success.mean),
        ));
    }
    out
}
