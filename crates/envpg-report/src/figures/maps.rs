//! Map figures, drawn from each environment's [`Sketch`] of a design: the designs with their
//! policies (Figure 1 a/b — UAVs and routes, cluster centres and assignments, facilities and
//! routes), and ζ trajectories over training.

use std::path::{Path, PathBuf};

use envpg_core::policy::actions_from_rows;
use envpg_core::{Registry, ResultFile, Sketch};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Drawn, Figure, Panel, colour, draw_legend, grid, save, text};
use crate::ReportError;

const PANEL: u32 = 520;

/// The sketch of a result's design and greedy policy, if its environment draws one.
pub fn sketch_of(registry: &Registry, r: &ResultFile) -> Option<Sketch> {
    let env = r.load_env(registry, "<figure>").ok()?;
    let actions = actions_from_rows(env.sampler(), &r.policy);
    env.env.sketch(&r.zeta, &actions)
}

/// The sketch markers (design points) at every `zeta` of `path`, with the result's policy.
fn marker_paths(registry: &Registry, r: &ResultFile, path: &[&[f64]]) -> Vec<Vec<(f64, f64)>> {
    let Ok(env) = r.load_env(registry, "<figure>") else { return Vec::new() };
    let actions = actions_from_rows(env.sampler(), &r.policy);
    let per_step: Vec<Vec<[f64; 2]>> = path
        .iter()
        .filter_map(|z| env.env.sketch(z, &actions).map(|s| s.markers.iter().map(|m| m.xy).collect()))
        .collect();
    let n = per_step.first().map_or(0, Vec::len);
    (0..n).map(|j| per_step.iter().filter_map(|m| m.get(j)).map(|p| (p[0], p[1])).collect()).collect()
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

fn every_point(s: &Sketch) -> impl Iterator<Item = (f64, f64)> + '_ {
    s.points
        .iter()
        .map(|p| p.xy)
        .chain(s.markers.iter().map(|m| m.xy))
        .chain(s.landmarks.iter().map(|l| l.xy))
        .map(|p| (p[0], p[1]))
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

struct Designs<'a> {
    registry: &'a Registry,
    cells: &'a [Option<Panel<'a>>],
    cols: usize,
}

impl Figure for Designs<'_> {
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
                match sketch_of(self.registry, p.result) {
                    Some(s) => design(area, p.title, &s)?,
                    None => {
                        area.titled(
                            &format!("{} (environment `{}` draws no picture)", p.title, p.result.env),
                            text(14),
                        )?;
                    }
                }
            }
        }
        Ok(())
    }
}

fn design<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, title: &str, s: &Sketch) -> Drawn
where
    DB::ErrorType: 'static,
{
    let (xr, yr) = window(every_point(s));
    let head = 0.03 * (xr.end - xr.start);
    let mut chart = ChartBuilder::on(area)
        .caption(title, text(15))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(36)
        .build_cartesian_2d(xr, yr)?;
    chart.configure_mesh().disable_mesh().x_labels(5).y_labels(5).label_style(text(12)).draw()?;
    chart.draw_series(s.points.iter().map(|p| {
        let c = p.group.map_or(RGBColor(150, 150, 150), colour);
        Circle::new((p.xy[0], p.xy[1]), 2, c.mix(0.75).filled())
    }))?;
    for a in &s.arrows {
        let style = if a.strong { BLACK.stroke_width(2) } else { BLACK.mix(0.25).stroke_width(1) };
        for path in arrow((a.from[0], a.from[1]), (a.to[0], a.to[1]), head) {
            chart.draw_series(std::iter::once(PathElement::new(path, style)))?;
        }
    }
    // Labels sit above-left of their marker: routes mostly run the other way.
    for l in &s.landmarks {
        let (x, y) = (l.xy[0], l.xy[1]);
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - 0.4 * head, y - 0.4 * head), (x + 0.4 * head, y + 0.4 * head)],
            BLACK.filled(),
        )))?;
        chart.draw_series(std::iter::once(Text::new(l.label.clone(), (x - 2.2 * head, y + 1.6 * head), text(12))))?;
    }
    for (j, m) in s.markers.iter().enumerate() {
        let xy = (m.xy[0], m.xy[1]);
        // A black triangle under a smaller coloured one: a marker with an outline.
        chart.draw_series([
            TriangleMarker::new(xy, 11, BLACK.filled()),
            TriangleMarker::new(xy, 8, colour(j).filled()),
        ])?;
        chart.draw_series(std::iter::once(Text::new(
            m.label.clone(),
            (xy.0 - 1.3 * head, xy.1 + 1.5 * head),
            text(13),
        )))?;
    }
    Ok(())
}

/// Designs and policies: one panel per cell of a grid `cols` wide (None leaves a cell empty),
/// each drawn from its environment's sketch. Writes `stem.svg` and `stem.png` in `dir` — or
/// nothing when no result's environment draws a picture.
pub fn designs(
    registry: &Registry,
    cells: &[Option<Panel>],
    cols: usize,
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    if !cells.iter().flatten().any(|p| sketch_of(registry, p.result).is_some()) {
        return Ok(Vec::new());
    }
    save(&Designs { registry, cells, cols }, dir, stem)
}

struct Trajectories<'a> {
    registry: &'a Registry,
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
            let design = self.designs.iter().find(|d| d.instance == p.result.instance);
            trajectory(self.registry, area, p, design.copied())?;
        }
        Ok(())
    }
}

fn trajectory<DB: DrawingBackend>(
    registry: &Registry,
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    design: Option<&ResultFile>,
) -> Drawn
where
    DB::ErrorType: 'static,
{
    let r = p.result;
    let Some(sketch) = sketch_of(registry, r) else {
        area.titled(&format!("ζ over training · {} (no picture for `{}`)", p.title, r.env), text(14))?;
        return Ok(());
    };
    let history = r.history.as_deref().unwrap_or(&[]);
    // A few hundred points per path are plenty on a 500-pixel panel.
    let stride = history.len().div_ceil(400).max(1);
    let path: Vec<&[f64]> =
        history.iter().step_by(stride).map(|h| h.zeta.as_slice()).chain([r.zeta.as_slice()]).collect();
    let paths = marker_paths(registry, r, &path);
    let starts = marker_paths(registry, r, &[r.zeta0.as_slice()]);
    let oracle = design.map(|d| marker_paths(registry, d, &[d.zeta.as_slice()])).unwrap_or_default();
    let pts = sketch
        .points
        .iter()
        .map(|p| (p.xy[0], p.xy[1]))
        .chain(sketch.landmarks.iter().map(|l| (l.xy[0], l.xy[1])))
        .chain(paths.iter().flatten().copied());
    let (xr, yr) = window(pts);
    let head = 0.03 * (xr.end - xr.start);
    let mut chart = ChartBuilder::on(area)
        .caption(format!("ζ over training · {}", p.title), text(14))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(36)
        .build_cartesian_2d(xr, yr)?;
    chart.configure_mesh().disable_mesh().x_labels(5).y_labels(5).label_style(text(11)).draw()?;
    chart.draw_series(
        sketch.points.iter().map(|p| Circle::new((p.xy[0], p.xy[1]), 2, RGBColor(190, 190, 190).filled())),
    )?;
    for l in &sketch.landmarks {
        let (x, y) = (l.xy[0], l.xy[1]);
        chart.draw_series(std::iter::once(Rectangle::new(
            [(x - 0.4 * head, y - 0.4 * head), (x + 0.4 * head, y + 0.4 * head)],
            BLACK.filled(),
        )))?;
    }
    for (j, line) in paths.iter().enumerate() {
        let c = colour(j);
        let label = sketch.markers.get(j).map_or_else(|| format!("{j}"), |m| m.label.clone());
        chart
            .draw_series(LineSeries::new(line.iter().copied(), c.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
        if let Some(&s0) = starts.get(j).and_then(|s| s.first()) {
            chart.draw_series([Circle::new(s0, 5, c.stroke_width(2)), Circle::new(s0, 5, c.mix(0.3).filled())])?;
        }
        if let Some(&end) = line.last() {
            chart
                .draw_series([TriangleMarker::new(end, 11, BLACK.filled()), TriangleMarker::new(end, 8, c.filled())])?;
        }
    }
    if !oracle.is_empty() {
        chart
            .draw_series(oracle.iter().filter_map(|o| o.first()).map(|&xy| Cross::new(xy, 6, BLACK.stroke_width(2))))?
            .label("oracle design")
            .legend(|(x, y)| Cross::new((x + 8, y), 5, BLACK.stroke_width(2)));
    }
    draw_legend(&mut chart, 11)?;
    Ok(())
}

/// ζ trajectories over training (○ ζ₀, ▲ the reported ζ, × the oracle design on the same
/// instance when one of `designs` matches); one panel per run. Writes `stem.svg` and `stem.png`
/// in `dir` — or nothing when no run's environment draws a picture.
pub fn trajectories(
    registry: &Registry,
    panels: &[Panel],
    designs: &[&ResultFile],
    dir: &Path,
    stem: &str,
) -> Result<Vec<PathBuf>, ReportError> {
    if !panels.iter().any(|p| sketch_of(registry, p.result).is_some()) {
        return Ok(Vec::new());
    }
    save(&Trajectories { registry, panels, designs }, dir, stem)
}
