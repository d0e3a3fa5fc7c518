//! A small L-BFGS minimiser with Armijo backtracking and a step-length cap.
//!
//! Hand-written because the oracle needs two things general-purpose crates make awkward:
//! objective evaluations that may *fail* (soft value iteration diverging at a trial point is
//! treated as +∞ and backtracked from), and warm-start state threaded through evaluations.

/// Settings of [`minimize`].
#[derive(Debug, Clone)]
pub struct LbfgsConfig {
    /// Maximum iterations.
    pub max_iter: usize,
    /// History length.
    pub memory: usize,
    /// Stop when `‖g‖∞ ≤ gtol`.
    pub gtol: f64,
    /// Stop when the decrease of f in one iteration is ≤ `ftol·(1 + |f|)`.
    pub ftol: f64,
    /// Maximum Euclidean length of one step.
    pub max_step: f64,
}

impl Default for LbfgsConfig {
    fn default() -> Self {
        Self { max_iter: 50, memory: 8, gtol: 1e-7, ftol: 1e-12, max_step: 1.0 }
    }
}

/// The outcome of [`minimize`].
#[derive(Debug, Clone)]
pub struct LbfgsResult {
    /// Final point.
    pub x: Vec<f64>,
    /// Final value.
    pub f: f64,
    /// Final gradient.
    pub g: Vec<f64>,
    /// Iterations taken.
    pub iterations: usize,
    /// Function evaluations.
    pub evaluations: usize,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Minimises `f` from `x0`. `f` returns `None` where it is undefined (treated as +∞).
/// Returns `None` only if `f(x0)` is undefined.
pub fn minimize(
    x0: &[f64],
    cfg: &LbfgsConfig,
    mut f: impl FnMut(&[f64]) -> Option<(f64, Vec<f64>)>,
) -> Option<LbfgsResult> {
    let n = x0.len();
    let (mut fx, mut g) = f(x0)?;
    let mut x = x0.to_vec();
    let mut evals = 1;
    let mut hist: std::collections::VecDeque<(Vec<f64>, Vec<f64>, f64)> = std::collections::VecDeque::new();
    let mut iterations = 0;
    while iterations < cfg.max_iter {
        let gnorm = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if gnorm <= cfg.gtol {
            break;
        }
        iterations += 1;
        // Two-loop recursion.
        let mut d: Vec<f64> = g.iter().map(|v| -v).collect();
        let mut alphas = Vec::with_capacity(hist.len());
        for (s, y, rho) in hist.iter().rev() {
            let a = rho * dot(s, &d);
            for i in 0..n {
                d[i] -= a * y[i];
            }
            alphas.push(a);
        }
        if let Some((s, y, _)) = hist.back() {
            let gamma = dot(s, y) / dot(y, y);
            d.iter_mut().for_each(|v| *v *= gamma);
        } else {
            // First step: move at most max_step/10 along −g.
            let scale = (0.1 * cfg.max_step / dot(&g, &g).sqrt()).min(1.0);
            d.iter_mut().for_each(|v| *v *= scale);
        }
        for ((s, y, rho), a) in hist.iter().zip(alphas.iter().rev()) {
            let b = rho * dot(y, &d);
            for i in 0..n {
                d[i] += (a - b) * s[i];
            }
        }
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            hist.clear();
            d = g.iter().map(|v| -v).collect();
            slope = dot(&g, &d);
        }
        let len = dot(&d, &d).sqrt();
        let mut t = if len > cfg.max_step { cfg.max_step / len } else { 1.0 };
        let mut accepted = None;
        for _ in 0..24 {
            let xt: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + t * b).collect();
            evals += 1;
            if let Some((ft, gt)) = f(&xt)
                && ft.is_finite()
                && ft <= fx + 1e-4 * t * slope
            {
                accepted = Some((xt, ft, gt));
                break;
            }
            t *= 0.5;
        }
        let Some((xn, fnew, gn)) = accepted else { break };
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-12 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() {
            if hist.len() == cfg.memory {
                hist.pop_front();
            }
            hist.push_back((s, y, 1.0 / sy));
        }
        let decrease = fx - fnew;
        x = xn;
        fx = fnew;
        g = gn;
        if decrease <= cfg.ftol * (1.0 + fx.abs()) {
            break;
        }
    }
    Some(LbfgsResult { x, f: fx, g, iterations, evaluations: evals })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimises_rosenbrock() {
        let cfg = LbfgsConfig { max_iter: 500, max_step: 10.0, gtol: 1e-9, ..Default::default() };
        let r = minimize(&[-1.2, 1.0], &cfg, |x| {
            let (a, b) = (x[0], x[1]);
            let f = (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2);
            Some((f, vec![-2.0 * (1.0 - a) - 400.0 * a * (b - a * a), 200.0 * (b - a * a)]))
        })
        .unwrap();
        assert!((r.x[0] - 1.0).abs() < 1e-6 && (r.x[1] - 1.0).abs() < 1e-6, "{:?}", r.x);
    }

    #[test]
    fn backs_off_where_the_objective_is_undefined() {
        // Undefined for x < 0.5; minimum of the defined part at the boundary side x = 1.
        let cfg = LbfgsConfig { max_iter: 100, max_step: 100.0, ..Default::default() };
        let r = minimize(&[3.0], &cfg, |x| (x[0] >= 0.5).then(|| ((x[0] - 1.0).powi(2), vec![2.0 * (x[0] - 1.0)])))
            .unwrap();
        assert!((r.x[0] - 1.0).abs() < 1e-6);
    }
}
