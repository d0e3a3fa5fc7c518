//! What a finished table says about itself: the preamble above its rows (settings in the
//! instance's units, compute) and its figures.

use std::path::{Path, PathBuf};

use envpg_core::ResultFile;

use super::{Alg1Runner, Job, TableColumn, TablePlan};
use crate::{ReportError, figures, stats};

/// Settings and scales to three significant digits.
fn fmt_num(x: f64) -> String {
    crate::stats::sig(x, 3)
}

pub(super) fn preamble(
    plan: &TablePlan,
    columns: &[TableColumn],
    runner: &dyn Alg1Runner,
    files: &[(Job, ResultFile)],
    wall: f64,
) -> Vec<String> {
    let compute: f64 = files.iter().filter_map(|(_, r)| r.seconds).sum();
    let seeds = plan.seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ");
    let env = &columns[0].env;
    let s = env.sampler();
    // Absolute values: scale-free settings in this instance's units.
    let c = &plan.config.resolve(s);
    let units = if plan.config.scale_free {
        let l = s.zeta_space().scale().iter().sum::<f64>() / s.zeta_dim().max(1) as f64;
        format!(
            " (scale-free settings in this instance's units: cost C = {}, length L = {})",
            fmt_num(s.cost_scale()),
            fmt_num(l)
        )
    } else {
        String::new()
    };
    let mut lines = vec![
        format!(
            "Instance `{}` (environment `{}`: {} states, {} actions, ζ ∈ ℝ^{}), {}{}, seeds {seeds}.",
            env.title,
            env.name,
            s.n_states(),
            s.n_actions(),
            s.zeta_dim(),
            env.params_text(),
            plan.vary.as_ref().map_or(String::new(), |v| format!(" except {} per column", v.key)),
        ),
        format!(
            "Algorithm 1: {} iterations × {} episodes (+{} exploration), σ = {}, α {} → {}, estimator {:?}{}; {}{units}.",
            c.iterations,
            c.episodes,
            c.explore_episodes,
            if c.sigma_anneal == 1.0 {
                fmt_num(c.sigma)
            } else {
                format!("{} → {}", fmt_num(c.sigma), fmt_num(c.sigma * c.sigma_anneal))
            },
            fmt_num(c.alpha0),
            fmt_num(c.alpha_final),
            c.zeta_estimator,
            if c.polish_iterations > 0 {
                format!(
                    ", then ζ polish: {} iterations × {} episodes, {} policy rounds, best of {} starts \
                     (spread {}, {} screening iterations each)",
                    c.polish_iterations,
                    c.polish_episodes,
                    c.polish_policy_rounds,
                    c.polish_candidates,
                    fmt_num(c.polish_spread),
                    c.polish_screen
                )
            } else {
                String::new()
            },
            runner.describe()
        ),
        format!(
            "Oracle: same ζ₀ = one warm restart from each seed's ζ₀ over α {} → {}; best = {} restarts (seed {}).",
            fmt_num(c.alpha0),
            fmt_num(c.alpha_final),
            plan.restarts,
            plan.oracle_seed
        ),
        format!(
            "Run time: {:.0} s of runs, this invocation {:.0} s wall with {} parallel jobs.",
            compute, wall, plan.jobs
        ),
    ];
    lines.extend(plan.preamble.iter().cloned());
    lines
}

/// The table's figures: designs (Algorithm 1's median seed above the best oracle, one column per
/// table column), gradient norm and learning curves of every seed, and the median seeds' ζ
/// trajectories.
pub(super) fn table_figures(
    plan: &TablePlan,
    columns: &[TableColumn],
    files: &[(Job, ResultFile)],
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    let alg1_at = |col: usize| -> Vec<&ResultFile> {
        files
            .iter()
            .filter(|(j, r)| matches!(j, Job::Alg1 { .. }) && j.col() == col && r.j.is_some())
            .map(|(_, r)| r)
            .collect()
    };
    let best_at =
        |col: usize| files.iter().find(|(j, _)| matches!(j, Job::Best { .. }) && j.col() == col).map(|(_, r)| r);
    let median: Vec<Option<&ResultFile>> = (0..columns.len())
        .map(|col| {
            let at = alg1_at(col);
            let js: Vec<f64> = at.iter().map(|r| r.j.unwrap_or(f64::INFINITY)).collect();
            stats::median_index(&js).map(|i| at[i])
        })
        .collect();
    let titles_alg1: Vec<String> = median
        .iter()
        .zip(columns)
        .map(|(r, c)| r.map(|r| format!("{} · {} (median seed)", figures::title(r), c.label)).unwrap_or_default())
        .collect();
    let titles_best: Vec<String> = (0..columns.len())
        .map(|col| {
            best_at(col)
                .map(|r| {
                    format!(
                        "Oracle · {} · best of {} · J = {}",
                        columns[col].label,
                        plan.restarts,
                        crate::stats::fixed(r.j.unwrap_or(f64::NAN))
                    )
                })
                .unwrap_or_default()
        })
        .collect();
    let mut cells = Vec::new();
    for (r, t) in median.iter().zip(&titles_alg1) {
        cells.push(r.map(|r| figures::Panel { result: r, title: t }));
    }
    for (col, t) in titles_best.iter().enumerate() {
        cells.push(best_at(col).map(|r| figures::Panel { result: r, title: t }));
    }
    let mut out = figures::designs(&plan.registry, &cells, columns.len(), dir, "designs")?;
    let groups: Vec<(String, Vec<&ResultFile>)> =
        (0..columns.len()).map(|col| (columns[col].label.clone(), alg1_at(col))).filter(|g| !g.1.is_empty()).collect();
    if !groups.is_empty() {
        let oracle: Vec<(String, &ResultFile)> =
            (0..columns.len()).filter_map(|col| Some((columns[col].label.clone(), best_at(col)?))).collect();
        out.extend(figures::grad_norm(&groups, plan.window, dir, "grad_norm")?);
        out.extend(figures::learning_curves(&groups, &oracle, plan.window, dir, "learning_curves")?);
        let panels: Vec<figures::Panel> = median
            .iter()
            .zip(&titles_alg1)
            .filter_map(|(r, t)| Some(figures::Panel { result: (*r)?, title: t }))
            .collect();
        let designs: Vec<&ResultFile> = oracle.iter().map(|(_, r)| *r).collect();
        out.extend(figures::trajectories(&plan.registry, &panels, &designs, dir, "trajectories")?);
    }
    Ok(out)
}
