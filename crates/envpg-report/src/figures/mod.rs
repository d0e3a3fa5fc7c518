//! Figures, drawn with plotters to SVG and PNG side by side.
//!
//! - [`designs`]: Figure 1 (a/b) — each result's design and greedy policy, drawn from its
//!   environment's sketch (UAVs with users coloured by their relay and the UAVs' next hops;
//!   cluster centres with points coloured by assignment; facilities with the agents' routes).
//! - [`grad_norm`]: Figure 1 (c) — ‖ζ-gradient estimate‖ per iteration with a moving average,
//!   one curve per group (a table column).
//! - [`learning_curves`]: exact J of (ζ_k, greedy π_k) and the J_H estimate per iteration,
//!   with the oracle's J as a horizontal line; one panel per group.
//! - [`trajectories`]: the design points' paths over training on the map.
//! - [`sweep`]: final J and the estimator's variance and bias against a swept setting.
//! - [`throughput`]: training throughput against the number of workers, predicted by the
//!   model of `envpg-launch --bench` and measured.
//!
//! [`plot_results`] is what `envpg plot` calls: every figure that the given results support.
//! Each figure is drawn once, as `NAME.svg`, and rasterised to `NAME.png` with the same
//! font; both are written atomically.

mod curves;
mod maps;
mod sweep_fig;
mod throughput;

use std::error::Error;
use std::path::{Path, PathBuf};

use envpg_core::{Registry, ResultFile};
use plotters::coord::Shift;
use plotters::prelude::*;

pub use curves::{grad_norm, learning_curves};
pub use maps::{designs, sketch_of, trajectories};
pub use sweep_fig::sweep;
pub use throughput::{ThroughputCurve, throughput};

use crate::ReportError;
use crate::font;

/// What a drawing step returns: plotters' errors differ per backend, so they are boxed.
pub(crate) type Drawn = Result<(), Box<dyn Error>>;

/// Draws the legend of `chart` the same way in every figure: upper right, on a translucent
/// white box, labels of `size` px.
pub(crate) fn draw_legend<'a, DB, CT>(chart: &mut ChartContext<'a, DB, CT>, size: u32) -> Drawn
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: CoordTranslate,
{
    chart
        .configure_series_labels()
        .label_font(text(size))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    Ok(())
}

/// A figure that can be drawn on any plotters backend.
pub(crate) trait Figure {
    /// Pixel size.
    fn size(&self) -> (u32, u32);
    /// Draws onto `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn
    where
        DB::ErrorType: 'static;
}

/// Writes `dir/stem.svg` and `dir/stem.png` (the SVG rasterised); returns both paths.
pub(crate) fn save(fig: &impl Figure, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, ReportError> {
    font::ensure();
    std::fs::create_dir_all(dir).map_err(|e| ReportError::io(dir, e))?;
    let (w, h) = fig.size();
    let svg = dir.join(format!("{stem}.svg"));
    let png = dir.join(format!("{stem}.png"));
    let draw_err = |path: &Path, reason: String| ReportError::Draw { path: path.to_owned(), reason };
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (w, h)).into_drawing_area();
        fig.draw(&root).and_then(|_| root.present().map_err(Into::into)).map_err(|e| draw_err(&svg, e.to_string()))?;
    }
    envpg_core::io::write_atomic(&svg, text.as_bytes()).map_err(|e| ReportError::io(&svg, e))?;
    let bytes = font::rasterise(&text, w, h).map_err(|e| draw_err(&png, e))?;
    envpg_core::io::write_atomic(&png, &bytes).map_err(|e| ReportError::io(&png, e))?;
    Ok(vec![svg, png])
}

/// Colours of the design points, curves and seeds (Tableau 10: distinct and colour-blind tolerable).
pub(crate) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// The i-th palette colour.
pub(crate) fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// A text style of the shipped font.
pub(crate) fn text(size: u32) -> TextStyle<'static> {
    (font::FAMILY, size).into_font().into()
}

/// Rows × columns for `n` panels, at most `max_cols` wide.
pub(crate) fn grid(n: usize, max_cols: usize) -> (usize, usize) {
    let cols = n.clamp(1, max_cols.max(1));
    (n.div_ceil(cols).max(1), cols)
}

/// One panel: a result and its title.
#[derive(Debug, Clone, Copy)]
pub struct Panel<'a> {
    /// The result drawn.
    pub result: &'a ResultFile,
    /// Title above the panel.
    pub title: &'a str,
}

/// A result's method for titles: `Algorithm 1` or `Oracle`.
pub fn method_name(r: &ResultFile) -> &'static str {
    match r.method.as_str() {
        "envpg-ac" => "Algorithm 1",
        "oracle" => "Oracle",
        _ => "Result",
    }
}

/// The standard title of a result: method, seed and J.
pub fn title(r: &ResultFile) -> String {
    let j = r.j.map_or("J n/a".to_string(), |j| format!("J = {}", crate::stats::fixed(j)));
    format!("{} · seed {} · {j}", method_name(r), r.seed)
}

/// The label of each result among `results`: the instance parameters that differ between them
/// (`kappa = 0.9`), or the instance's name where none do.
pub fn group_labels(results: &[ResultFile]) -> Vec<String> {
    let params = |r: &ResultFile| -> Vec<(String, f64)> {
        r.instance
            .get("params")
            .and_then(|p| p.as_object())
            .map(|p| p.iter().filter_map(|(k, v)| Some((k.clone(), v.as_f64()?))).collect())
            .unwrap_or_default()
    };
    let all: Vec<Vec<(String, f64)>> = results.iter().map(params).collect();
    let varying: Vec<String> = all
        .iter()
        .flatten()
        .map(|(k, _)| k.clone())
        .filter(|k| {
            let vals: Vec<Option<f64>> =
                all.iter().map(|ps| ps.iter().find(|(key, _)| key == k).map(|(_, v)| *v)).collect();
            vals.iter().any(|v| *v != vals[0])
        })
        .fold(Vec::new(), |mut acc, k| {
            if !acc.contains(&k) {
                acc.push(k);
            }
            acc
        });
    results
        .iter()
        .zip(&all)
        .map(|(r, ps)| {
            let shown: Vec<String> =
                ps.iter().filter(|(k, _)| varying.contains(k)).map(|(k, v)| format!("{k} = {v}")).collect();
            if shown.is_empty() { r.instance_name().to_owned() } else { shown.join(", ") }
        })
        .collect()
}

/// Options of [`plot_results`].
#[derive(Debug, Clone)]
pub struct PlotOptions {
    /// Moving-average window (iterations) of the per-iteration curves.
    pub window: usize,
}

impl Default for PlotOptions {
    fn default() -> Self {
        Self { window: 100 }
    }
}

/// Every figure the results support: designs of all of them (one column per group of
/// [`group_labels`], Algorithm 1 runs above oracles), and for the Algorithm 1 runs the
/// gradient-norm, learning-curve and trajectory figures, with the best oracle J per group as
/// reference. Environments are rebuilt from the results' own instances by `registry`. Returns
/// the files.
pub fn plot_results(
    results: &[ResultFile],
    registry: &Registry,
    dir: &Path,
    opts: &PlotOptions,
) -> Result<Vec<PathBuf>, ReportError> {
    if results.is_empty() {
        return Err(ReportError::Plan("nothing to plot: no result files given".into()));
    }
    let labels = group_labels(results);
    let mut groups: Vec<String> = Vec::new();
    for l in &labels {
        if !groups.contains(l) {
            groups.push(l.clone());
        }
    }
    let titles: Vec<String> = results.iter().zip(&labels).map(|(r, l)| format!("{} · {l}", title(r))).collect();
    // Columns are groups; within a column Algorithm 1 runs come first, then oracles.
    let mut columns: Vec<Vec<Panel>> = groups
        .iter()
        .map(|g| {
            let mut col: Vec<(usize, Panel)> = results
                .iter()
                .zip(&titles)
                .enumerate()
                .filter(|(i, _)| &labels[*i] == g)
                .map(|(i, (r, t))| (i, Panel { result: r, title: t }))
                .collect();
            col.sort_by_key(|(i, p)| (p.result.method != "envpg-ac", *i));
            col.into_iter().map(|(_, p)| p).collect()
        })
        .collect();
    let rows = columns.iter().map(Vec::len).max().unwrap_or(0);
    let mut cells: Vec<Option<Panel>> = Vec::new();
    for r in 0..rows {
        for col in &mut columns {
            cells.push(col.get(r).copied());
        }
    }
    let mut files = designs(registry, &cells, groups.len(), dir, "designs")?;
    let runs: Vec<usize> =
        (0..results.len()).filter(|&i| results[i].history.is_some() && results[i].method == "envpg-ac").collect();
    if !runs.is_empty() {
        let by_group: Vec<(String, Vec<&ResultFile>)> = groups
            .iter()
            .map(|g| (g.clone(), runs.iter().filter(|&&i| &labels[i] == g).map(|&i| &results[i]).collect::<Vec<_>>()))
            .filter(|(_, v)| !v.is_empty())
            .collect();
        let oracle = best_oracle_per_group(results, &labels);
        files.extend(grad_norm(&by_group, opts.window, dir, "grad_norm")?);
        files.extend(learning_curves(&by_group, &oracle, opts.window, dir, "learning_curves")?);
        let panels: Vec<Panel> = runs.iter().map(|&i| Panel { result: &results[i], title: &titles[i] }).collect();
        let designs: Vec<&ResultFile> = oracle.iter().map(|(_, r)| *r).collect();
        files.extend(trajectories(registry, &panels, &designs, dir, "trajectories")?);
    }
    Ok(files)
}

/// The oracle result with the lowest J in each group.
pub fn best_oracle_per_group<'a>(results: &'a [ResultFile], labels: &[String]) -> Vec<(String, &'a ResultFile)> {
    let mut best: Vec<(String, &ResultFile)> = Vec::new();
    for (r, l) in results.iter().zip(labels).filter(|(r, _)| r.method == "oracle" && r.j.is_some()) {
        match best.iter_mut().find(|(k, _)| k == l) {
            Some(slot) if slot.1.j > r.j => slot.1 = r,
            Some(_) => {}
            None => best.push((l.clone(), r)),
        }
    }
    best
}
