//! A rogue peer that opens the run's services beside the real workers and publishes malformed
//! episodes — wrong lengths, states and actions out of range, NaN and infinite costs, stale and
//! future iterations, unknown episode ids, another run's id, well-formed episodes claiming a
//! worker they were not handed to — is refused message by message and counted, and the run's
//! result is bitwise the one without it. (A peer that forges the id of the very worker an
//! episode was handed to is beyond what the learner can tell apart: see docs/training.md.)

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use envpg_ac::AcConfig;
use envpg_ac::trainer::RunSpec;
use envpg_core::{LoadedEnv, ResultFile};
use envpg_learner::{LearnerConfig, LinkStats, run_learner};
use envpg_protocol::{EpisodeHeader, EpisodeId, PROTOCOL_VERSION, Step, run_id_bytes, step_words, write_step};
use envpg_transport::{WorkerEnd, local};
use envpg_worker::{WorkerConfig, run_worker};

fn spec(env: &LoadedEnv) -> RunSpec {
    let config = AcConfig {
        iterations: 40,
        episodes: 16,
        explore_episodes: 8,
        hidden: vec![32],
        batch: 128,
        warmup: 50,
        eval_every: 20,
        polish_iterations: 0,
        ..AcConfig::default()
    };
    RunSpec::new(env, 3, config)
}

/// Publishes one malformed message of every kind for iteration `k` (and a few around it).
fn attack(end: &WorkerEnd<local::Service>, run_id: &str, k: u64, d: usize, n_states: u32, n_actions: u32) -> u64 {
    let good = Step { s: 0, a: 0, s2: 0, cost: 1.0 };
    let zeta = vec![0.5f32; d];
    // The words of steps at ζ_pert = zeta (nan_zeta: with a NaN first coordinate).
    let words = |steps: &[Step], nan_zeta: bool| {
        let mut z = zeta.clone();
        if nan_zeta {
            z[0] = f32::NAN;
        }
        let mut out = vec![0u32; steps.len() * step_words(d)];
        for (rec, st) in out.chunks_exact_mut(step_words(d)).zip(steps) {
            write_step(rec, *st, &z);
        }
        out
    };
    let header = |k: u64, index: u32, len: usize| EpisodeHeader {
        protocol: PROTOCOL_VERSION,
        // Forged: the rogue claims to be a worker slot that was never handed anything.
        worker_id: 4242,
        run_id: run_id_bytes(run_id),
        k,
        episode: EpisodeId { kind: 0, index },
        seq: 0,
        len: len as u32,
        capped: 0,
        zeta_dim: d as u32,
        _pad: 0,
    };
    let mut sent = 0;
    let mut send = |h: EpisodeHeader, recs: Vec<u32>| {
        if end.publish_episode(h, &recs).is_ok() {
            sent += 1;
        }
    };
    let one = |st: Step| words(&[st], false);
    for index in 0..4 {
        send(header(k, index, 3), words(&[good; 2], false)); // length disagrees with the header
        send(header(k, index, 1), one(Step { s: n_states, ..good }));
        send(header(k, index, 1), one(Step { s2: u32::MAX, ..good }));
        send(header(k, index, 1), one(Step { a: n_actions, ..good }));
        send(header(k, index, 1), one(Step { cost: f32::NAN, ..good }));
        send(header(k, index, 1), one(Step { cost: f32::INFINITY, ..good }));
        send(header(k, index, 1), words(&[good], true));
        send(EpisodeHeader { zeta_dim: d as u32 + 1, ..header(k, index, 1) }, one(good));
        let mut short = one(good);
        short.pop(); // a record cut short
        send(header(k, index, 1), short);
        send(EpisodeHeader { worker_id: 0, len: 0, ..header(k, index, 0) }, vec![]);
        send(EpisodeHeader { run_id: run_id_bytes("someone-else"), ..header(k, index, 1) }, one(good));
        send(EpisodeHeader { protocol: PROTOCOL_VERSION + 7, ..header(k, index, 1) }, one(good));
        send(EpisodeHeader { capped: 9, ..header(k, index, 1) }, one(good));
    }
    // Well-formed but forged: a future iteration, a past one, no such episode, and this
    // iteration's episodes from a worker they were never handed to.
    send(header(k + 1, 0, 1), one(good));
    send(header(k.saturating_sub(1), 0, 1), one(good));
    send(header(k, 1_000_000, 1), one(good));
    for index in 0..4 {
        send(header(k, index, 1), one(good));
    }
    let _ = end.notify_learner();
    sent
}

fn run(env: &LoadedEnv, run_id: &str, rogue: bool) -> (ResultFile, LinkStats, u64) {
    let spec = spec(env);
    let lcfg = LearnerConfig {
        run_id: run_id.into(),
        spec: spec.clone(),
        env: env.clone(),
        max_workers: 5,
        worker_timeout: Duration::from_millis(2000),
        checkpoint: None,
        resume: None,
        stall_timeout: Duration::from_secs(60),
        collect_only: false,
    };
    let over = Arc::new(AtomicBool::new(false));
    std::thread::scope(|scope| {
        for i in 0..2u32 {
            let wcfg = WorkerConfig {
                run_id: run_id.into(),
                spec: spec.clone(),
                env: env.clone(),
                worker_id: i,
                incarnation: 1,
                protocol: PROTOCOL_VERSION,
                join_timeout: Duration::from_secs(30),
                heartbeat: Duration::from_millis(200),
                emulator_cost_us: 0,
                run_over: Some(over.clone()),
            };
            scope.spawn(move || {
                let _ = run_worker::<local::Service>(&wcfg);
            });
        }
        let attacker = rogue.then(|| {
            let over = over.clone();
            let (n_states, n_actions) = (env.sampler().n_states() as u32, env.sampler().n_actions() as u32);
            let d = env.sampler().zeta_dim();
            scope.spawn(move || {
                let end = WorkerEnd::<local::Service>::open(run_id, 77, PROTOCOL_VERSION, Duration::from_secs(30))
                    .expect("the rogue opens the run's services");
                let mut sent = 0;
                let mut last = None;
                while !over.load(Ordering::Acquire) {
                    if let Ok(Some((h, _))) = end.latest_weights()
                        && last != Some(h.k)
                    {
                        last = Some(h.k);
                        sent += attack(&end, run_id, h.k, d, n_states, n_actions);
                    }
                    std::thread::sleep(Duration::from_micros(200));
                }
                sent
            })
        });
        let (result, stats) = run_learner::<local::Service>(&lcfg, |_| true).expect("the run completes");
        over.store(true, Ordering::Release);
        let sent = attacker.map_or(0, |h| h.join().expect("the rogue thread"));
        (result, stats, sent)
    })
}

#[test]
fn malformed_episodes_are_refused_and_counted_and_the_result_is_unchanged() {
    let env = envpg_envs::registry().load("flpo-n10m4", &[]).unwrap();
    let (clean, clean_stats, _) = run(&env, "rogue-clean", false);
    let (attacked, stats, sent) = run(&env, "rogue-attack", true);
    assert!(sent > 0, "the rogue published nothing");
    assert_eq!(clean_stats.refused + clean_stats.stale, 0);
    let rejected = stats.refused + stats.stale + stats.duplicates;
    assert!(rejected > 0, "{stats:?}");
    assert!(rejected <= sent, "{stats:?}, {sent} rogue messages");
    assert_eq!(stats.episodes, clean_stats.episodes, "only the real episodes were accepted");
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&attacked.zeta), bits(&clean.zeta), "ζ changed");
    assert_eq!(attacked.policy, clean.policy, "the policy changed");
    assert_eq!(attacked.j.map(f64::to_bits), clean.j.map(f64::to_bits), "J changed");
    eprintln!(
        "{sent} rogue messages; refused {}, stale {}, duplicates {}",
        stats.refused, stats.stale, stats.duplicates
    );
}
