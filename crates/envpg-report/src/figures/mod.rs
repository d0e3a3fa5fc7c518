//! Figures, drawn with plotters to SVG and PNG side by side.
//!
//! - [`placements`]: Figure 1 (a/b) — users coloured by the UAV their greedy action picks, the
//!   UAVs, the destination and each UAV's greedy next hop; one panel per result.
//! - [`grad_norm`]: Figure 1 (c) — ‖ζ-gradient estimate‖ per iteration with a moving average,
//!   one curve per κ.
//! - [`learning_curves`]: exact J of (ζ_k, greedy π_k) and the J_H estimate per iteration,
//!   with the oracle's J as a horizontal line; one panel per κ.
//! - [`trajectories`]: the UAVs' paths over training on the map.
//! - [`sweep`]: final J and the estimator's variance and bias against a swept setting.
//!
//! [`plot_results`] is what `envpg plot` calls: every figure that the given results support.
//! Each figure is drawn once, as `NAME.svg`, and rasterised to `NAME.png` with the same
//! font; both are written atomically.

mod curves;
mod maps;
mod sweep_fig;

use std::error::Error;
use std::path::{Path, PathBuf};

use envpg_core::ResultFile;
use plotters::coord::Shift;
use plotters::prelude::*;

pub use curves::{grad_norm, learning_curves};
pub use maps::{placements, trajectories};
pub use sweep_fig::sweep;

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

/// Colours of the UAVs, curves and seeds (Tableau 10: distinct and colour-blind tolerable).
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

/// The standard title of a result: method, κ, seed and J.
pub fn title(r: &ResultFile) -> String {
    let j = r.j.map_or("J n/a".to_string(), |j| format!("J = {j:.3}"));
    format!("{} · κ = {} · seed {} · {j}", method_name(r), r.kappa, r.seed)
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

/// Every figure the results support: placements of all of them (grouped by κ: one column per
/// κ, Algorithm 1 above the oracle), and for the Algorithm 1 runs the gradient-norm, learning-
/// curve and trajectory figures, with the best oracle J per κ as reference. Returns the files.
pub fn plot_results(results: &[ResultFile], dir: &Path, opts: &PlotOptions) -> Result<Vec<PathBuf>, ReportError> {
    if results.is_empty() {
        return Err(ReportError::Plan("nothing to plot: no result files given".into()));
    }
    let mut kappas: Vec<f64> = results.iter().map(|r| r.kappa).collect();
    kappas.sort_by(|a, b| b.total_cmp(a));
    kappas.dedup();
    let titles: Vec<String> = results.iter().map(title).collect();
    // Columns are κ (descending); within a column Algorithm 1 runs come first, then oracles.
    let mut columns: Vec<Vec<Panel>> = kappas
        .iter()
        .map(|&k| {
            let mut col: Vec<(usize, Panel)> = results
                .iter()
                .zip(&titles)
                .enumerate()
                .filter(|(_, (r, _))| r.kappa == k)
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
    let mut files = placements(&cells, kappas.len(), dir, "placements")?;
    let runs: Vec<&ResultFile> = results.iter().filter(|r| r.history.is_some() && r.method == "envpg-ac").collect();
    if !runs.is_empty() {
        let oracle = best_oracle_per_kappa(results);
        files.extend(grad_norm(&runs, opts.window, dir, "grad_norm")?);
        files.extend(learning_curves(&runs, &oracle, opts.window, dir, "learning_curves")?);
        let panels: Vec<Panel> = runs
            .iter()
            .map(|r| Panel { result: r, title: &titles[results.iter().position(|x| std::ptr::eq(x, *r)).unwrap()] })
            .collect();
        let designs: Vec<&ResultFile> = oracle.iter().map(|(_, r)| *r).collect();
        files.extend(trajectories(&panels, &designs, dir, "trajectories")?);
    }
    Ok(files)
}

/// The oracle result with the lowest J at each κ.
pub fn best_oracle_per_kappa(results: &[ResultFile]) -> Vec<(f64, &ResultFile)> {
    let mut best: Vec<(f64, &ResultFile)> = Vec::new();
    for r in results.iter().filter(|r| r.method == "oracle" && r.j.is_some()) {
        match best.iter_mut().find(|(k, _)| *k == r.kappa) {
            Some(slot) if slot.1.j > r.j => slot.1 = r,
            Some(_) => {}
            None => best.push((r.kappa, r)),
        }
    }
    best
}
