//! The model-based oracle: annealed co-design with exact (or finite-difference) ζ-gradients.
//!
//! For each restart: start from ζ₀, lower α geometrically to `alpha_min`, and at each
//! temperature minimise `J_H(ζ)` of the soft-optimal policy with L-BFGS. A last level at α = 0
//! polishes ζ for the hard objective; the reported policy is the hard-optimal (greedy) one and
//! `J` its exact value. Two kinds of restart:
//!
//! - **anneal** (deterministic annealing): start hot (`alpha0`, default 10× the squared extent
//!   of the instance) where every UAV sits at one point, so ζ₀ is forgotten. Levels hotter than
//!   `alpha_switch` use the finite-horizon form, which cannot diverge; colder levels use the
//!   exact SSP form where its soft values exist and agree with the horizon form.
//! - **warm**: start at a moderate `warm_alpha0` from ζ₀ (random, or `init`) with the SSP form
//!   wherever it exists (horizon form otherwise), as the paper's oracle does; this is the
//!   oracle a model-free run from the same ζ₀ is compared with.
//!
//! Every step stays inside the environment's design bounds (projected L-BFGS, projected
//! perturbations), and the temperatures and horizon default to the environment's
//! [`envpg_core::OracleHints`].
//!
//! On the bundled UAV instance at κ = 1 every anneal restart reaches the same design, but on
//! larger ones (2,000 users and more) annealing at one cooling rate follows one branch of its
//! bifurcations whatever the noise, often into a poor basin; faster schedules and warm starts
//! land elsewhere. With stochastic transitions (κ < 1, η = 100) there are many basins within a
//! few percent of each other. So the default (`Strategy::Auto`) runs a *portfolio* when the
//! model is deterministic at the first ζ₀ — restart 0 anneals at `cooling`, then warm restarts
//! and faster anneals (`cooling²`, `cooling³`, `cooling⁴`) alternate — and otherwise mixes one
//! anneal restart with warm restarts from random ζ₀; the best restart is kept. The portfolio's
//! warm restarts start from the environment's clustered designs
//! ([`ParamMdp::clustered_design`](envpg_core::ParamMdp::clustered_design)) where it has them:
//! on generated UAV instances with 2,000 and 10,000 users, warm restarts from the users' k-means
//! centres reach designs no anneal restart finds, at a fraction of an anneal's cost.
//!
//! A portfolio then *kicks* (basin hopping, [`OracleConfig::kicks`]): warm restarts from the best
//! design so far moved by Gaussian noise, in rounds of [`KICKS_PER_ROUND`]; a kick replaces the
//! best design only if it is better by more than [`KICK_GAIN`]. At 10,000 users the best design
//! often lies in a basin next to the best restart's that no independent restart reaches. Then
//! come *relocation kicks* ([`OracleConfig::relocations`]): colder warm restarts from the best
//! design with one design element moved to serve a costly hop, for basins that differ by where
//! a single UAV sits.

use std::rc::Rc;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use envpg_core::{ModelMdp, Purpose, Streams};
use rand_distr::{Distribution, Normal};

use crate::error::ModelError;
use crate::evaluate::optimal_greedy;
use crate::lbfgs::{Curvature, LbfgsConfig, minimize_with};
use crate::objective::{Form, GradientKind, Objective, Solved};
use crate::snapshot::Snapshot;

mod config;
mod outcome;
mod relocate;

pub use config::{DEFAULT_KICKS, DEFAULT_RELOCATIONS, KICKS_PER_ROUND, OracleConfig, RestartKind, Strategy};
pub use outcome::{Level, OracleOutcome, Restart};

/// Whether every transition of `model` at `zeta` is certain.
pub fn deterministic_at<M: ModelMdp + ?Sized>(model: &M, zeta: &[f64]) -> bool {
    Snapshot::build(model, zeta).prob.iter().all(|&p| p == 0.0 || p == 1.0)
}

/// Runs the oracle on `model`.
pub fn run_oracle<M: ModelMdp + ?Sized>(model: &M, cfg: &OracleConfig) -> Result<OracleOutcome, ModelError> {
    run_oracle_with(model, cfg, &|_| {})
}

/// A restart (or kick) that has just ended, as [`run_oracle_with`] reports it.
#[derive(Debug, Clone, Copy)]
pub struct Finished<'a> {
    /// The restart, `from` set for a kick.
    pub restart: &'a Restart,
    /// Restarts and kicks the run has in all.
    pub total: usize,
}

/// [`run_oracle`], calling `finished` with each restart and kick as it ends — in the order they
/// end, from the threads that ran them — for progress displays. The result does not depend on it.
pub fn run_oracle_with<M: ModelMdp + ?Sized>(
    model: &M,
    cfg: &OracleConfig,
    finished: &(dyn Fn(Finished<'_>) + Sync),
) -> Result<OracleOutcome, ModelError> {
    cfg.validate(model)?;
    let start = Instant::now();
    let streams = Streams::new(cfg.seed);
    let zeta0 = |r: usize| model.random_design(&mut streams.stream(Purpose::Zeta0, r as u64, 0));
    // The designs come from the environment's hooks: a wrong one is an error here, not a panic
    // in the model or inside a restart.
    let checked = |r: usize, z: Vec<f64>| {
        model.zeta_space().check(&z).map_err(|e| ModelError::Invalid(format!("ζ₀ of restart {r}: {e}")))?;
        Ok::<_, ModelError>(z)
    };
    let first = checked(0, cfg.init.clone().unwrap_or_else(|| zeta0(0)))?;
    let deterministic = deterministic_at(model, &first);
    let zeta0s: Vec<Vec<f64>> = std::iter::once(Ok(first))
        .chain((1..cfg.restarts).map(|r| {
            let warm = cfg.portfolio(deterministic) && cfg.restart_kind(r, deterministic) == RestartKind::Warm;
            let clustered =
                if warm { model.clustered_design(&mut streams.stream(Purpose::Zeta0, r as u64, 0)) } else { None };
            checked(r, clustered.unwrap_or_else(|| zeta0(r)))
        }))
        .collect::<Result<_, _>>()?;
    let kicks = cfg.kick_count(deterministic);
    let relocations = cfg.relocation_count(model, deterministic);
    let total = cfg.restarts + kicks + relocations;
    let runner = Runner { model, cfg, streams: &streams, deterministic, finished, total };
    let mut restarts = runner.run(0, &zeta0s, None)?;
    // Kicks: rounds of warm restarts from the best design so far, each moved by noise of one
    // of three scales (a design a little off the best one often descends into a better basin
    // nearby; on large UAV instances the independent restarts rarely reach it).
    let length = cfg_length(model);
    let space = model.zeta_space();
    for k0 in (0..kicks).step_by(KICKS_PER_ROUND) {
        let from = best_of(&restarts, cfg.restarts);
        let round: Vec<Vec<f64>> = (k0..kicks.min(k0 + KICKS_PER_ROUND))
            .map(|k| {
                let sd = cfg.kick_scale * length * f64::from(1u32 << (k % 3));
                let noise = Normal::new(0.0, sd).expect("validated kick scale");
                let mut rng = streams.stream(Purpose::Oracle, (cfg.restarts + k) as u64, 1);
                let mut z = restarts[from].zeta.clone();
                jitter(&mut z, &noise, &mut rng, space);
                z
            })
            .collect();
        restarts.extend(runner.run(cfg.restarts + k0, &round, Some(from))?);
    }
    // Relocation kicks: rounds of colder warm restarts from the best design so far with one
    // design element moved (two basins of a large UAV instance often differ by where one UAV
    // sits, further than any Gaussian kick reaches).
    for k0 in (0..relocations).step_by(KICKS_PER_ROUND) {
        // A round has fewer designs only where few elements can move; the indices stay dense.
        let first = restarts.len();
        let from = best_of(&restarts, cfg.restarts);
        let n = relocations.min(k0 + KICKS_PER_ROUND) - k0;
        let mut rng = streams.stream(Purpose::Oracle, first as u64, 1);
        let round = relocate::relocations(model, &restarts[from].zeta, n, &mut rng, cfg.threads)?;
        restarts.extend(runner.run(first, &round, Some(from))?);
    }
    let best = best_of(&restarts, cfg.restarts);
    let jbest = restarts[best].j;
    let independent = &restarts[..cfg.restarts];
    let hits = independent.iter().filter(|r| r.j <= jbest * (1.0 + cfg.basin_tol)).count();
    let (_, policy, _) = optimal_greedy(model, &restarts[best].zeta)?;
    Ok(OracleOutcome {
        fraction_best: hits as f64 / independent.len() as f64,
        best,
        restarts,
        policy,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Adds a draw of `noise` to each coordinate of `zeta`, in order, and projects it into `space`.
fn jitter(zeta: &mut [f64], noise: &Normal<f64>, rng: &mut impl rand::Rng, space: &envpg_core::ZetaSpace) {
    for z in zeta.iter_mut() {
        *z += noise.sample(rng);
    }
    space.project(zeta);
}

/// A kick replaces the best design only if its J is lower by more than this, relative: a kick
/// that descends back into the same basin ends within rounding of it, and must not take its place.
pub const KICK_GAIN: f64 = 1e-9;

/// The best of `restarts`, whose first `independent` are not kicks: among those, lowest J, then
/// lowest index; then each kick in turn if it is better by more than [`KICK_GAIN`].
fn best_of(restarts: &[Restart], independent: usize) -> usize {
    let mut best = (0..independent.min(restarts.len()))
        .min_by(|&a, &b| restarts[a].j.total_cmp(&restarts[b].j).then(a.cmp(&b)))
        .expect("at least one restart");
    for (i, r) in restarts.iter().enumerate().skip(independent) {
        let jb = restarts[best].j;
        if r.j < jb - KICK_GAIN * jb.abs() {
            best = i;
        }
    }
    best
}

/// Runs the restarts of one oracle run, with what they all share.
struct Runner<'a, M: ?Sized> {
    model: &'a M,
    cfg: &'a OracleConfig,
    streams: &'a Streams,
    deterministic: bool,
    finished: &'a (dyn Fn(Finished<'_>) + Sync),
    total: usize,
}

impl<M: ModelMdp + ?Sized> Runner<'_, M> {
    /// Runs restarts `first`, `first + 1`, … from `zeta0s` (kicks of restart `from`) on up to
    /// `cfg.threads` threads. Restarts cost from a fraction to several times one another (a
    /// slow anneal, then warm starts and faster anneals), so each thread takes the next restart
    /// not yet started rather than a fixed share. A restart depends only on its index, so
    /// results do not depend on which thread ran it.
    fn run(&self, first: usize, zeta0s: &[Vec<f64>], from: Option<usize>) -> Result<Vec<Restart>, ModelError> {
        let n = zeta0s.len();
        let next = AtomicUsize::new(0);
        let results: Vec<OnceLock<Result<Restart, ModelError>>> = (0..n).map(|_| OnceLock::new()).collect();
        std::thread::scope(|scope| {
            for _ in 0..self.cfg.threads.clamp(1, n.max(1)) {
                scope.spawn(|| {
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        if i >= n {
                            break;
                        }
                        let (model, cfg) = (self.model, self.cfg);
                        let r = anneal(model, cfg, first + i, &zeta0s[i], self.streams, self.deterministic);
                        let r = r.map(|r| Restart { from, ..r });
                        if let Ok(restart) = &r {
                            (self.finished)(Finished { restart, total: self.total });
                        }
                        let _ = results[i].set(r);
                    }
                });
            }
        });
        results.into_iter().map(|r| r.into_inner().expect("every restart ran")).collect()
    }
}

/// What a level's line search needs to finish the gradient at a point it accepts.
enum Point {
    /// Already evaluated, gradient and all (the level's form check).
    Evaluated(Vec<f64>),
    /// Solved, gradient pending (the solution is also the next solve's warm start).
    Solved(Rc<Solved>),
}

/// Anneals one restart from `zeta0` (of kind [`OracleConfig::restart_kind`] given whether the
/// model is `deterministic`).
pub fn anneal<M: ModelMdp + ?Sized>(
    model: &M,
    cfg: &OracleConfig,
    index: usize,
    zeta0: &[f64],
    streams: &Streams,
    deterministic: bool,
) -> Result<Restart, ModelError> {
    let start = Instant::now();
    let space = model.zeta_space();
    let bounds = Some((space.lower(), space.upper()));
    let length = cfg_length(model);
    let tight = LbfgsConfig {
        max_iter: cfg.iters_per_level,
        gtol: 1e-9 * length,
        ftol: 1e-13,
        max_step: 0.25 * length,
        ..Default::default()
    };
    let tracking = LbfgsConfig { xtol: cfg.tracking_tol * length, ..tight.clone() };
    let mut rng = streams.stream(Purpose::Oracle, index as u64, 0);
    let noise = Normal::new(0.0, cfg.perturb * length).expect("valid std");
    let mut zeta = zeta0.to_vec();
    let mut warm: Option<Vec<f64>> = None;
    let mut levels = Vec::new();
    let mut fallbacks = 0;
    let mut j_h = f64::NAN;
    let kind = cfg.restart_kind(index, deterministic);
    // Warm restarts use the SSP form wherever it exists; anneal restarts only below the switch.
    let alpha_switch = match kind {
        RestartKind::Anneal => cfg.alpha_switch,
        RestartKind::Warm | RestartKind::Kick | RestartKind::Relocation => f64::INFINITY,
    };
    let cooling = cfg.restart_cooling(index, deterministic);
    let mut alphas = cfg.schedule(kind, cooling);
    if cfg.polish {
        alphas.push(0.0);
    }
    let horizon = Form::Horizon(cfg.horizon);
    // One objective per form for the whole restart: each keeps its last snapshot, whose
    // component decomposition and stages the next level's snapshots reuse.
    // L-BFGS keeps its curvature pairs from one level to the next: the objective at the next
    // temperature is a nearby one, and its first step is then a quasi-Newton step rather than a
    // short one down the gradient.
    let mut curvature = Curvature::default();
    let mut ssp_obj = Objective::new(model, 0.0, Form::Ssp);
    let mut hor_obj = Objective::new(model, 0.0, horizon);
    ssp_obj.gradient = cfg.gradient;
    hor_obj.gradient = cfg.gradient;
    for &alpha in &alphas {
        ssp_obj.alpha = alpha;
        hor_obj.alpha = alpha;
        if alpha > alpha_switch && cfg.perturb > 0.0 {
            jitter(&mut zeta, &noise, &mut rng, space);
        }
        let mut form = if alpha > alpha_switch { horizon } else { Form::Ssp };
        // The level's first evaluation, when the form check below already made it.
        let mut first = None;
        // Near the divergence boundary the SSP objective falls towards −∞ and its gradient
        // explodes, luring ζ into a trap; where the soft SSP values exist they agree with the
        // horizon form to rounding at low α. Use SSP only where it exists and agrees.
        if form == Form::Ssp && alpha > 0.0 {
            // With the exact gradient: where SSP is kept, this is exactly the first evaluation
            // of the level's minimization (same ζ, same warm start), which then reuses it. The
            // central-difference gradient costs 2d solves, too many to spend on a check.
            let ssp = match cfg.gradient {
                GradientKind::Exact => ssp_obj.value_grad(&zeta, warm.as_deref()).map(|e| (e.value, Some(e))),
                GradientKind::Fd => ssp_obj.value(&zeta, warm.as_deref()).map(|(v, _)| (v, None)),
            };
            let hor = hor_obj.value(&zeta, None);
            let agree = match (&ssp, &hor) {
                (Ok((a, _)), Ok((b, _))) => (a - b).abs() <= 1e-6 * (1.0 + b.abs()),
                _ => false,
            };
            if agree {
                first = ssp.ok().and_then(|(_, e)| e);
            } else {
                form = horizon;
                fallbacks += 1;
            }
        }
        let obj = if form == Form::Ssp { &ssp_obj } else { &hor_obj };
        // Each solve warm-starts the next, backed-off trials included (from the level's own
        // warm start until one succeeds); the gradient is computed only where the line search
        // uses it.
        let mut base = warm.clone();
        let mut latest: Option<Rc<Solved>> = None;
        let lb = if alpha > cfg.alpha_min { &tracking } else { &tight };
        let res = minimize_with(
            &zeta,
            bounds,
            lb,
            &mut curvature,
            |z| match first.take() {
                // minimize_lazy starts at ζ itself: ζ is inside the bounds here (no level noise
                // below the switch), so its projection changes no bit.
                Some(e) if z == zeta.as_slice() => {
                    base = Some(e.warm);
                    Some((e.value, Point::Evaluated(e.grad)))
                }
                _ => {
                    let from = latest.as_deref().map(Solved::warm).or(base.as_deref());
                    let solved = Rc::new(obj.solve(z, from).ok()?);
                    latest = Some(Rc::clone(&solved));
                    Some((solved.value, Point::Solved(solved)))
                }
            },
            |_, point| match point {
                Point::Evaluated(g) => Some(g),
                Point::Solved(solved) => obj.gradient(&solved).ok(),
            },
        );
        let Some(res) = res else {
            // Not even the starting point of this level is solvable: report the cause.
            return Err(obj.value(&zeta, None).err().unwrap_or(ModelError::Invalid("objective undefined".into())));
        };
        zeta = res.x;
        warm = latest.map(|s| s.warm().to_vec()).or(base);
        if alpha > 0.0 {
            j_h = res.f;
        }
        levels.push(Level {
            alpha,
            form: if matches!(form, Form::Ssp) { "ssp" } else { "horizon" },
            j_h: res.f,
            grad_norm: res.g.iter().map(|g| g * g).sum::<f64>().sqrt(),
            iterations: res.iterations,
            evaluations: res.evaluations,
            zeta: zeta.clone(),
        });
    }
    let (_, _, j) = optimal_greedy(model, &zeta)?;
    debug_assert_eq!(zeta.len(), model.zeta_dim());
    Ok(Restart {
        index,
        kind,
        from: None,
        cooling,
        zeta0: zeta0.to_vec(),
        zeta,
        j,
        j_h,
        ssp_fallbacks: fallbacks,
        levels,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The length scale of the oracle's steps: the square root of the environment's cost scale.
fn cfg_length<M: ModelMdp + ?Sized>(model: &M) -> f64 {
    model.oracle_hints().cost_scale.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flpo() -> envpg_core::LoadedEnv {
        envpg_envs::registry().load("flpo-n10m4", &[]).unwrap()
    }

    #[test]
    fn a_portfolio_alternates_warm_restarts_and_ever_faster_anneals() {
        let env = flpo();
        let cfg = OracleConfig { cooling: 0.8, ..OracleConfig::for_env(env.model().unwrap()) };
        // Coolings to 1e-12 (`powi` may round differently from one build to another).
        let plan = |cfg: &OracleConfig, deterministic: bool| -> Vec<(RestartKind, i64)> {
            let q = |c: f64| (c * 1e12).round() as i64;
            (0..9).map(|r| (cfg.restart_kind(r, deterministic), q(cfg.restart_cooling(r, deterministic)))).collect()
        };
        let (a, w) = (RestartKind::Anneal, RestartKind::Warm);
        let c = |k: i32| (0.8f64.powi(k) * 1e12).round() as i64;
        let portfolio =
            vec![(a, c(1)), (w, c(1)), (a, c(2)), (w, c(1)), (a, c(3)), (w, c(1)), (a, c(4)), (w, c(1)), (a, c(2))];
        assert_eq!(plan(&cfg, true), portfolio, "auto on a deterministic model");
        assert_eq!(plan(&OracleConfig { strategy: Strategy::Portfolio, ..cfg.clone() }, false), portfolio);
        let mixed: Vec<_> = (0..9).map(|r| (if r == 0 { a } else { w }, c(1))).collect();
        assert_eq!(plan(&cfg, false), mixed, "auto on a stochastic model");
        // A first design of the user's own starts warm; the portfolio follows it.
        let init = OracleConfig { init: Some(env.model().unwrap().heuristic_design().unwrap()), ..cfg.clone() };
        assert_eq!(plan(&init, true)[..4], [(w, c(1)), (a, c(1)), (w, c(1)), (a, c(2))]);
    }

    #[test]
    fn a_portfolio_keeps_the_single_cooling_anneal_as_its_first_restart() {
        // The portfolio never does worse than annealing at `cooling` alone: its restart 0 is that
        // anneal, bit for bit.
        let env = flpo();
        let model = env.model().unwrap();
        let base = OracleConfig { restarts: 3, threads: 1, ..OracleConfig::for_env(model) };
        let portfolio = run_oracle(model, &OracleConfig { strategy: Strategy::Portfolio, ..base.clone() }).unwrap();
        let anneal = run_oracle(model, &OracleConfig { strategy: Strategy::Anneal, ..base }).unwrap();
        assert_eq!(portfolio.restarts[0].zeta, anneal.restarts[0].zeta);
        assert_eq!(portfolio.restarts[0].j.to_bits(), anneal.restarts[0].j.to_bits());
        assert!(portfolio.restarts[portfolio.best].j <= anneal.restarts[0].j);
        assert_eq!(portfolio.restarts[1].kind, RestartKind::Warm);
        assert_eq!(portfolio.restarts[2].cooling, portfolio.restarts[0].cooling.powi(2));
    }

    #[test]
    fn a_portfolio_starts_its_warm_restarts_from_clustered_designs_where_the_env_has_them() {
        let restart_zeta0 = |r: usize| Streams::new(1).stream(Purpose::Zeta0, r as u64, 0);
        // uav (κ = 1): warm restarts from the users' k-means centres, anneals from random ζ₀.
        let uav = envpg_envs::registry().load("uav271", &[]).unwrap();
        let model = uav.model().unwrap();
        let cfg = OracleConfig {
            restarts: 3,
            threads: 2,
            kicks: Some(0),
            relocations: Some(0),
            ..OracleConfig::for_env(model)
        };
        let out = run_oracle(model, &cfg).unwrap();
        let kinds: Vec<_> = out.restarts.iter().map(|r| r.kind).collect();
        assert_eq!(kinds, [RestartKind::Anneal, RestartKind::Warm, RestartKind::Anneal]);
        assert_eq!(out.restarts[1].zeta0, model.clustered_design(&mut restart_zeta0(1)).unwrap());
        for r in [0, 2] {
            assert_eq!(out.restarts[r].zeta0, model.random_design(&mut restart_zeta0(r)));
        }
        // A stochastic model's mixed restarts stay random.
        let noisy = envpg_envs::registry().load("uav271", &[("kappa".into(), 0.9)]).unwrap();
        let model = noisy.model().unwrap();
        let out = run_oracle(model, &OracleConfig { restarts: 2, ..cfg.clone() }).unwrap();
        assert_eq!(out.restarts[1].kind, RestartKind::Warm);
        assert_eq!(out.restarts[1].zeta0, model.random_design(&mut restart_zeta0(1)));
        // flpo has no clustered design: its portfolio's warm restarts start at random designs.
        let env = flpo();
        let model = env.model().unwrap();
        let out = run_oracle(model, &OracleConfig { restarts: 2, ..OracleConfig::for_env(model) }).unwrap();
        assert_eq!(out.restarts[1].kind, RestartKind::Warm);
        assert_eq!(out.restarts[1].zeta0, model.random_design(&mut restart_zeta0(1)));
    }

    /// Every restart, kick and relocation is reported once, as it ends, with the run's total
    /// and the design and J the outcome holds for it (a kick with the restart it moved).
    #[test]
    fn a_run_reports_each_restart_and_kick_as_it_ends() {
        let env = flpo();
        let model = env.model().unwrap();
        let cfg = OracleConfig {
            restarts: 3,
            kicks: Some(3),
            relocations: Some(2),
            threads: 2,
            ..OracleConfig::for_env(model)
        };
        let seen = std::sync::Mutex::new(Vec::new());
        let out = run_oracle_with(model, &cfg, &|f| {
            let r = f.restart;
            seen.lock().unwrap().push((r.index, f.total, r.from, r.j.to_bits(), r.zeta.clone()));
        })
        .unwrap();
        let mut seen = seen.into_inner().unwrap();
        seen.sort_by_key(|s| s.0);
        assert_eq!(seen.len(), 8, "three restarts, three kicks and two relocations, each once");
        for (s, r) in seen.iter().zip(&out.restarts) {
            assert_eq!(s, &(r.index, 8, r.from, r.j.to_bits(), r.zeta.clone()));
        }
        assert!(out.restarts[3..].iter().all(|r| r.from.is_some()), "kicks say which restart they moved");
        let quiet = run_oracle(model, &cfg).unwrap();
        assert_eq!(quiet.best, out.best);
        assert_eq!(quiet.restarts[out.best].j.to_bits(), out.restarts[out.best].j.to_bits());
    }

    #[test]
    fn restarts_end_the_same_whatever_the_thread_count() {
        // Threads take restarts as they free up, so which thread runs which restart varies;
        // each restart's design and J must not.
        let env = flpo();
        let model = env.model().unwrap();
        let run = |threads| run_oracle(model, &OracleConfig { restarts: 5, threads, ..OracleConfig::for_env(model) });
        let one = run(1).unwrap();
        assert_eq!(one.restarts.len(), 5 + DEFAULT_KICKS + DEFAULT_RELOCATIONS, "the default kicks run too");
        for threads in [2, 3] {
            let many = run(threads).unwrap();
            assert_eq!(many.best, one.best);
            for (a, b) in one.restarts.iter().zip(&many.restarts) {
                assert_eq!((a.index, &a.zeta, a.j.to_bits()), (b.index, &b.zeta, b.j.to_bits()), "{threads} threads");
            }
        }
    }

    #[test]
    fn kicks_start_near_the_best_design_so_far_and_never_lose_it() {
        let env = flpo();
        let model = env.model().unwrap();
        let base = OracleConfig { restarts: 3, threads: 1, relocations: Some(0), ..OracleConfig::for_env(model) };
        let plain = run_oracle(model, &OracleConfig { kicks: Some(0), ..base.clone() }).unwrap();
        let kicked = run_oracle(model, &OracleConfig { kicks: Some(5), ..base.clone() }).unwrap();
        assert_eq!(plain.restarts.len(), 3);
        assert_eq!(kicked.restarts.len(), 8);
        // The restarts before the kicks are untouched, bit for bit.
        for (a, b) in plain.restarts.iter().zip(&kicked.restarts) {
            assert_eq!((a.kind, &a.zeta, a.j.to_bits(), a.from), (b.kind, &b.zeta, b.j.to_bits(), b.from));
        }
        // Rounds of two (the last one short), each from the best design when the round began.
        let length = cfg_length(model);
        for (k, r) in kicked.restarts[3..].iter().enumerate() {
            assert_eq!((r.index, r.kind), (3 + k, RestartKind::Kick));
            let round_start = 3 + k / KICKS_PER_ROUND * KICKS_PER_ROUND;
            let from = r.from.expect("a kick names its origin");
            assert_eq!(from, best_of(&kicked.restarts[..round_start], 3), "kick {k}");
            model.zeta_space().check(&r.zeta0).unwrap();
            let moved = r.zeta0.iter().zip(&kicked.restarts[from].zeta).map(|(a, b)| (a - b).powi(2)).sum::<f64>();
            let sd = base.kick_scale * length * f64::from(1u32 << (k % 3));
            let d = r.zeta0.len() as f64;
            // Projection only shortens the move; 5 sd² · d bounds a χ²_d draw with ample margin.
            assert!(moved > 0.0 && moved < 5.0 * sd * sd * d, "kick {k}: moved {moved}, sd {sd}");
        }
        let (jk, jp) = (kicked.restarts[kicked.best].j, plain.restarts[plain.best].j);
        assert!(jk <= jp);
        // A kick is the best only if it is better beyond rounding.
        if kicked.best >= 3 {
            assert!(jk < jp * (1.0 - KICK_GAIN));
        } else {
            assert_eq!(kicked.best, plain.best);
        }
        // The fraction at the best counts the independent restarts only.
        let jbest = kicked.restarts[kicked.best].j;
        let hits = plain.restarts.iter().filter(|r| r.j <= jbest * (1.0 + base.basin_tol)).count();
        assert_eq!(kicked.fraction_best, hits as f64 / 3.0);
    }

    #[test]
    fn kicks_are_off_outside_a_portfolio_unless_asked_for() {
        let env = flpo();
        let model = env.model().unwrap();
        let cfg = OracleConfig { restarts: 2, ..OracleConfig::for_env(model) };
        assert_eq!(cfg.kick_count(true), DEFAULT_KICKS);
        assert_eq!(cfg.kick_count(false), 0, "auto on a stochastic model is mixed");
        assert_eq!(OracleConfig { strategy: Strategy::Warm, ..cfg.clone() }.kick_count(true), 0);
        assert_eq!(OracleConfig { strategy: Strategy::Warm, kicks: Some(2), ..cfg.clone() }.kick_count(true), 2);
        assert_eq!(cfg.relocation_count(model, true), DEFAULT_RELOCATIONS, "flpo's facilities move");
        assert_eq!(cfg.relocation_count(model, false), 0);
        assert_eq!(OracleConfig { relocations: Some(3), ..cfg.clone() }.relocation_count(model, false), 3);
        let warm = run_oracle(model, &OracleConfig { strategy: Strategy::Warm, ..cfg.clone() }).unwrap();
        assert_eq!(warm.restarts.len(), 2);
        let bad = OracleConfig { kick_scale: f64::NAN, ..cfg.clone() };
        assert!(bad.validate(model).unwrap_err().to_string().contains("kick_scale"));
        let bad = OracleConfig { relocation_alpha0: Some(0.0), ..cfg };
        assert!(bad.validate(model).unwrap_err().to_string().contains("relocation_alpha0"));
        // An environment with no design elements has nothing to relocate.
        let aac = envpg_envs::registry().load("aac1800", &[]).unwrap();
        let aac = aac.model().unwrap();
        let cfg = OracleConfig { restarts: 2, relocations: Some(4), ..OracleConfig::for_env(aac) };
        assert!(aac.design_elements().len() < 2);
        assert_eq!(cfg.relocation_count(aac, true), 0);
    }

    /// A relocation kick starts from the best design so far with exactly one design element
    /// moved, at the colder temperature, two per round from the best design after the round before; the result is
    /// never worse than without them.
    #[test]
    fn relocation_kicks_move_one_design_element_and_never_lose_the_best() {
        let env = flpo();
        let model = env.model().unwrap();
        let base = OracleConfig { restarts: 3, threads: 2, kicks: Some(2), ..OracleConfig::for_env(model) };
        let plain = run_oracle(model, &OracleConfig { relocations: Some(0), ..base.clone() }).unwrap();
        let moved = run_oracle(model, &OracleConfig { relocations: Some(4), ..base.clone() }).unwrap();
        assert_eq!(moved.restarts.len(), 9);
        for (a, b) in plain.restarts.iter().zip(&moved.restarts) {
            assert_eq!((a.index, &a.zeta, a.j.to_bits()), (b.index, &b.zeta, b.j.to_bits()));
        }
        let elements = model.design_elements();
        for (k, r) in moved.restarts[5..].iter().enumerate() {
            assert_eq!((r.index, r.kind), (5 + k, RestartKind::Relocation));
            let round_start = 5 + k / KICKS_PER_ROUND * KICKS_PER_ROUND;
            let from = r.from.expect("a relocation names its origin");
            assert_eq!(from, best_of(&moved.restarts[..round_start], 3), "relocation {k}");
            let origin = &moved.restarts[from].zeta;
            let changed: Vec<_> =
                elements.iter().filter(|e| e.coords.clone().any(|i| r.zeta0[i] != origin[i])).collect();
            assert_eq!(changed.len(), 1, "relocation {k} moves one element");
            let untouched = (0..origin.len()).filter(|i| !changed[0].coords.contains(i));
            assert!(untouched.into_iter().all(|i| r.zeta0[i] == origin[i]));
            assert_eq!(r.levels[0].alpha, 0.1 * base.warm_alpha0, "relocations start colder");
        }
        // The two of a round move different elements.
        for pair in moved.restarts[5..].chunks(2) {
            let which = |r: &Restart| {
                let origin = &moved.restarts[r.from.unwrap()].zeta;
                elements.iter().position(|e| e.coords.clone().any(|i| r.zeta0[i] != origin[i])).unwrap()
            };
            assert_ne!(which(&pair[0]), which(&pair[1]));
        }
        assert!(moved.restarts[moved.best].j <= plain.restarts[plain.best].j);
    }

    /// Levels that only track the minimiser stop at the first short step: far fewer evaluations,
    /// and the same design (J to 1e-9) as converging every level fully, for an anneal and a warm
    /// restart on uav271 (κ = 1 and 0.85) and flpo.
    #[test]
    fn tracking_levels_end_at_the_design_of_fully_converged_ones_for_fewer_evaluations() {
        let cases: [(&str, &[(&str, f64)]); 3] =
            [("uav271", &[("kappa", 1.0)]), ("uav271", &[("kappa", 0.85)]), ("flpo-n10m4", &[])];
        for (name, params) in cases {
            let params: Vec<(String, f64)> = params.iter().map(|&(k, v)| (k.to_string(), v)).collect();
            let env = envpg_envs::registry().load(name, &params).unwrap();
            let model = env.model().unwrap();
            let streams = Streams::new(1);
            let zeta0 = model.random_design(&mut streams.stream(Purpose::Zeta0, 0, 0));
            for strategy in [Strategy::Anneal, Strategy::Warm] {
                let cfg = OracleConfig { strategy, threads: 1, ..OracleConfig::for_env(model) };
                let full = OracleConfig { tracking_tol: 0.0, ..cfg.clone() };
                let det = deterministic_at(model, &zeta0);
                let fast = anneal(model, &cfg, 0, &zeta0, &streams, det).unwrap();
                let slow = anneal(model, &full, 0, &zeta0, &streams, det).unwrap();
                let evals = |r: &Restart| r.levels.iter().map(|l| l.evaluations).sum::<usize>();
                let what = format!("{name} {params:?} {strategy:?}");
                assert!((fast.j - slow.j).abs() <= 1e-9 * slow.j, "{what}: J {} vs {}", fast.j, slow.j);
                assert!(evals(&fast) < evals(&slow), "{what}: {} vs {} evaluations", evals(&fast), evals(&slow));
            }
        }
        let env = flpo();
        let bad = OracleConfig { tracking_tol: -1.0, ..OracleConfig::for_env(env.model().unwrap()) };
        assert!(bad.validate(env.model().unwrap()).unwrap_err().to_string().contains("tracking_tol"));
    }
}
