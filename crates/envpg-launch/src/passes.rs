//! `--passes N`: Algorithm 1 run N times, each pass with a seed of its own, and the best pass
//! kept — a model-free way out of a poor basin.
//!
//! Pass P trains in `DIR/pass-P/` (a run directory of its own: `run.json`, metrics, log,
//! checkpoints, `result.json`) with the run's settings and a seed of its own ([`pass_seed`]).
//! Where it starts is [`PassStart`]: the run's `--zeta0`, drawn anew with the pass's seed where
//! it is drawn (`fresh`, independent passes), the design of the best pass before it
//! (`best`), that design moved by noise (`kick`, [`kick_start`]), moved by noise with the
//! best pass's networks kept and the end of the schedule trained again (`warm`, the default,
//! [`warm_from`]), or the first half `fresh` and the rest `warm` (`portfolio`,
//! [`PassStart::of_pass`]). Passes are ranked by
//! [`envpg_ac::polish::score_designs`]: each finished pass's design and greedy policy sampled on
//! the same episodes, the lowest mean cost first — the environment's sampler only, never its
//! model; each pass is scored once, when first ranked. The kept pass's result file, with every
//! pass listed in `details.passes`, is the run's result. A pass whose `result.json` exists is
//! done, so `--resume DIR` continues with the first pass that is not.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use envpg_ac::Zeta0;
use envpg_ac::polish::{PolishSettings, RankScore, best_of, score_designs};
use envpg_core::policy::actions_from_rows;
use envpg_core::{LoadedEnv, Purpose, Registry, ResultFile, Streams};
use rand::Rng;
use serde_json::json;

use crate::run_dir::RunFile;
use crate::train::{Pass, train_pass};
use crate::{InputError, LaunchArgs};

/// Where the passes after the first start (`--pass-start`). Measured (docs/uav-results.md,
/// "Thousands of users"): `warm` ahead of `best` at 2,000 and 10,000 users, of `fresh` at
/// 10,000 users, where one pass has not finished improving, and of `portfolio` at both (on
/// held-out instances at 2,000 users, worst run +0.03% against +0.85%), for about half a
/// pass's time per pass — hence the default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PassStart {
    /// From the design of the best pass so far: a run that had not finished improving
    /// continues from there.
    Best,
    /// From the run's `--zeta0`, drawn anew with the pass's seed (`random`, `clustered`):
    /// independent restarts, for a run that ends in a poor basin.
    Fresh,
    /// From the design of the best pass so far moved by Gaussian noise ([`kick_start`]):
    /// basin hopping, for a run whose passes keep ending in the same poor basin.
    Kick,
    /// As `kick`, and the pass trains on from the best pass's networks rather than from new
    /// ones, over the last [`WARM_FRACTION`] of the schedule only ([`warm_from`]): a local
    /// search from the kicked design with the policy kept, as the oracle's kicks are.
    #[default]
    Warm,
    /// The first half of the passes (rounded up, [`fresh_passes`]) as `fresh`, the rest as
    /// `warm` from the best of all passes so far, their kicks 2%, 4%, 8%, … from the first
    /// warm pass on: independent restarts, then a local search from the best — the oracle's
    /// portfolio of restarts and kicks, for runs where either alone misses the best basin.
    Portfolio,
}

impl PassStart {
    /// How pass `p` (from 2) of `passes` starts, as one of `best`, `fresh`, `kick` or `warm`,
    /// and the index of its kick among the run's kicked passes (0 for the first).
    pub fn of_pass(self, p: usize, passes: usize) -> (PassStart, usize) {
        match self {
            PassStart::Portfolio if p <= fresh_passes(passes) => (PassStart::Fresh, 0),
            PassStart::Portfolio => (PassStart::Warm, p - fresh_passes(passes) - 1),
            start => (start, p - 2),
        }
    }
}

/// The passes a `--pass-start portfolio` run of `passes` passes starts `fresh`: the first
/// `⌈passes / 2⌉` (pass 1 included).
pub fn fresh_passes(passes: usize) -> usize {
    passes.div_ceil(2)
}

/// The share of the schedule a `--pass-start warm` pass trains again: from iteration
/// [`warm_from`] on, at that iteration's α (the window over which the reported design is
/// averaged, with the default `zeta_average`).
pub const WARM_FRACTION: f64 = 0.25;

/// The iteration a `--pass-start warm` pass of a run of `iterations` iterations starts from:
/// the last `⌈WARM_FRACTION · iterations⌉` are trained again.
pub fn warm_from(iterations: usize) -> u64 {
    (iterations - (WARM_FRACTION * iterations as f64).ceil() as usize) as u64
}

/// Standard deviation of the first kick, relative to each coordinate's scale
/// ([`envpg_core::ZetaSpace::scale`]); kick `k` (pass `k + 2`) uses `2^(k mod 3)` times it. On the
/// UAV network (scale: half the diagonal of the box of users and destination) these are the
/// oracle's kicks, 1%, 2% and 4% of the diagonal.
pub const KICK_SCALE: f64 = 0.02;

/// Stream key of the kicks' noise.
const PASS_KICKS: u64 = 0x6b69_636b;

/// The start of pass `p` (from 2), the run's kick number `kick` (from 0; `p − 2` with
/// `--pass-start kick` or `warm`, [`PassStart::of_pass`]): `best` moved by
/// [`ZetaSpace::kick`](envpg_core::ZetaSpace::kick) with relative standard deviation
/// `KICK_SCALE · 2^(kick mod 3)`, from the run's `streams` keyed by the pass.
pub(crate) fn kick_start(
    best: &[f64],
    space: &envpg_core::ZetaSpace,
    streams: &Streams,
    p: usize,
    kick: usize,
) -> Vec<f64> {
    let relative = KICK_SCALE * f64::from(1u32 << (kick % 3));
    space.kick(best, relative, &mut streams.stream(Purpose::Other, PASS_KICKS, p as u64))
}

/// `DIR/pass-P`.
pub(crate) fn pass_dir(dir: &Path, pass: usize) -> PathBuf {
    dir.join(format!("pass-{pass}"))
}

/// Checks, before any process starts, that every pass directory of the run in `dir` that has a
/// checkpoint and no result yet can continue from it (same run, readable): a corrupt or
/// foreign checkpoint is bad input, found now rather than after the passes before it.
pub(crate) fn check_resumable(top: &RunFile, dir: &Path) -> Result<()> {
    for p in 1..=top.passes {
        let pdir = pass_dir(dir, p);
        if RunFile::result_copy_path(&pdir).exists() || !RunFile::checkpoint_path(&pdir).exists() {
            continue;
        }
        let run = RunFile::load(&pdir).map_err(|e| InputError(format!("--resume {}: {e:#}", dir.display())))?;
        run.load_checkpoint(&pdir).map_err(|e| InputError(format!("--resume {}: {e}", dir.display())))?;
    }
    Ok(())
}

/// Stream key of the passes' seeds.
const PASS_SEEDS: u64 = 0x7061_7373;

/// The seed of pass `p` (from 1) of a run with seed `seed`: the run's own for pass 1 (so pass 1
/// is the one-pass run, bit for bit), for the others a draw from the run seed's stream keyed by
/// the pass.
pub(crate) fn pass_seed(seed: u64, p: usize) -> u64 {
    if p == 1 { seed } else { Streams::new(seed).stream(Purpose::Other, PASS_SEEDS, p as u64).next_u64() }
}

/// The description of pass `p` of `top`: its own run id (service names) and seed
/// ([`pass_seed`]), ζ₀ `zeta0` where given (pass 1: the run's), its result in its directory,
/// no further passes.
fn pass_run(top: &RunFile, p: usize, dir: &Path, zeta0: Option<&[f64]>) -> RunFile {
    let mut run = top.clone();
    run.run_id = format!("{}p{p}", top.run_id);
    run.spec.seed = pass_seed(top.spec.seed, p);
    run.passes = 1;
    run.out = RunFile::result_copy_path(&pass_dir(dir, p));
    run.tensorboard = top.tensorboard.as_ref().map(|t| t.join(format!("pass-{p}")));
    if let Some(z) = zeta0 {
        run.spec.config.zeta0 = Zeta0::Given(z.to_vec());
    }
    run
}

/// Runs (or, `resuming`, continues) the passes of `top` in `dir`, ranks them and writes the
/// best one's result, with every pass listed, to `top.out`.
pub(crate) fn run(top: &RunFile, dir: &Path, resuming: bool, launch: &LaunchArgs, registry: &Registry) -> Result<()> {
    let env = top.spec.load(registry).map_err(|e| InputError(format!("{e:#}")))?;
    let settings = top.spec.config.polish();
    let streams = Streams::new(top.spec.seed);
    let mut done: Vec<ResultFile> = Vec::with_capacity(top.passes);
    let mut ranking = Ranking { env: &env, settings, streams, scores: Vec::with_capacity(top.passes), seconds: 0.0 };
    for p in 1..=top.passes {
        let pdir = pass_dir(dir, p);
        let copy = RunFile::result_copy_path(&pdir);
        // Ranked before every pass that starts from the best, resumed or not (a few
        // milliseconds), so that a resumed run scores the passes an uninterrupted one does.
        let (mode, kick) = if p == 1 { (PassStart::Fresh, 0) } else { top.pass_start.of_pass(p, top.passes) };
        let best = match mode {
            PassStart::Fresh => None,
            _ => Some(ranking.best(&done)),
        };
        let start = best.map(|b| match mode {
            PassStart::Kick | PassStart::Warm => {
                kick_start(&done[b].zeta, env.sampler().zeta_space(), &streams, p, kick)
            }
            _ => done[b].zeta.clone(),
        });
        // `warm`: the pass starts from the best pass's final checkpoint (written, like the
        // pass's run description, before it trains; rewritten if a resumed run finds none).
        let warm = best.filter(|_| mode == PassStart::Warm);
        if !(resuming && copy.exists()) {
            let (run, checkpoint) = if resuming && RunFile::path(&pdir).exists() {
                let run = RunFile::load(&pdir)?;
                let checkpoint = if RunFile::checkpoint_path(&pdir).exists() {
                    Some(run.load_checkpoint(&pdir).map_err(|e| InputError(format!("--resume: {e}")))?)
                } else {
                    warm.map(|b| warm_checkpoint(&run, &pdir, &env, dir, b + 1)).transpose()?
                };
                (run, checkpoint)
            } else {
                let run = pass_run(top, p, dir, start.as_deref());
                envpg_core::io::create_private_dir(&pdir)
                    .with_context(|| format!("creating the pass directory {}", pdir.display()))?;
                run.save(&pdir)?;
                let checkpoint = warm.map(|b| warm_checkpoint(&run, &pdir, &env, dir, b + 1)).transpose()?;
                (run, checkpoint)
            };
            // The progress line names how the pass starts (`pass 4/5 warm `).
            let how = clap::ValueEnum::to_possible_value(&mode).map_or(String::new(), |v| format!("{} ", v.get_name()));
            let label = format!("pass {p}/{} {how}", top.passes);
            train_pass(&run, &pdir, checkpoint, launch, registry, &Pass { label, resume_dir: dir })?;
        }
        done.push(ResultFile::load(&copy).with_context(|| format!("reading pass {p}'s result"))?);
    }
    let kept = ranking.best(&done);
    let result = combine(top, &done, kept, &ranking);
    crate::run_dir::save_result(&result, &top.out, dir)?;
    if !launch.quiet {
        let line = |i: usize, r: &ResultFile| {
            format!(
                "pass {}: sampled {:.6}, J = {}{}",
                i + 1,
                ranking.scores[i].j_estimate,
                r.j.map_or("inf".into(), |j| format!("{j:.6}")),
                if i == kept { "  (kept)" } else { "" }
            )
        };
        for (i, r) in done.iter().enumerate() {
            println!("{}", line(i, r));
        }
        println!(
            "J = {}  → {}  (run directory {})",
            result.j.map_or("inf".into(), |j| format!("{j:.6}")),
            top.out.display(),
            dir.display()
        );
    }
    Ok(())
}

/// The model-free ranking of a run's finished passes ([`score_designs`]): each pass is scored
/// once, when first ranked, since its score does not depend on what it is ranked with.
struct Ranking<'a> {
    env: &'a LoadedEnv,
    settings: PolishSettings,
    streams: Streams,
    /// The scores of the passes scored so far, in pass order.
    scores: Vec<RankScore>,
    /// Time spent scoring, over the whole run.
    seconds: f64,
}

impl Ranking<'_> {
    /// The index of the best of the finished passes `done` ([`best_of`]), scoring those not
    /// scored yet.
    fn best(&mut self, done: &[ResultFile]) -> usize {
        let designs: Vec<(Vec<f64>, Vec<usize>)> = done[self.scores.len()..]
            .iter()
            .map(|r| (r.zeta.clone(), actions_from_rows(self.env.sampler(), &r.policy)))
            .collect();
        if !designs.is_empty() {
            let started = Instant::now();
            self.scores.extend(score_designs(self.env.sampler(), &designs, &self.settings, &self.streams));
            self.seconds += started.elapsed().as_secs_f64();
        }
        best_of(&self.scores)
    }

    /// Environment steps spent scoring: each pass's one scoring.
    fn transitions(&self) -> u64 {
        self.scores.iter().map(|s| s.transitions).sum()
    }

    /// Episodes per score.
    fn episodes(&self) -> usize {
        envpg_ac::polish::RANKING_EPISODES * self.settings.episodes.max(1)
    }
}

/// Writes, as `run`'s checkpoint in `pdir`, the warm start of `run` ([`envpg_learner::warm_start`])
/// from the final checkpoint of pass `from` of the run in `dir`, at `run`'s ζ₀ (the kicked
/// design) and iteration [`warm_from`]; returns it.
fn warm_checkpoint(
    run: &RunFile,
    pdir: &Path,
    env: &LoadedEnv,
    dir: &Path,
    from: usize,
) -> Result<envpg_protocol::Checkpoint> {
    let fdir = pass_dir(dir, from);
    let unusable = |e: String| InputError(format!("--pass-start warm: pass {from}'s final checkpoint: {e}"));
    let source = RunFile::load(&fdir).map_err(|e| unusable(format!("{e:#}")))?;
    let kept = source.load_checkpoint(&fdir).map_err(|e| unusable(e.to_string()))?;
    if kept.k != source.spec.config.iterations as u64 {
        return Err(unusable(format!(
            "it was written at iteration {} of {}, not at the end of training",
            kept.k, source.spec.config.iterations
        ))
        .into());
    }
    let envpg_ac::Zeta0::Given(zeta) = &run.spec.config.zeta0 else {
        return Err(
            InputError(format!("{}: a warm pass starts from a given design", RunFile::path(pdir).display())).into()
        );
    };
    let k = warm_from(run.spec.config.iterations);
    let c = envpg_learner::warm_start(&run.spec, env, &run.run_id, &kept, k, zeta.clone())
        .map_err(|e| unusable(e.to_string()))?;
    let path = RunFile::checkpoint_path(pdir);
    envpg_core::io::write_atomic_with(&path, |w| c.write_to(w))
        .with_context(|| format!("writing the warm start {}", path.display()))?;
    Ok(c)
}

/// The run's result: the kept pass's result file, its `seconds` and `details.transitions` the
/// whole run's (every pass and the ranking), `details.passes` each pass's design, sampled cost
/// in the ranking, J (scored for the record, not used to rank), time, transitions and the
/// transitions of its one scoring in the ranking.
fn combine(top: &RunFile, done: &[ResultFile], kept: usize, ranking: &Ranking) -> ResultFile {
    let mut result = done[kept].clone();
    // The run's seed, which names every pass's (each pass's own is listed with it).
    result.seed = top.spec.seed;
    let transitions = |r: &ResultFile| r.details.as_ref().and_then(|d| d.get("transitions")).and_then(|t| t.as_u64());
    let passes: Vec<serde_json::Value> = done
        .iter()
        .zip(&ranking.scores)
        .enumerate()
        .map(|(i, (r, s))| {
            json!({
                "pass": i + 1,
                "seed": r.seed,
                "zeta0": r.zeta0,
                "zeta": r.zeta,
                "j_estimate": s.j_estimate,
                "capped": s.capped,
                "loops": s.loops,
                "J": r.j,
                "seconds": r.seconds,
                "transitions": transitions(r),
                "ranking_transitions": s.transitions,
            })
        })
        .collect();
    let total: u64 = done.iter().filter_map(transitions).sum::<u64>() + ranking.transitions();
    result.seconds = Some(done.iter().filter_map(|r| r.seconds).sum::<f64>() + ranking.seconds);
    let details = result.details.get_or_insert_with(|| json!({}));
    if let Some(d) = details.as_object_mut() {
        d.insert("transitions".into(), json!(total));
        d.insert(
            "passes".into(),
            json!({
                "kept": kept + 1,
                "start": top.pass_start,
                "ranking_episodes": ranking.episodes(),
                "ranking_seconds": ranking.seconds,
                "runs": passes,
            }),
        );
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sample standard deviation of `z`'s coordinates about 0.
    fn sd(z: &[f64]) -> f64 {
        (z.iter().map(|x| x * x).sum::<f64>() / z.len() as f64).sqrt()
    }

    #[test]
    fn a_portfolio_starts_its_first_half_fresh_and_the_rest_warm_with_kicks_from_the_smallest() {
        let plan = |passes: usize| (2..=passes).map(|p| PassStart::Portfolio.of_pass(p, passes)).collect::<Vec<_>>();
        use PassStart::{Fresh, Warm};
        assert_eq!(plan(2), [(Warm, 0)], "one fresh pass (the first), one warm");
        assert_eq!(plan(3), [(Fresh, 0), (Warm, 0)]);
        assert_eq!(plan(5), [(Fresh, 0), (Fresh, 0), (Warm, 0), (Warm, 1)]);
        assert_eq!(plan(6), [(Fresh, 0), (Fresh, 0), (Warm, 0), (Warm, 1), (Warm, 2)]);
        // The other starts are the same for every pass, their kicks counted from pass 2.
        assert_eq!(PassStart::Warm.of_pass(5, 5), (Warm, 3));
        assert_eq!(PassStart::Best.of_pass(2, 3), (PassStart::Best, 0));
    }

    #[test]
    fn kicks_grow_twofold_over_three_passes_then_start_again_with_noise_of_their_own() {
        let d = 4000;
        let space = envpg_core::ZetaSpace::with_scales(
            (0..d).map(|i| format!("z{i}")).collect(),
            vec![f64::NEG_INFINITY; d],
            vec![f64::INFINITY; d],
            vec![0.0; d],
            vec![10.0; d],
        )
        .unwrap();
        let zero = vec![0.0; d];
        let kicks: Vec<Vec<f64>> = (2..=5).map(|p| kick_start(&zero, &space, &Streams::new(9), p, p - 2)).collect();
        // Pass p: N(0, (KICK_SCALE · 10 · 2^((p − 2) mod 3))²) per coordinate; sd within 5%.
        for (k, factor) in [1.0, 2.0, 4.0, 1.0].into_iter().enumerate() {
            let want = KICK_SCALE * 10.0 * factor;
            assert!((sd(&kicks[k]) / want - 1.0).abs() < 0.05, "pass {}: sd {} want {want}", k + 2, sd(&kicks[k]));
        }
        assert_ne!(kicks[0], kicks[3], "passes 2 and 5 kick alike in size, not in direction");
        assert_eq!(kick_start(&zero, &space, &Streams::new(9), 3, 1), kicks[1], "same seed and pass, same kick");
        assert_ne!(kick_start(&zero, &space, &Streams::new(10), 3, 1), kicks[1], "another run seed, another kick");
    }
}
