//! `--passes N`: Algorithm 1 run N times, each pass after the first from the design of the best
//! pass so far, and the best pass kept — a model-free way out of a poor basin.
//!
//! Pass P trains in `DIR/pass-P/` (a run directory of its own: `run.json`, metrics, log,
//! checkpoints, `result.json`) with the run's settings, ζ₀ being the design of the best pass
//! before it, and a seed of its own ([`pass_seed`]). Passes are ranked by
//! [`envpg_ac::polish::rank_designs`]: each finished pass's design and greedy policy sampled on
//! the same episodes, the lowest mean cost first — the environment's sampler only, never its
//! model. The kept pass's result file, with every pass listed in `details.passes`, is the run's
//! result. A pass whose `result.json` exists is done,
//! so `--resume DIR` continues with the first pass that is not.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use envpg_ac::Zeta0;
use envpg_ac::polish::{RankScore, rank_designs};
use envpg_core::policy::actions_from_rows;
use envpg_core::{Purpose, Registry, ResultFile, Streams};
use rand::Rng;
use serde_json::json;

use crate::run_dir::RunFile;
use crate::{InputError, LaunchArgs, Pass, train_pass};

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

/// The seed of pass `p` (from 1) of a run with seed `seed`: the run's own for pass 1, for the
/// others a draw from the run seed's stream keyed by the pass. A pass that starts from the
/// same design as one before it (the best design did not change) is then a new sample, not
/// a repeat of that pass.
pub(crate) fn pass_seed(seed: u64, p: usize) -> u64 {
    if p == 1 { seed } else { Streams::new(seed).stream(Purpose::Other, PASS_SEEDS, p as u64).next_u64() }
}

/// The description of pass `p` of `top`: its own run id (service names) and seed
/// ([`pass_seed`]), ζ₀ `zeta0` (pass 1: the run's), its result in its directory, no further
/// passes.
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
    let mut ranked: (usize, Vec<RankScore>) = (0, Vec::new());
    let mut ranking_seconds = 0.0;
    for p in 1..=top.passes {
        let pdir = pass_dir(dir, p);
        let copy = RunFile::result_copy_path(&pdir);
        if !(resuming && copy.exists()) {
            let (run, checkpoint) = if resuming && RunFile::path(&pdir).exists() {
                let run = RunFile::load(&pdir)?;
                let checkpoint = if RunFile::checkpoint_path(&pdir).exists() {
                    Some(run.load_checkpoint(&pdir).map_err(|e| InputError(format!("--resume: {e}")))?)
                } else {
                    None
                };
                (run, checkpoint)
            } else {
                let zeta0 = (p > 1).then(|| done[ranked.0].zeta.as_slice());
                let run = pass_run(top, p, dir, zeta0);
                envpg_core::io::create_private_dir(&pdir)
                    .with_context(|| format!("creating the pass directory {}", pdir.display()))?;
                run.save(&pdir)?;
                (run, None)
            };
            let label = format!("pass {p}/{} ", top.passes);
            train_pass(&run, &pdir, checkpoint, launch, registry, &Pass { label, resume_dir: dir })?;
        }
        done.push(ResultFile::load(&copy).with_context(|| format!("reading pass {p}'s result"))?);
        if done.len() > 1 {
            let started = Instant::now();
            let designs: Vec<(Vec<f64>, Vec<usize>)> =
                done.iter().map(|r| (r.zeta.clone(), actions_from_rows(env.sampler(), &r.policy))).collect();
            ranked = rank_designs(env.sampler(), &designs, &settings, &streams);
            ranking_seconds += started.elapsed().as_secs_f64();
        }
    }
    let result = combine(
        top.spec.seed,
        &done,
        &ranked,
        ranking_seconds,
        envpg_ac::polish::RANKING_EPISODES * settings.episodes.max(1),
    );
    crate::run_dir::save_result(&result, &top.out, dir)?;
    if !launch.quiet {
        let line = |i: usize, r: &ResultFile| {
            format!(
                "pass {}: sampled {:.6}, J = {}{}",
                i + 1,
                ranked.1[i].j_estimate,
                r.j.map_or("inf".into(), |j| format!("{j:.6}")),
                if i == ranked.0 { "  (kept)" } else { "" }
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

/// The run's result: the kept pass's result file, its `seconds` and `details.transitions` the
/// whole run's (every pass and the ranking), `details.passes` each pass's design, sampled cost
/// in the ranking, J (scored for the record, not used to rank), time and transitions.
fn combine(
    seed: u64,
    done: &[ResultFile],
    (kept, scores): &(usize, Vec<RankScore>),
    ranking_seconds: f64,
    ranking_episodes: usize,
) -> ResultFile {
    let mut result = done[*kept].clone();
    // The run's seed, which names every pass's (each pass's own is listed with it).
    result.seed = seed;
    let transitions = |r: &ResultFile| r.details.as_ref().and_then(|d| d.get("transitions")).and_then(|t| t.as_u64());
    let passes: Vec<serde_json::Value> = done
        .iter()
        .zip(scores)
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
            })
        })
        .collect();
    let total: u64 =
        done.iter().filter_map(transitions).sum::<u64>() + scores.iter().map(|s| s.transitions).sum::<u64>();
    result.seconds = Some(done.iter().filter_map(|r| r.seconds).sum::<f64>() + ranking_seconds);
    let details = result.details.get_or_insert_with(|| json!({}));
    if let Some(d) = details.as_object_mut() {
        d.insert("transitions".into(), json!(total));
        d.insert(
            "passes".into(),
            json!({
                "kept": kept + 1,
                "ranking_episodes": ranking_episodes,
                "ranking_seconds": ranking_seconds,
                "runs": passes,
            }),
        );
    }
    result
}
