//! [`Summary`]: Table I from result files — `table.md` in the paper's layout and `table.csv`
//! with one row per run.
//!
//! Algorithm 1 gets two rows from the same runs: *alone* (its design and the actor's greedy
//! policy before the ζ polish, as `details.polish.J_before` records them) and *+ polish* (the
//! result the run reports). Both are exact J of the design and policy stored in the file.

use std::fmt::Write as _;

use envpg_core::ResultFile;

use crate::stats::{fixed, mean, mean_std};

/// Which row of Table I a run belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Method {
    /// Algorithm 1 (model-free).
    Algorithm1,
    /// The oracle warm-started from the same ζ₀ as an Algorithm 1 seed, with the same α range.
    OracleSameStart,
    /// The oracle's best of its restarts.
    OracleBest,
}

impl Method {
    /// The name used in CSV files and file names.
    pub fn key(self) -> &'static str {
        match self {
            Method::Algorithm1 => "algorithm1",
            Method::OracleSameStart => "oracle-same-start",
            Method::OracleBest => "oracle-best",
        }
    }
}

/// One run of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Method.
    pub method: Method,
    /// Column index.
    pub col: usize,
    /// Seed (the oracle's own seed for [`Method::OracleBest`]).
    pub seed: u64,
    /// Exact final J (None when the final policy does not terminate).
    pub j: Option<f64>,
    /// Algorithm 1 alone: exact J of the design and greedy policy before the polish (the
    /// final J when the run had no polish).
    pub j_alone: Option<f64>,
    /// Exact final J_H at the final α.
    pub j_h: Option<f64>,
    /// Wall-clock seconds.
    pub seconds: Option<f64>,
    /// Iterations (Algorithm 1) or temperature levels (oracle).
    pub iterations: Option<u64>,
    /// Environment transitions (Algorithm 1 only; the oracle uses the model).
    pub transitions: Option<u64>,
    /// The result file, relative to the table directory.
    pub file: String,
}

/// Algorithm 1's J before the polish, from a result file (its J when it had no polish).
pub fn j_alone(r: &ResultFile) -> Option<f64> {
    match r.details.as_ref().and_then(|d| d.get("polish")) {
        Some(p) => p.get("J_before").and_then(|j| j.as_f64()),
        None => r.j,
    }
}

impl Row {
    /// The row of result file `r` in column `col` (stored as `file`).
    pub fn from_result(method: Method, col: usize, r: &ResultFile, file: &str) -> Self {
        let detail = |key: &str| r.details.as_ref().and_then(|d| d.get(key)).and_then(|v| v.as_u64());
        let (iterations, transitions) = match method {
            Method::Algorithm1 => (detail("iterations"), detail("transitions")),
            _ => (r.history.as_ref().map(|h| h.len() as u64), None),
        };
        Self {
            method,
            col,
            seed: r.seed,
            j: r.j,
            j_alone: if method == Method::Algorithm1 { j_alone(r) } else { r.j },
            j_h: r.j_h,
            seconds: r.seconds,
            iterations,
            transitions,
            file: file.to_owned(),
        }
    }
}

/// Statistics of one column, for one of Algorithm 1's two rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Versus {
    /// Final J of Algorithm 1 per seed (None: no proper final policy).
    pub alg1: Vec<Option<f64>>,
    /// Mean over seeds of (J_alg1 − J_same)/J_same (paired; seeds with both values).
    pub rel_same: Option<f64>,
    /// Mean over seeds of (J_alg1 − J_best)/J_best.
    pub rel_best: Option<f64>,
    /// Seeds whose J is within the basin tolerance of the best-of-restarts J.
    pub in_basin: usize,
    /// Seeds whose J is within the basin tolerance of their own same-start oracle's J (or
    /// below it); a seed missing either J does not count.
    pub near_same: usize,
}

/// Statistics of one column.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnStats {
    /// Column label.
    pub label: String,
    /// Algorithm 1 alone (before the polish).
    pub alone: Versus,
    /// Algorithm 1 with the polish (the reported result).
    pub polished: Versus,
    /// Final J of the same-start oracle per seed, in the same order.
    pub same_start: Vec<Option<f64>>,
    /// The best-of-restarts oracle J.
    pub best: Option<f64>,
}

/// Table I.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Every run.
    pub rows: Vec<Row>,
    /// Column labels, in the order given.
    pub columns: Vec<String>,
    /// Seeds.
    pub seeds: Vec<u64>,
    /// Restarts of the best-of-restarts oracle.
    pub restarts: usize,
    /// Relative J tolerance for "reached the best basin".
    pub basin_tol: f64,
    /// Lines printed above the table (instance, settings, command, machine).
    pub preamble: Vec<String>,
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b) / b
}

impl Summary {
    fn find(&self, method: Method, col: usize, seed: Option<u64>) -> Option<&Row> {
        self.rows.iter().find(|r| r.method == method && r.col == col && seed.is_none_or(|s| r.seed == s))
    }

    fn versus(&self, alg1: Vec<Option<f64>>, same: &[Option<f64>], best: Option<f64>) -> Versus {
        let paired: Vec<f64> = alg1.iter().zip(same).filter_map(|(a, b)| Some(rel((*a)?, (*b)?))).collect();
        let vs_best: Vec<f64> = alg1.iter().filter_map(|a| Some(rel((*a)?, best?))).collect();
        Versus {
            near_same: paired.iter().filter(|d| **d <= self.basin_tol).count(),
            in_basin: vs_best.iter().filter(|d| **d <= self.basin_tol).count(),
            rel_same: (!paired.is_empty()).then(|| mean(&paired)),
            rel_best: (!vs_best.is_empty()).then(|| mean(&vs_best)),
            alg1,
        }
    }

    /// The statistics of every column.
    pub fn columns(&self) -> Vec<ColumnStats> {
        (0..self.columns.len())
            .map(|col| {
                let row = |m, s| self.find(m, col, Some(s));
                let same_start: Vec<_> =
                    self.seeds.iter().map(|&s| row(Method::OracleSameStart, s).and_then(|r| r.j)).collect();
                let best = self.find(Method::OracleBest, col, None).and_then(|r| r.j);
                let polished = self.seeds.iter().map(|&s| row(Method::Algorithm1, s).and_then(|r| r.j)).collect();
                let alone = self.seeds.iter().map(|&s| row(Method::Algorithm1, s).and_then(|r| r.j_alone)).collect();
                ColumnStats {
                    label: self.columns[col].clone(),
                    alone: self.versus(alone, &same_start, best),
                    polished: self.versus(polished, &same_start, best),
                    same_start,
                    best,
                }
            })
            .collect()
    }

    /// Mean relative differences over every (column, seed) of one of Algorithm 1's rows:
    /// (vs same start, vs best).
    pub fn overall(&self, pick: impl Fn(&ColumnStats) -> &Versus) -> (Option<f64>, Option<f64>) {
        let mut same = Vec::new();
        let mut best = Vec::new();
        for c in &self.columns() {
            let v = pick(c);
            for (a, b) in v.alg1.iter().zip(&c.same_start) {
                if let (Some(a), Some(b)) = (a, b) {
                    same.push(rel(*a, *b));
                }
                if let (Some(a), Some(b)) = (a, c.best) {
                    best.push(rel(*a, b));
                }
            }
        }
        let m = |v: &[f64]| (!v.is_empty()).then(|| mean(v));
        (m(&same), m(&best))
    }

    /// `table.md`.
    pub fn markdown(&self) -> String {
        let cols = self.columns();
        let mut s = String::from("# Table I: final J, mean ± std over seeds\n\n");
        for line in &self.preamble {
            let _ = writeln!(s, "{line}  ");
        }
        s.push('\n');
        let _ = writeln!(s, "| | {} | overall |", self.columns.join(" | "));
        let _ = writeln!(s, "|---|{}---|", "---|".repeat(self.columns.len()));
        let cell = |v: &[Option<f64>]| {
            let ok: Vec<f64> = v.iter().flatten().copied().collect();
            let missing = v.len() - ok.len();
            let mut c = if ok.is_empty() { "–".to_string() } else { mean_std(&ok) };
            if missing > 0 {
                let _ = write!(c, " ({missing} missing)");
            }
            c
        };
        let pct = |x: Option<f64>| x.map_or("–".to_string(), |x| format!("{:+.2}%", 100.0 * x));
        let row =
            |name: &str, cells: Vec<String>, last: String| format!("| {name} | {} | {last} |\n", cells.join(" | "));
        type Pick = fn(&ColumnStats) -> &Versus;
        let rows: [(&str, Pick); 2] = [("Algorithm 1 alone", |c| &c.alone), ("Algorithm 1 + polish", |c| &c.polished)];
        for (name, pick) in rows {
            s += &row(name, cols.iter().map(|c| cell(&pick(c).alg1)).collect(), String::new());
        }
        s += &row("Oracle, same ζ₀", cols.iter().map(|c| cell(&c.same_start)).collect(), String::new());
        s += &row(
            &format!("Oracle, best of {} restarts", self.restarts),
            cols.iter().map(|c| c.best.map_or("–".into(), fixed)).collect(),
            String::new(),
        );
        let n_seeds = cols.iter().map(|c| c.polished.alg1.len()).sum::<usize>();
        for (name, pick) in rows {
            let (all_same, all_best) = self.overall(pick);
            s += &row(
                &format!("Δ {name} vs same-ζ₀ oracle"),
                cols.iter().map(|c| pct(pick(c).rel_same)).collect(),
                pct(all_same),
            );
            s += &row(
                &format!("Δ {name} vs best oracle"),
                cols.iter().map(|c| pct(pick(c).rel_best)).collect(),
                pct(all_best),
            );
        }
        for (name, pick) in rows {
            let near: usize = cols.iter().map(|c| pick(c).near_same).sum();
            s += &row(
                &format!("{name}: seeds within {:.1}% of their same-ζ₀ oracle (or below)", 100.0 * self.basin_tol),
                cols.iter().map(|c| format!("{}/{}", pick(c).near_same, pick(c).alg1.len())).collect(),
                format!("{near}/{n_seeds}"),
            );
            let basin: usize = cols.iter().map(|c| pick(c).in_basin).sum();
            s += &row(
                &format!("{name}: seeds within {:.1}% of the best oracle", 100.0 * self.basin_tol),
                cols.iter().map(|c| format!("{}/{}", pick(c).in_basin, pick(c).alg1.len())).collect(),
                format!("{basin}/{n_seeds}"),
            );
        }
        s += "\n*Algorithm 1 alone* is the design Algorithm 1 ends with and the actor's greedy policy \
              there; *+ polish* adds the model-free ζ polish after training (design and greedy policy \
              refined on sampled episodes), which needs a sampler that can be replayed with \
              caller-supplied randomness and started from any state. Δ is the mean over seeds of \
              (J_Algorithm1 − J_oracle)/J_oracle, paired by seed for the same-ζ₀ oracle. Every J is the \
              exact objective of a design and greedy policy stored in the result file named in \
              `table.csv` (recompute it with `envpg evaluate FILE`).\n";
        s
    }

    /// `table.csv`: one row per run.
    pub fn csv(&self) -> String {
        let mut s = String::from("method,column,seed,J,J_alone,J_H,seconds,iterations,transitions,file\n");
        let opt_f = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x}"));
        let opt_u = |x: Option<u64>| x.map_or(String::new(), |x| x.to_string());
        let mut rows: Vec<&Row> = self.rows.iter().collect();
        rows.sort_by(|a, b| a.method.cmp(&b.method).then(a.col.cmp(&b.col)).then(a.seed.cmp(&b.seed)));
        for r in rows {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{}",
                r.method.key(),
                self.columns[r.col],
                r.seed,
                opt_f(r.j),
                opt_f(r.j_alone),
                opt_f(r.j_h),
                r.seconds.map_or(String::new(), |x| format!("{x:.2}")),
                opt_u(r.iterations),
                opt_u(r.transitions),
                r.file
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: Method, col: usize, seed: u64, j: Option<f64>, alone: Option<f64>) -> Row {
        Row {
            method,
            col,
            seed,
            j,
            j_alone: alone,
            j_h: None,
            seconds: Some(1.0),
            iterations: None,
            transitions: None,
            file: format!("{}_{col}_{seed}.json", method.key()),
        }
    }

    fn summary() -> Summary {
        use Method::*;
        Summary {
            rows: vec![
                row(Algorithm1, 0, 1, Some(10.2), Some(10.4)),
                row(Algorithm1, 0, 2, Some(11.0), Some(11.0)),
                row(OracleSameStart, 0, 1, Some(10.0), Some(10.0)),
                row(OracleSameStart, 0, 2, Some(11.0), Some(11.0)),
                row(OracleBest, 0, 7, Some(10.0), Some(10.0)),
                row(Algorithm1, 1, 1, None, Some(30.0)),
                row(Algorithm1, 1, 2, Some(20.0), Some(24.0)),
                row(OracleSameStart, 1, 1, Some(20.0), Some(20.0)),
                row(OracleSameStart, 1, 2, Some(16.0), Some(16.0)),
                row(OracleBest, 1, 7, Some(16.0), Some(16.0)),
            ],
            columns: vec!["kappa = 1".into(), "kappa = 0.5".into()],
            seeds: vec![1, 2],
            restarts: 4,
            basin_tol: 0.05,
            preamble: vec!["test".into()],
        }
    }

    #[test]
    fn relative_differences_are_paired_by_seed_for_both_algorithm_1_rows() {
        let cols = summary().columns();
        // Column 0, + polish: (10.2−10)/10 = 2%, (11−11)/11 = 0% → 1%; vs best: 2% and 10% → 6%.
        assert!((cols[0].polished.rel_same.unwrap() - 0.01).abs() < 1e-12);
        assert!((cols[0].polished.rel_best.unwrap() - 0.06).abs() < 1e-12);
        assert_eq!((cols[0].polished.in_basin, cols[0].polished.near_same), (1, 2));
        // Alone: 4% and 0% → 2%.
        assert!((cols[0].alone.rel_same.unwrap() - 0.02).abs() < 1e-12);
        assert_eq!((cols[0].alone.in_basin, cols[0].alone.near_same), (1, 2));
        // Column 1: seed 1 has no J after the polish, so only seed 2 counts: (20−16)/16 = 25%.
        assert!((cols[1].polished.rel_same.unwrap() - 0.25).abs() < 1e-12);
        assert_eq!((cols[1].polished.in_basin, cols[1].polished.near_same), (0, 0), "a missing J does not count");
        let (same, best) = summary().overall(|c| &c.polished);
        assert!((same.unwrap() - (0.02 + 0.0 + 0.25) / 3.0).abs() < 1e-12);
        assert!((best.unwrap() - (0.02 + 0.1 + 0.25) / 3.0).abs() < 1e-12);
    }

    #[test]
    fn markdown_and_csv_have_one_line_per_row() {
        let s = summary();
        let md = s.markdown();
        assert!(md.contains("| Algorithm 1 + polish | 10.6000 ± 0.5657 | 20.0000 ± 0.0000 (1 missing) |  |"), "{md}");
        assert!(md.contains("| Algorithm 1 alone | 10.7000 ± 0.4243 | 27.0000 ± 4.2426 |  |"), "{md}");
        assert!(md.contains("| Δ Algorithm 1 + polish vs same-ζ₀ oracle | +1.00% | +25.00% | +9.00% |"), "{md}");
        assert!(
            md.contains("| Algorithm 1 + polish: seeds within 5.0% of the best oracle | 1/2 | 0/2 | 1/4 |"),
            "{md}"
        );
        assert!(
            md.contains(
                "| Algorithm 1 + polish: seeds within 5.0% of their same-ζ₀ oracle (or below) | 2/2 | 0/2 | 2/4 |"
            ),
            "{md}"
        );
        let csv = s.csv();
        assert_eq!(csv.lines().count(), 1 + s.rows.len());
        assert!(csv.contains("algorithm1,kappa = 0.5,1,,30,,1.00,,,algorithm1_1_1.json"), "{csv}");
    }
}
