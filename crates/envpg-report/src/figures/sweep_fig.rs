//! The sweep figure: final J, estimator variance and bias against the swept setting.

use std::path::{Path, PathBuf};

use envpg_ac::study::EstimatorStats;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Drawn, Figure, colour, draw_legend, save, text};
use crate::ReportError;
use crate::stats::{mean, std};
use crate::sweep::{KINDS, SweepRow, kind_name};

/// A statistic of one estimator.
type Stat = fn(&EstimatorStats) -> f64;

struct Sweep<'a> {
    param: &'a str,
    values: &'a [String],
    rows: &'a [SweepRow],
}

impl Sweep<'_> {
    /// Per value index: the rows at that value.
    fn at(&self, i: usize) -> impl Iterator<Item = &SweepRow> {
        self.rows.iter().filter(move |r| r.value == self.values[i])
    }

    /// Per estimator: (value index, mean of `f`) where defined.
    fn estimator_means(&self, f: Stat) -> Vec<Vec<(f64, f64)>> {
        KINDS
            .iter()
            .map(|&k| {
                (0..self.values.len())
                    .filter_map(|i| {
                        let v: Vec<f64> = self.at(i).filter_map(|r| r.of(k).map(f)).filter(|x| x.is_finite()).collect();
                        (!v.is_empty()).then(|| (i as f64, mean(&v)))
                    })
                    .collect()
            })
            .collect()
    }
}

fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) =
        values.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let pad = 0.08 * (hi - lo).max(1e-3 * hi.abs().max(1e-9));
    lo - pad..hi + pad
}

impl Figure for Sweep<'_> {
    fn size(&self) -> (u32, u32) {
        (1500, 500)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, 3));
        let n = self.values.len();
        let xr = -0.5..n as f64 - 0.5;
        let label = |x: &f64| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                self.values[i as usize].clone()
            } else {
                String::new()
            }
        };
        // (a) final J per seed and mean ± std.
        let js: Vec<Vec<f64>> = (0..n).map(|i| self.at(i).filter_map(|r| r.j).collect()).collect();
        // Runs with an improper greedy policy (J = ∞) cannot be drawn; the caption counts them.
        let improper = self.rows.iter().filter(|r| r.j.is_none()).count();
        let caption = match improper {
            0 => format!("Final J vs {}", self.param),
            k => format!("Final J vs {} ({k} runs with J = ∞ not shown)", self.param),
        };
        let mut chart = ChartBuilder::on(&areas[0])
            .caption(caption, text(16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(xr.clone(), range(js.iter().flatten().copied()))?;
        chart
            .configure_mesh()
            .x_labels(n)
            .x_label_formatter(&label)
            .x_desc(self.param)
            .y_desc("final exact J")
            .label_style(text(12))
            .axis_desc_style(text(13))
            .light_line_style(WHITE.mix(0.0))
            .draw()?;
        chart.draw_series(
            js.iter()
                .enumerate()
                .flat_map(|(i, v)| v.iter().map(move |&j| Circle::new((i as f64, j), 3, colour(7).mix(0.6).filled()))),
        )?;
        let means: Vec<(f64, f64, f64)> =
            js.iter().enumerate().filter(|(_, v)| !v.is_empty()).map(|(i, v)| (i as f64, mean(v), std(v))).collect();
        chart.draw_series(LineSeries::new(means.iter().map(|m| (m.0, m.1)), colour(0).stroke_width(2)))?;
        for &(x, m, s) in &means {
            chart.draw_series([
                PathElement::new(vec![(x, m - s), (x, m + s)], colour(0).stroke_width(2)),
                PathElement::new(vec![(x - 0.08, m - s), (x + 0.08, m - s)], colour(0).stroke_width(2)),
                PathElement::new(vec![(x - 0.08, m + s), (x + 0.08, m + s)], colour(0).stroke_width(2)),
            ])?;
        }
        // (b) log10 variance and (c) relative bias of every estimator.
        let panels: [(&str, &str, Stat); 2] = [
            ("ζ-gradient estimate: variance", "log10 trace of covariance", |e| e.variance.max(1e-300).log10()),
            ("ζ-gradient estimate: bias", "‖mean − exact‖ / ‖exact‖", |e| e.rel_bias),
        ];
        for (area, (title, desc, f)) in areas[1..].iter().zip(panels) {
            let series = self.estimator_means(f);
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{title} vs {}", self.param), text(16))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(56)
                .build_cartesian_2d(xr.clone(), range(series.iter().flatten().map(|p| p.1)))?;
            chart
                .configure_mesh()
                .x_labels(n)
                .x_label_formatter(&label)
                .x_desc(self.param)
                .y_desc(desc)
                .label_style(text(12))
                .axis_desc_style(text(13))
                .light_line_style(WHITE.mix(0.0))
                .draw()?;
            for (j, (k, pts)) in KINDS.iter().zip(&series).enumerate() {
                let c = colour(j);
                chart
                    .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))?
                    .label(kind_name(*k))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))?;
            }
            draw_legend(&mut chart, 12)?;
        }
        Ok(())
    }
}

/// Final J (per seed, mean ± std), and the variance and bias of every ζ-gradient estimator,
/// against the swept values (in the order given). Writes `stem.svg` and `stem.png` in `dir`.
pub fn sweep(
    param: &str,
    values: &[String],
    rows: &[SweepRow],
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    save(&Sweep { param, values, rows }, dir, stem)
}
