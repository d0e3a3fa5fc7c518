//! [`Summary`]: Table I from result files — `table.md` in the paper's layout and `table.csv`
//! with one row per run.

use std::fmt::Write as _;

use envpg_core::ResultFile;

use crate::stats::{mean, std};

/// Which column of Table I a run belongs to.
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
    /// κ.
    pub kappa: f64,
    /// Seed (the oracle's own seed for [`Method::OracleBest`]).
    pub seed: u64,
    /// Exact final J (None when the final policy does not reach the destination).
    pub j: Option<f64>,
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

impl Row {
    /// The row of result file `r` (stored as `file`).
    pub fn from_result(method: Method, r: &ResultFile, file: &str) -> Self {
        let detail = |key: &str| r.details.as_ref().and_then(|d| d.get(key)).and_then(|v| v.as_u64());
        let (iterations, transitions) = match method {
            Method::Algorithm1 => (detail("iterations"), detail("transitions")),
            _ => (r.history.as_ref().map(|h| h.len() as u64), None),
        };
        Self {
            method,
            kappa: r.kappa,
            seed: r.seed,
            j: r.j,
            j_h: r.j_h,
            seconds: r.seconds,
            iterations,
            transitions,
            file: file.to_owned(),
        }
    }
}

/// Statistics of one κ column.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// κ.
    pub kappa: f64,
    /// Final J of Algorithm 1 per seed (None: no proper final policy).
    pub alg1: Vec<Option<f64>>,
    /// Final J of the same-start oracle per seed, in the same order.
    pub same_start: Vec<Option<f64>>,
    /// The best-of-restarts oracle J.
    pub best: Option<f64>,
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

/// Table I.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Every run.
    pub rows: Vec<Row>,
    /// κ columns, in the order given.
    pub kappas: Vec<f64>,
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
    fn find(&self, method: Method, kappa: f64, seed: Option<u64>) -> Option<&Row> {
        self.rows.iter().find(|r| r.method == method && r.kappa == kappa && seed.is_none_or(|s| r.seed == s))
    }

    /// The statistics of every κ column.
    pub fn columns(&self) -> Vec<Column> {
        self.kappas
            .iter()
            .map(|&kappa| {
                let j = |m, s| self.find(m, kappa, Some(s)).and_then(|r| r.j);
                let alg1: Vec<_> = self.seeds.iter().map(|&s| j(Method::Algorithm1, s)).collect();
                let same_start: Vec<_> = self.seeds.iter().map(|&s| j(Method::OracleSameStart, s)).collect();
                let best = self.find(Method::OracleBest, kappa, None).and_then(|r| r.j);
                let paired: Vec<f64> =
                    alg1.iter().zip(&same_start).filter_map(|(a, b)| Some(rel((*a)?, (*b)?))).collect();
                let vs_best: Vec<f64> = alg1.iter().filter_map(|a| Some(rel((*a)?, best?))).collect();
                Column {
                    kappa,
                    near_same: paired.iter().filter(|d| **d <= self.basin_tol).count(),
                    in_basin: vs_best.iter().filter(|d| **d <= self.basin_tol).count(),
                    rel_same: (!paired.is_empty()).then(|| mean(&paired)),
                    rel_best: (!vs_best.is_empty()).then(|| mean(&vs_best)),
                    alg1,
                    same_start,
                    best,
                }
            })
            .collect()
    }

    /// Mean relative differences over every (κ, seed): (vs same start, vs best).
    pub fn overall(&self) -> (Option<f64>, Option<f64>) {
        let cols = self.columns();
        let mut same = Vec::new();
        let mut best = Vec::new();
        for c in &cols {
            for (a, b) in c.alg1.iter().zip(&c.same_start) {
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
        let head: Vec<String> = self.kappas.iter().map(|k| format!("κ = {k}")).collect();
        let _ = writeln!(s, "| | {} | overall |", head.join(" | "));
        let _ = writeln!(s, "|---|{}---|", "---|".repeat(self.kappas.len()));
        let cell = |v: &[Option<f64>]| {
            let ok: Vec<f64> = v.iter().flatten().copied().collect();
            let missing = v.len() - ok.len();
            let mut c = if ok.is_empty() { "–".to_string() } else { format!("{:.3} ± {:.3}", mean(&ok), std(&ok)) };
            if missing > 0 {
                let _ = write!(c, " ({missing} missing)");
            }
            c
        };
        let pct = |x: Option<f64>| x.map_or("–".to_string(), |x| format!("{:+.2}%", 100.0 * x));
        let row =
            |name: &str, cells: Vec<String>, last: String| format!("| {name} | {} | {last} |\n", cells.join(" | "));
        s += &row("Algorithm 1", cols.iter().map(|c| cell(&c.alg1)).collect(), String::new());
        s += &row("Oracle, same ζ₀", cols.iter().map(|c| cell(&c.same_start)).collect(), String::new());
        s += &row(
            &format!("Oracle, best of {} restarts", self.restarts),
            cols.iter().map(|c| c.best.map_or("–".into(), |b| format!("{b:.3}"))).collect(),
            String::new(),
        );
        let (all_same, all_best) = self.overall();
        s += &row("Δ Algorithm 1 vs same-ζ₀ oracle", cols.iter().map(|c| pct(c.rel_same)).collect(), pct(all_same));
        s += &row("Δ Algorithm 1 vs best oracle", cols.iter().map(|c| pct(c.rel_best)).collect(), pct(all_best));
        let n_seeds = cols.iter().map(|c| c.alg1.len()).sum::<usize>();
        let near: usize = cols.iter().map(|c| c.near_same).sum();
        s += &row(
            &format!("seeds within {:.1}% of their same-ζ₀ oracle (or below)", 100.0 * self.basin_tol),
            cols.iter().map(|c| format!("{}/{}", c.near_same, c.alg1.len())).collect(),
            format!("{near}/{n_seeds}"),
        );
        let basin: usize = cols.iter().map(|c| c.in_basin).sum();
        s += &row(
            &format!("seeds within {:.1}% of the best oracle", 100.0 * self.basin_tol),
            cols.iter().map(|c| format!("{}/{}", c.in_basin, c.alg1.len())).collect(),
            format!("{basin}/{n_seeds}"),
        );
        s += "\nΔ is the mean over seeds of (J_Algorithm1 − J_oracle)/J_oracle, paired by seed for the \
              same-ζ₀ oracle. Every J is the exact objective of the run's final design and greedy \
              policy, stored in the result file named in `table.csv` (recompute it with \
              `envpg evaluate FILE`).\n";
        s
    }

    /// `table.csv`: one row per run.
    pub fn csv(&self) -> String {
        let mut s = String::from("method,kappa,seed,J,J_H,seconds,iterations,transitions,file\n");
        let opt_f = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x}"));
        let opt_u = |x: Option<u64>| x.map_or(String::new(), |x| x.to_string());
        let mut rows: Vec<&Row> = self.rows.iter().collect();
        rows.sort_by(|a, b| a.method.cmp(&b.method).then(b.kappa.total_cmp(&a.kappa)).then(a.seed.cmp(&b.seed)));
        for r in rows {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{}",
                r.method.key(),
                r.kappa,
                r.seed,
                opt_f(r.j),
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

    fn row(method: Method, kappa: f64, seed: u64, j: Option<f64>) -> Row {
        Row {
            method,
            kappa,
            seed,
            j,
            j_h: None,
            seconds: Some(1.0),
            iterations: None,
            transitions: None,
            file: format!("{}_{kappa}_{seed}.json", method.key()),
        }
    }

    fn summary() -> Summary {
        use Method::*;
        Summary {
            rows: vec![
                row(Algorithm1, 1.0, 1, Some(10.2)),
                row(Algorithm1, 1.0, 2, Some(11.0)),
                row(OracleSameStart, 1.0, 1, Some(10.0)),
                row(OracleSameStart, 1.0, 2, Some(11.0)),
                row(OracleBest, 1.0, 7, Some(10.0)),
                row(Algorithm1, 0.5, 1, None),
                row(Algorithm1, 0.5, 2, Some(20.0)),
                row(OracleSameStart, 0.5, 1, Some(20.0)),
                row(OracleSameStart, 0.5, 2, Some(16.0)),
                row(OracleBest, 0.5, 7, Some(16.0)),
            ],
            kappas: vec![1.0, 0.5],
            seeds: vec![1, 2],
            restarts: 4,
            basin_tol: 0.05,
            preamble: vec!["test".into()],
        }
    }

    #[test]
    fn relative_differences_are_paired_by_seed() {
        let cols = summary().columns();
        // κ = 1: (10.2−10)/10 = 2%, (11−11)/11 = 0% → 1%; vs best: 2% and 10% → 6%.
        assert!((cols[0].rel_same.unwrap() - 0.01).abs() < 1e-12);
        assert!((cols[0].rel_best.unwrap() - 0.06).abs() < 1e-12);
        assert_eq!((cols[0].in_basin, cols[0].near_same), (1, 2));
        // κ = 0.5: seed 1 has no J, so only seed 2 counts: (20−16)/16 = 25%.
        assert!((cols[1].rel_same.unwrap() - 0.25).abs() < 1e-12);
        assert_eq!((cols[1].in_basin, cols[1].near_same), (0, 0), "a missing J does not count");
        let (same, best) = summary().overall();
        assert!((same.unwrap() - (0.02 + 0.0 + 0.25) / 3.0).abs() < 1e-12);
        assert!((best.unwrap() - (0.02 + 0.1 + 0.25) / 3.0).abs() < 1e-12);
    }

    #[test]
    fn markdown_and_csv_have_one_line_per_row() {
        let s = summary();
        let md = s.markdown();
        assert!(md.contains("| Algorithm 1 | 10.600 ± 0.566 | 20.000 ± 0.000 (1 missing) |  |"), "{md}");
        assert!(md.contains("| Δ Algorithm 1 vs same-ζ₀ oracle | +1.00% | +25.00% | +9.00% |"), "{md}");
        assert!(md.contains("| seeds within 5.0% of the best oracle | 1/2 | 0/2 | 1/4 |"), "{md}");
        assert!(md.contains("| seeds within 5.0% of their same-ζ₀ oracle (or below) | 2/2 | 0/2 | 2/4 |"), "{md}");
        let csv = s.csv();
        assert_eq!(csv.lines().count(), 1 + s.rows.len());
        assert!(csv.contains("algorithm1,0.5,1,,,1.00,,,algorithm1_0.5_1.json"), "{csv}");
    }
}
