//! A small L-BFGS minimiser with Armijo backtracking and a step-length cap.
//!
//! Hand-written because the oracle needs two things general-purpose crates make awkward:
//! objective evaluations that may *fail* (soft value iteration diverging at a trial point is
//! treated as +∞ and backtracked from), and warm-start state threaded through evaluations.
//! An annealing run also threads the quasi-Newton state itself ([`Curvature`]) from one
//! temperature to the next, through [`minimize_with`].

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
    /// Stop when one iteration's step is no longer than this (Euclidean).
    pub xtol: f64,
    /// Maximum Euclidean length of one step.
    pub max_step: f64,
}

impl Default for LbfgsConfig {
    fn default() -> Self {
        Self { max_iter: 50, memory: 8, gtol: 1e-7, ftol: 1e-12, xtol: 0.0, max_step: 1.0 }
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
    f: impl FnMut(&[f64]) -> Option<(f64, Vec<f64>)>,
) -> Option<LbfgsResult> {
    minimize_in(x0, None, cfg, f)
}

/// [`minimize`] inside the box `lower ≤ x ≤ upper` (infinite bounds allowed): projected
/// L-BFGS. Coordinates at a bound whose gradient points outward are *active* — held at the
/// bound, left out of the quasi-Newton direction and of the convergence test — and every trial
/// point is projected onto the box, with the Armijo test on the projected step. `x0` is
/// projected first. Without finite bounds this is exactly the unconstrained algorithm.
pub fn minimize_in(
    x0: &[f64],
    bounds: Option<(&[f64], &[f64])>,
    cfg: &LbfgsConfig,
    f: impl FnMut(&[f64]) -> Option<(f64, Vec<f64>)>,
) -> Option<LbfgsResult> {
    minimize_lazy(x0, bounds, cfg, f, |_, g| Some(g))
}

/// [`minimize_in`] with the gradient finished apart from the value: `value(x)` returns `f(x)`
/// and whatever `grad` needs to compute `∇f(x)` there, and `grad(x, that)` is called only where
/// the gradient is used — at `x0` and at accepted steps, never at a point the line search backs
/// off from. A point whose gradient is undefined (`None`) counts as undefined; the iterates,
/// values and counts are those of [`minimize_in`] on the pair.
pub fn minimize_lazy<S>(
    x0: &[f64],
    bounds: Option<(&[f64], &[f64])>,
    cfg: &LbfgsConfig,
    value: impl FnMut(&[f64]) -> Option<(f64, S)>,
    grad: impl FnMut(&[f64], S) -> Option<Vec<f64>>,
) -> Option<LbfgsResult> {
    minimize_with(x0, bounds, cfg, &mut Curvature::default(), value, grad)
}

/// The curvature pairs `(s, y, 1/sᵀy)` L-BFGS has gathered, newest last.
#[derive(Debug, Clone, Default)]
pub struct Curvature {
    pairs: std::collections::VecDeque<(Vec<f64>, Vec<f64>, f64)>,
}

/// [`minimize_lazy`] starting from the curvature pairs in `history` (of a nearby objective, such
/// as the previous temperature of an anneal) and leaving there those it ends with.
pub fn minimize_with<S>(
    x0: &[f64],
    bounds: Option<(&[f64], &[f64])>,
    cfg: &LbfgsConfig,
    history: &mut Curvature,
    mut value: impl FnMut(&[f64]) -> Option<(f64, S)>,
    mut grad: impl FnMut(&[f64], S) -> Option<Vec<f64>>,
) -> Option<LbfgsResult> {
    let n = x0.len();
    let bounds = bounds.filter(|(l, u)| l.iter().chain(u.iter()).any(|b| b.is_finite()));
    let project = |x: &mut [f64]| -> bool {
        let mut clamped = false;
        if let Some((l, u)) = bounds {
            for i in 0..x.len() {
                if x[i] < l[i] {
                    x[i] = l[i];
                    clamped = true;
                } else if x[i] > u[i] {
                    x[i] = u[i];
                    clamped = true;
                }
            }
        }
        clamped
    };
    // The gradient with the active coordinates zeroed.
    let projected_gradient = |x: &[f64], g: &[f64]| -> Vec<f64> {
        match bounds {
            None => g.to_vec(),
            Some((l, u)) => (0..n)
                .map(|i| if (x[i] <= l[i] && g[i] > 0.0) || (x[i] >= u[i] && g[i] < 0.0) { 0.0 } else { g[i] })
                .collect(),
        }
    };
    let mut x = x0.to_vec();
    project(&mut x);
    let (mut fx, at) = value(&x)?;
    let mut g = grad(&x, at)?;
    let mut evals = 1;
    let hist = &mut history.pairs;
    if hist.front().is_some_and(|(s, _, _)| s.len() != n) {
        hist.clear();
    }
    let mut iterations = 0;
    while iterations < cfg.max_iter {
        let pg = projected_gradient(&x, &g);
        let gnorm = pg.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if gnorm <= cfg.gtol {
            break;
        }
        iterations += 1;
        // Two-loop recursion.
        let mut d: Vec<f64> = pg.iter().map(|v| -v).collect();
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
            let scale = (0.1 * cfg.max_step / dot(&pg, &pg).sqrt()).min(1.0);
            d.iter_mut().for_each(|v| *v *= scale);
        }
        for ((s, y, rho), a) in hist.iter().zip(alphas.iter().rev()) {
            let b = rho * dot(y, &d);
            for i in 0..n {
                d[i] += (a - b) * s[i];
            }
        }
        if bounds.is_some() {
            for i in 0..n {
                if pg[i] == 0.0 && g[i] != 0.0 {
                    d[i] = 0.0;
                }
            }
        }
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            hist.clear();
            d = pg.iter().map(|v| -v).collect();
            slope = dot(&g, &d);
        }
        let len = dot(&d, &d).sqrt();
        let mut t = if len > cfg.max_step { cfg.max_step / len } else { 1.0 };
        let mut accepted = None;
        for _ in 0..24 {
            let mut xt: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + t * b).collect();
            // A projected step's decrease is measured along the step actually taken.
            let expected = if project(&mut xt) {
                let step: Vec<f64> = xt.iter().zip(&x).map(|(a, b)| a - b).collect();
                dot(&g, &step)
            } else {
                t * slope
            };
            evals += 1;
            if let Some((ft, at)) = value(&xt)
                && ft.is_finite()
                && ft <= fx + 1e-4 * expected
                && let Some(gt) = grad(&xt, at)
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
        let step = dot(&s, &s).sqrt();
        if sy > 1e-12 * step * dot(&y, &y).sqrt() {
            if hist.len() == cfg.memory {
                hist.pop_front();
            }
            hist.push_back((s, y, 1.0 / sy));
        }
        let decrease = fx - fnew;
        x = xn;
        fx = fnew;
        g = gn;
        if decrease <= cfg.ftol * (1.0 + fx.abs()) || step <= cfg.xtol {
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
    fn stays_in_the_box_and_stops_at_a_bound_minimum() {
        // Minimum of (x−2)² + (y+1)² over [0, 1] × [0, 1] is the corner (1, 0).
        let cfg = LbfgsConfig { max_iter: 100, max_step: 10.0, gtol: 1e-10, ftol: 0.0, ..Default::default() };
        let (lo, hi) = ([0.0, 0.0], [1.0, 1.0]);
        let mut inside = true;
        let r = minimize_in(&[0.5, 0.5], Some((&lo, &hi)), &cfg, |x| {
            inside &= (0.0..=1.0).contains(&x[0]) && (0.0..=1.0).contains(&x[1]);
            Some(((x[0] - 2.0).powi(2) + (x[1] + 1.0).powi(2), vec![2.0 * (x[0] - 2.0), 2.0 * (x[1] + 1.0)]))
        })
        .unwrap();
        assert!(inside, "every evaluation inside the box");
        assert_eq!(r.x, vec![1.0, 0.0]);
        // An interior minimum is found as without bounds.
        let r = minimize_in(&[0.9, 0.1], Some((&lo, &hi)), &cfg, |x| {
            Some(((x[0] - 0.3).powi(2) + 3.0 * (x[1] - 0.6).powi(2), vec![2.0 * (x[0] - 0.3), 6.0 * (x[1] - 0.6)]))
        })
        .unwrap();
        assert!((r.x[0] - 0.3).abs() < 1e-8 && (r.x[1] - 0.6).abs() < 1e-8, "{:?}", r.x);
    }

    #[test]
    fn infinite_bounds_are_the_unconstrained_algorithm() {
        let cfg = LbfgsConfig { max_iter: 200, max_step: 10.0, gtol: 1e-9, ..Default::default() };
        let rosen = |x: &[f64]| {
            let (a, b) = (x[0], x[1]);
            Some((
                (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2),
                vec![-2.0 * (1.0 - a) - 400.0 * a * (b - a * a), 200.0 * (b - a * a)],
            ))
        };
        let free = minimize(&[-1.2, 1.0], &cfg, rosen).unwrap();
        let inf = [f64::NEG_INFINITY, f64::NEG_INFINITY];
        let sup = [f64::INFINITY, f64::INFINITY];
        let boxed = minimize_in(&[-1.2, 1.0], Some((&inf, &sup)), &cfg, rosen).unwrap();
        assert_eq!((free.x, free.iterations, free.evaluations), (boxed.x, boxed.iterations, boxed.evaluations));
    }

    /// The gradient is finished only at the start and at accepted steps, and the iterates are
    /// those of the eager minimiser to the bit.
    #[test]
    fn a_lazy_gradient_is_computed_only_where_a_step_is_accepted() {
        let cfg = LbfgsConfig { max_iter: 200, max_step: 10.0, gtol: 1e-9, ..Default::default() };
        let f = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
        let g =
            |x: &[f64]| vec![-2.0 * (1.0 - x[0]) - 400.0 * x[0] * (x[1] - x[0] * x[0]), 200.0 * (x[1] - x[0] * x[0])];
        let eager = minimize(&[-1.2, 1.0], &cfg, |x| Some((f(x), g(x)))).unwrap();
        let (mut values, mut grads) = (0, 0);
        let lazy = minimize_lazy(
            &[-1.2, 1.0],
            None,
            &cfg,
            |x| {
                values += 1;
                Some((f(x), x.to_vec()))
            },
            |x, at| {
                assert_eq!(x, &at[..], "the gradient is asked at the point just evaluated");
                grads += 1;
                Some(g(x))
            },
        )
        .unwrap();
        assert_eq!((lazy.x.clone(), lazy.f.to_bits(), lazy.iterations), (eager.x, eager.f.to_bits(), eager.iterations));
        assert_eq!((values, lazy.evaluations), (eager.evaluations, eager.evaluations));
        assert_eq!(grads, lazy.iterations + 1, "x0 and one accepted step an iteration");
        assert!(values > grads, "some trial points were backed off from, without a gradient");
    }

    /// A point whose value exists but whose gradient does not is backed off from.
    #[test]
    fn a_point_without_a_gradient_is_backed_off_from() {
        let cfg = LbfgsConfig { max_iter: 100, max_step: 100.0, ..Default::default() };
        let r = minimize_lazy(
            &[3.0],
            None,
            &cfg,
            |x| Some(((x[0] - 1.0).powi(2), ())),
            |x, ()| (x[0] >= 0.5).then(|| vec![2.0 * (x[0] - 1.0)]),
        )
        .unwrap();
        assert!((r.x[0] - 1.0).abs() < 1e-6);
    }

    /// An ill-conditioned quadratic `Σ kᵢ (xᵢ − cᵢ)²` with its gradient.
    fn bowl(c: [f64; 3]) -> impl Fn(&[f64]) -> Option<(f64, Vec<f64>)> {
        let k = [1.0, 30.0, 400.0];
        move |x: &[f64]| {
            let f = (0..3).map(|i| k[i] * (x[i] - c[i]).powi(2)).sum();
            Some((f, (0..3).map(|i| 2.0 * k[i] * (x[i] - c[i])).collect()))
        }
    }

    /// Started with the curvature pairs of a minimisation of the same bowl at another centre, the
    /// next minimisation reaches the same point in fewer evaluations; without them it is
    /// exactly [`minimize_lazy`].
    #[test]
    fn curvature_carried_from_a_nearby_objective_saves_evaluations() {
        let cfg = LbfgsConfig { max_iter: 200, max_step: 10.0, gtol: 1e-10, ftol: 0.0, ..Default::default() };
        let mut history = Curvature::default();
        let first = minimize_with(&[0.0; 3], None, &cfg, &mut history, bowl([1.0, 2.0, 3.0]), |_, g| Some(g)).unwrap();
        assert!(!history.pairs.is_empty(), "the first minimisation leaves its pairs");
        let moved = bowl([1.2, 1.9, 3.1]);
        let fresh = minimize_lazy(&first.x, None, &cfg, &moved, |_, g| Some(g)).unwrap();
        let cold = minimize_with(&first.x, None, &cfg, &mut Curvature::default(), &moved, |_, g| Some(g)).unwrap();
        assert_eq!((&cold.x, cold.evaluations), (&fresh.x, fresh.evaluations), "no pairs: minimize_lazy");
        let warm = minimize_with(&first.x, None, &cfg, &mut history, &moved, |_, g| Some(g)).unwrap();
        for (a, b) in warm.x.iter().zip([1.2, 1.9, 3.1]) {
            assert!((a - b).abs() < 1e-9, "{:?}", warm.x);
        }
        assert!(warm.evaluations < fresh.evaluations, "{} vs {}", warm.evaluations, fresh.evaluations);
        // Pairs of another dimension are dropped, not used.
        let mut other = Curvature::default();
        minimize_with(
            &[0.0; 2],
            None,
            &cfg,
            &mut other,
            |x| Some((x[0] * x[0] + x[1] * x[1], vec![2.0 * x[0], 2.0 * x[1]])),
            |_, g| Some(g),
        );
        let dropped = minimize_with(&first.x, None, &cfg, &mut other, &moved, |_, g| Some(g)).unwrap();
        assert_eq!((&dropped.x, dropped.evaluations), (&fresh.x, fresh.evaluations));
    }

    /// `xtol` stops at the first step shorter than it: earlier than the gradient test would,
    /// with that last step as short as asked.
    #[test]
    fn a_step_tolerance_stops_at_the_first_short_step() {
        let tight = LbfgsConfig { max_iter: 200, max_step: 10.0, gtol: 1e-12, ftol: 0.0, ..Default::default() };
        let loose = LbfgsConfig { xtol: 1e-3, ..tight.clone() };
        let mut steps = Vec::new();
        let mut last: Option<Vec<f64>> = None;
        let full = minimize(&[0.0; 3], &tight, bowl([1.0, 2.0, 3.0])).unwrap();
        let early = minimize(&[0.0; 3], &loose, |x| {
            if let Some(p) = &last {
                steps.push(p.iter().zip(x).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt());
            }
            last = Some(x.to_vec());
            bowl([1.0, 2.0, 3.0])(x)
        })
        .unwrap();
        assert!(early.iterations < full.iterations, "{} vs {}", early.iterations, full.iterations);
        let dist = early.x.iter().zip([1.0, 2.0, 3.0]).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
        assert!(dist < 1e-2, "near the minimum: {dist}");
        assert!(steps.last().is_some_and(|&s| s <= 1e-3), "the last step is short: {steps:?}");
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
