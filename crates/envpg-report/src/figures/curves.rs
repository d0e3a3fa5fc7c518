//! Per-iteration curves: the ζ-gradient norm (Figure 1 c) and learning curves, one curve or
//! panel per labelled group of runs (a table column).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use envpg_core::ResultFile;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Drawn, Figure, colour, draw_legend, grid, save, text};
use crate::ReportError;
use crate::stats::{mean, moving_average};

/// Mean over runs of a per-iteration quantity: (k, mean) for every k some run recorded.
fn mean_series(runs: &[&ResultFile], get: impl Fn(&envpg_core::result::HistoryRow) -> Option<f64>) -> Vec<(f64, f64)> {
    let mut at: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for r in runs {
        for h in r.history.as_deref().unwrap_or(&[]) {
            if let Some(v) = get(h).filter(|v| v.is_finite()) {
                at.entry(h.k).or_default().push(v);
            }
        }
    }
    at.into_iter().map(|(k, v)| (k as f64, mean(&v))).collect()
}

fn smooth(series: &[(f64, f64)], window: usize) -> Vec<(f64, f64)> {
    let ys: Vec<f64> = series.iter().map(|p| p.1).collect();
    series.iter().zip(moving_average(&ys, window)).map(|(p, y)| (p.0, y)).collect()
}

fn x_end(runs: &[&ResultFile]) -> f64 {
    runs.iter().flat_map(|r| r.history.as_deref().unwrap_or(&[]).last()).map(|h| h.k as f64).fold(1.0, f64::max)
}

/// One group's curve: its label, raw points, moving average, number of runs averaged.
struct Curve {
    label: String,
    raw: Vec<(f64, f64)>,
    ma: Vec<(f64, f64)>,
    runs: usize,
}

struct GradNorm<'a> {
    groups: &'a [(String, Vec<&'a ResultFile>)],
    window: usize,
}

impl Figure for GradNorm<'_> {
    fn size(&self) -> (u32, u32) {
        (900, 520)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let series: Vec<Curve> = self
            .groups
            .iter()
            .map(|(k, runs)| {
                let raw = mean_series(runs, |h| h.grad_norm);
                let ma = smooth(&raw, self.window);
                Curve { label: k.clone(), raw, ma, runs: runs.len() }
            })
            .collect();
        let ma_max = series.iter().flat_map(|s| s.ma.iter().map(|p| p.1)).fold(0.0, f64::max);
        let mut raw_all: Vec<f64> = series.iter().flat_map(|s| s.raw.iter().map(|p| p.1)).collect();
        raw_all.sort_by(f64::total_cmp);
        let p99 = raw_all.get(raw_all.len() * 99 / 100).copied().unwrap_or(1.0);
        let top = (1.15 * ma_max).max(p99).max(1e-12);
        let runs: Vec<&ResultFile> = self.groups.iter().flat_map(|g| g.1.iter().copied()).collect();
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("‖ζ-gradient estimate‖ per iteration (moving average over {} iterations)", self.window),
                text(17),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..x_end(&runs), 0.0..top)?;
        chart
            .configure_mesh()
            .x_desc("iteration k")
            .y_desc("‖ĝ_ζ‖")
            .label_style(text(12))
            .axis_desc_style(text(14))
            .light_line_style(WHITE.mix(0.0))
            .draw()?;
        for (i, Curve { label: k, raw, ma, runs: n }) in series.iter().enumerate() {
            let c = colour(i);
            chart.draw_series(LineSeries::new(raw.iter().map(|&(x, y)| (x, y.min(top))), c.mix(0.18)))?;
            let label = if *n > 1 { format!("{k} (mean of {n} seeds)") } else { k.clone() };
            chart
                .draw_series(LineSeries::new(ma.iter().copied(), c.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        }
        draw_legend(&mut chart, 13)?;
        Ok(())
    }
}

/// ‖ζ-gradient estimate‖ per iteration, one curve per labelled group of runs (their mean), raw
/// (faint) and as a trailing moving average over `window` iterations. Writes `stem.svg` and
/// `stem.png` in `dir`.
pub fn grad_norm(
    groups: &[(String, Vec<&ResultFile>)],
    window: usize,
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    save(&GradNorm { groups, window }, dir, stem)
}

struct Learning<'a> {
    groups: &'a [(String, Vec<&'a ResultFile>)],
    oracle: &'a [(String, &'a ResultFile)],
    window: usize,
}

impl Figure for Learning<'_> {
    fn size(&self) -> (u32, u32) {
        let (rows, cols) = grid(self.groups.len(), 2);
        (640 * cols as u32, 440 * rows as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        for (area, (label, runs)) in root.split_evenly(grid(self.groups.len(), 2)).iter().zip(self.groups) {
            let oracle_j = self.oracle.iter().find(|(k, _)| k == label).and_then(|(_, r)| r.j);
            learning_panel(area, label, runs, oracle_j, self.window)?;
        }
        Ok(())
    }
}

fn learning_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    label: &str,
    runs: &[&ResultFile],
    oracle_j: Option<f64>,
    window: usize,
) -> Drawn
where
    DB::ErrorType: 'static,
{
    let end = x_end(runs);
    let exact: Vec<(u64, Vec<(f64, f64)>)> = runs
        .iter()
        .map(|r| {
            let pts =
                r.history.as_deref().unwrap_or(&[]).iter().filter_map(|h| Some((h.k as f64, h.j_exact?))).collect();
            (r.seed, pts)
        })
        .collect();
    let j_h = smooth(&mean_series(runs, |h| h.j_h_estimate), window);
    // The early, hot iterations dwarf everything after: scale the axis to the last 75%, at
    // most 60% above the lowest value, and pin what lies above to the top edge.
    let late = |x: f64| x >= 0.25 * end;
    let values: Vec<f64> = exact
        .iter()
        .flat_map(|(_, p)| p.iter())
        .chain(j_h.iter())
        .filter(|p| late(p.0) && p.1.is_finite())
        .map(|p| p.1)
        .chain(oracle_j)
        .collect();
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() { (lo, hi.min(lo + 0.6 * lo.abs())) } else { (0.0, 1.0) };
    let pad = 0.05 * (hi - lo).max(1e-3 * hi.abs().max(1.0));
    let (lo, hi) = (lo - pad, hi + pad);
    let clamp = |p: &(f64, f64)| (p.0, p.1.clamp(lo, hi));
    let mut chart = ChartBuilder::on(area)
        .caption(format!("Learning curves · {label}"), text(16))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(52)
        .build_cartesian_2d(0.0..end, lo..hi)?;
    chart
        .configure_mesh()
        .x_desc("iteration k")
        .y_desc("J")
        .label_style(text(11))
        .axis_desc_style(text(13))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (i, (seed, pts)) in exact.iter().enumerate() {
        let c = colour(i);
        chart
            .draw_series(LineSeries::new(pts.iter().map(clamp), c.mix(0.8).stroke_width(1)))?
            .label(format!("exact J(ζ_k, greedy π_k), seed {seed}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
    }
    let grey = RGBColor(60, 60, 60);
    chart
        .draw_series(LineSeries::new(j_h.iter().map(clamp), grey.stroke_width(2)))?
        .label(format!("J_H estimate (mean of seeds, MA {window})"))
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], grey.stroke_width(2)));
    if let Some(j) = oracle_j {
        chart
            .draw_series(DashedLineSeries::new([(0.0, j), (end, j)], 8, 5, BLACK.stroke_width(2)))?
            .label(format!("oracle, best J = {j:.3}"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(2)));
    }
    draw_legend(&mut chart, 11)?;
    Ok(())
}

/// Learning curves, one panel per labelled group of runs: exact J of (ζ_k, greedy π_k) per run
/// (recorded every few iterations for reporting), the J_H estimate (mean over runs, moving
/// average), and the oracle's J from `oracle` (label, result) as a dashed line. Writes
/// `stem.svg` and `stem.png`.
pub fn learning_curves(
    groups: &[(String, Vec<&ResultFile>)],
    oracle: &[(String, &ResultFile)],
    window: usize,
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    save(&Learning { groups, oracle, window }, dir, stem)
}
