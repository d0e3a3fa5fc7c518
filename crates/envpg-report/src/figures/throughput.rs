//! The throughput figure: a training run's transitions/s against its number of worker
//! processes, as the model of `envpg-launch --bench` predicts it, with what the benchmark
//! measured beside it.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Drawn, Figure, colour, draw_legend, save, text};
use crate::ReportError;

/// One curve of the figure: predicted transitions/s per worker count, and measured points.
#[derive(Debug, Clone)]
pub struct ThroughputCurve {
    /// Legend label.
    pub label: String,
    /// (workers, predicted transitions/s), drawn as a line.
    pub predicted: Vec<(usize, f64)>,
    /// (workers, measured transitions/s), drawn as points.
    pub measured: Vec<(usize, f64)>,
    /// (workers, transitions/s the model predicts on the cores of the machine that measured),
    /// drawn as crosses beside the measured points.
    pub predicted_there: Vec<(usize, f64)>,
}

struct Throughput<'a> {
    title: &'a str,
    curves: &'a [ThroughputCurve],
}

impl Figure for Throughput<'_> {
    fn size(&self) -> (u32, u32) {
        (900, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let all = || self.curves.iter().flat_map(|c| c.predicted.iter().chain(&c.measured).chain(&c.predicted_there));
        let max_w = all().map(|p| p.0).max().unwrap_or(1).max(2) as f64;
        let max_y = all().map(|p| p.1).fold(0.0, f64::max).max(1.0) * 1.1;
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, text(16))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.2..max_w.log2() + 0.2, 0.0..max_y)?;
        chart
            .configure_mesh()
            .x_labels(max_w.log2() as usize + 1)
            .x_label_formatter(&|x| {
                let k = x.round();
                if (x - k).abs() < 1e-6 && k >= 0.0 { format!("{}", 2f64.powf(k)) } else { String::new() }
            })
            .y_label_formatter(&|y| format!("{:.0} k", y / 1e3))
            .x_desc("worker processes")
            .y_desc("transitions / s")
            .label_style(text(12))
            .axis_desc_style(text(13))
            .light_line_style(WHITE.mix(0.0))
            .draw()?;
        let x = |w: usize| (w.max(1) as f64).log2();
        for (i, c) in self.curves.iter().enumerate() {
            let col = colour(i);
            chart
                .draw_series(LineSeries::new(c.predicted.iter().map(|&(w, y)| (x(w), y)), col.stroke_width(2)))?
                .label(c.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], col.stroke_width(2)));
            chart.draw_series(c.measured.iter().map(|&(w, y)| Circle::new((x(w), y), 5, col.filled())))?;
            chart.draw_series(c.predicted_there.iter().map(|&(w, y)| Cross::new((x(w), y), 6, col.stroke_width(2))))?;
        }
        draw_legend(&mut chart, 12)?;
        Ok(())
    }
}

/// Draws `curves` (lines: predicted; points: measured) under `title` into `dir/stem.svg` and
/// `dir/stem.png`.
pub fn throughput(
    title: &str,
    curves: &[ThroughputCurve],
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    save(&Throughput { title, curves }, dir, stem)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_figure_is_written_as_svg_and_png() {
        let dir = tempfile::tempdir().unwrap();
        let curves = [ThroughputCurve {
            label: "lag 1".into(),
            predicted: vec![(1, 10e3), (2, 18e3), (4, 30e3), (64, 34e3)],
            measured: vec![(1, 10.2e3), (2, 16e3)],
            predicted_there: vec![(1, 10e3), (2, 17e3)],
        }];
        let paths = throughput("model", &curves, dir.path(), "throughput").unwrap();
        assert_eq!(paths.len(), 2);
        let svg = std::fs::read_to_string(&paths[0]).unwrap();
        assert!(svg.contains("worker processes") && svg.contains("lag 1"), "{}", &svg[..svg.len().min(400)]);
        assert!(std::fs::metadata(&paths[1]).unwrap().len() > 1000);
    }
}
