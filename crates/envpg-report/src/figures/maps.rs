//! Map figures: placements and routing (Figure 1 a/b), and ζ trajectories over training.

use std::path::{Path, PathBuf};

use envpg_core::ResultFile;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Drawn, Figure, Panel, colour, draw_legend, grid, save, text};
use crate::ReportError;

const PANEL: u32 = 520;

/// Index of the largest entry (the greedy action of a policy row).
fn argmax(row: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in row.iter().enumerate() {
        if x > row[best] {
            best = i;
        }
    }
    best
}

fn uav(zeta: &[f64], j: usize) -> (f64, f64) {
    (zeta[2 * j], zeta[2 * j + 1])
}

/// A square window around every point, with a margin.
fn window(points: impl Iterator<Item = (f64, f64)>) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for (x, y) in points.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if !x0.is_finite() {
        return (0.0..1.0, 0.0..1.0);
    }
    let half = 0.5 * (x1 - x0).max(y1 - y0).max(1e-9) * 1.08;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    (cx - half..cx + half, cy - half..cy + half)
}

/// The UAVs some user's greedy route passes through.
fn used_uavs(r: &ResultFile) -> Vec<bool> {
    let n = r.instance.n_users();
    let m = r.instance.n_uav;
    let mut used = vec![false; m];
    for u in 0..n {
        let mut j = argmax(&r.policy[u][..m]);
        // Follow the greedy chain; at most M hops without a loop.
        for _ in 0..m {
            if used[j] {
                break;
            }
            used[j] = true;
            let next = argmax(&r.policy[n + j]);
            if next == m {
                break;
            }
            j = next;
        }
    }
    used
}

/// An arrow from `a` to `b` (head length `head` in data units).
fn arrow(a: (f64, f64), b: (f64, f64), head: f64) -> Vec<Vec<(f64, f64)>> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = (dx * dx + dy * dy).sqrt().max(1e-12);
    let (ux, uy) = (dx / len, dy / len);
    let wing = |s: f64| {
        let (c, sn) = (0.93f64, 0.36 * s);
        (b.0 - head * (c * ux - sn * uy), b.1 - head * (sn * ux + c * uy))
    };
    vec![vec![a, b], vec![wing(1.0), b, wing(-1.0)]]
}

struct Placements<'a> {
    cells: &'a [Option<Panel<'a>>],
    cols: usize,
}

impl Figure for Placements<'_> {
    fn size(&self) -> (u32, u32) {
        let rows = self.cells.len().div_ceil(self.cols.max(1));
        (PANEL * self.cols.max(1) as u32, PANEL * rows.max(1) as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let rows = self.cells.len().div_ceil(self.cols.max(1));
        for (area, cell) in root.split_evenly((rows.max(1), self.cols.max(1))).iter().zip(self.cells) {
            if let Some(p) = cell {
                placement(area, p)?;
            }
        }
        Ok(())
    }
}

fn placement<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &Panel) -> Drawn
where
    DB::ErrorType: 'static,
{
    let r = p.result;
    let n = r.instance.n_users();
    let m = r.instance.n_uav;
    let dest = (r.instance.dest[0], r.instance.dest[1]);
    let pts = r.instance.users.iter().map(|u| (u[0], u[1])).chain((0..m).map(|j| uav(&r.zeta, j))).chain([dest]);
    let (xr, yr) = window(pts);
    let head = 0.03 * (xr.end - xr.start);
    let mut chart = ChartBuilder::on(area)
        .caption(p.title, text(15))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(36)
        .build_cartesian_2d(xr, yr)?;
    chart.configure_mesh().disable_mesh().x_labels(5).y_labels(5).label_style(text(12)).draw()?;
    chart.draw_series(r.instance.users.iter().enumerate().map(|(u, xy)| {
        let c = colour(argmax(&r.policy[u][..m]));
        Circle::new((xy[0], xy[1]), 2, c.mix(0.75).filled())
    }))?;
    let used = used_uavs(r);
    for j in 0..m {
        let next = argmax(&r.policy[n + j]);
        let to = if next == m { dest } else { uav(&r.zeta, next) };
        let style = if used[j] { BLACK.stroke_width(2) } else { BLACK.mix(0.25).stroke_width(1) };
        for path in arrow(uav(&r.zeta, j), to, head) {
            chart.draw_series(std::iter::once(PathElement::new(path, style)))?;
        }
    }
    chart.draw_series(std::iter::once(Rectangle::new(
        [(dest.0 - 0.4 * head, dest.1 - 0.4 * head), (dest.0 + 0.4 * head, dest.1 + 0.4 * head)],
        BLACK.filled(),
    )))?;
    // Labels sit above-left of their marker: the routes run towards the destination, so
    // that side is usually free.
    chart.draw_series(std::iter::once(Text::new("dest", (dest.0 - 2.2 * head, dest.1 + 1.6 * head), text(12))))?;
    for j in 0..m {
        let xy = uav(&r.zeta, j);
        // A black triangle under a smaller coloured one: a marker with an outline.
        chart.draw_series([
            TriangleMarker::new(xy, 11, BLACK.filled()),
            TriangleMarker::new(xy, 8, colour(j).filled()),
        ])?;
        chart.draw_series(std::iter::once(Text::new(
            format!("U{}", j + 1),
            (xy.0 - 1.3 * head, xy.1 + 1.5 * head),
            text(13),
        )))?;
    }
    Ok(())
}

/// Placements and routing: one panel per cell of a grid `cols` wide (None leaves a cell
/// empty). Writes `stem.svg` and `stem.png` in `dir`.
pub fn placements(cells: &[Option<Panel>], cols: usize, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, ReportError> {
    save(&Placements { cells, cols }, dir, stem)
}

struct Trajectories<'a> {
    panels: &'a [Panel<'a>],
    designs: &'a [&'a ResultFile],
}

impl Figure for Trajectories<'_> {
    fn size(&self) -> (u32, u32) {
        let (rows, cols) = grid(self.panels.len(), 4);
        (PANEL * cols as u32, PANEL * rows as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        for (area, p) in root.split_evenly(grid(self.panels.len(), 4)).iter().zip(self.panels) {
            let design = self.designs.iter().find(|d| d.kappa == p.result.kappa && d.instance == p.result.instance);
            trajectory(area, p, design.copied())?;
        }
        Ok(())
    }
}

fn trajectory<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &Panel, design: Option<&ResultFile>) -> Drawn
where
    DB::ErrorType: 'static,
{
    let r = p.result;
    let m = r.instance.n_uav;
    let history = r.history.as_deref().unwrap_or(&[]);
    // A few hundred points per path are plenty on a 500-pixel panel.
    let stride = history.len().div_ceil(400).max(1);
    let path: Vec<&[f64]> =
        history.iter().step_by(stride).map(|h| h.zeta.as_slice()).chain([r.zeta.as_slice()]).collect();
    let dest = (r.instance.dest[0], r.instance.dest[1]);
    let pts = r
        .instance
        .users
        .iter()
        .map(|u| (u[0], u[1]))
        .chain(path.iter().flat_map(|z| (0..m).map(|j| uav(z, j))))
        .chain([dest]);
    let (xr, yr) = window(pts);
    let head = 0.03 * (xr.end - xr.start);
    let mut chart = ChartBuilder::on(area)
        .caption(format!("ζ over training · {}", p.title), text(14))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(36)
        .build_cartesian_2d(xr, yr)?;
    chart.configure_mesh().disable_mesh().x_labels(5).y_labels(5).label_style(text(11)).draw()?;
    chart
        .draw_series(r.instance.users.iter().map(|u| Circle::new((u[0], u[1]), 2, RGBColor(190, 190, 190).filled())))?;
    chart.draw_series(std::iter::once(Rectangle::new(
        [(dest.0 - 0.4 * head, dest.1 - 0.4 * head), (dest.0 + 0.4 * head, dest.1 + 0.4 * head)],
        BLACK.filled(),
    )))?;
    for j in 0..m {
        let c = colour(j);
        chart
            .draw_series(LineSeries::new(path.iter().map(|z| uav(z, j)), c.stroke_width(2)))?
            .label(format!("U{}", j + 1))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
        chart.draw_series([
            Circle::new(uav(&r.zeta0, j), 5, c.stroke_width(2)),
            Circle::new(uav(&r.zeta0, j), 5, c.mix(0.3).filled()),
        ])?;
        let end = uav(&r.zeta, j);
        chart.draw_series([TriangleMarker::new(end, 11, BLACK.filled()), TriangleMarker::new(end, 8, c.filled())])?;
    }
    if let Some(d) = design {
        chart
            .draw_series((0..m).map(|j| Cross::new(uav(&d.zeta, j), 6, BLACK.stroke_width(2))))?
            .label("oracle design")
            .legend(|(x, y)| Cross::new((x + 8, y), 5, BLACK.stroke_width(2)));
    }
    draw_legend(&mut chart, 11)?;
    Ok(())
}

/// ζ trajectories over training (○ ζ₀, ▲ the reported ζ, × the oracle design at the same κ when one
/// of `designs` matches); one panel per run. Writes `stem.svg` and `stem.png` in `dir`.
pub fn trajectories(
    panels: &[Panel],
    designs: &[&ResultFile],
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    save(&Trajectories { panels, designs }, dir, stem)
}
