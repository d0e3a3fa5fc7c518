//! Algorithm 1 at the default sizes (`uav` preset, bundled instance, κ = 1), after 500
//! training iterations so that episodes have their trained lengths:
//! - `rollout_sampling`: one iteration's episodes (emulator + sampling from the policy table,
//!   per-step ζ perturbation), throughput in transitions;
//! - `policy_table`: the actor evaluated on every valid pair at ζ_k (once per iteration per
//!   worker), throughput in state–action pairs;
//! - `learner_update`: one learner iteration (critic, actor and ζ step) on that batch.
//!
//!
//! Before measuring, it prints the floating-point operations of one learner update counted from
//! the batch's shapes ([`update_flops`]) and the rate a plain timed loop of updates reaches.
//!
//! `cargo bench -p envpg-ac --bench algorithm1`.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use envpg_ac::rollout::run_iteration;
use envpg_ac::trainer::{RunSpec, advance};
use envpg_ac::{AcConfig, Batch, Learner};
use envpg_core::Streams;

/// Operations of one SiLU element as written (`fast_exp`'s clamp, range reduction and degree-6
/// polynomial, then `1/(1 + e)` and `z·σ`).
const SILU: f64 = 21.0;

/// Floating-point operations of one learner update on `batch` with the default settings
/// (Gibbs-fit actor, corollary ζ-estimator, one hidden layer, a minibatch that covers the batch),
/// counted from its shapes. A network column with `t` first-layer terms (non-zero dense inputs,
/// one-hot columns and the bias, one multiply and one add per element each) costs `2ht + 21h +
/// 2h` forward and `2ht + 7h` for its parameter gradient; an input gradient adds `2h·w`
/// for the `w` values a column stores (its listed inputs, with a routed ζ-block);
/// Adam is 14 operations per parameter and the target's Polyak average 3.
fn update_flops(learner: &Learner, batch: &Batch, config: &AcConfig) -> [f64; 4] {
    assert_eq!(config.hidden.len(), 1, "counted for one hidden layer");
    let h = config.hidden[0] as f64;
    let features = learner.features();
    let sets = learner.action_sets();
    let (groups, dense) = (features.onehot().len() as f64, features.dense_dim());
    let mut x = vec![0.0f32; dense];
    let mut terms = |s: usize, a: usize, zeta: &[f64]| {
        features.write(s, a, zeta, &mut x);
        x.iter().filter(|v| **v != 0.0).count() as f64 + groups + 1.0
    };
    let fwd = |t: f64| 2.0 * h * t + SILU * h + 2.0 * h;
    let bwd = |t: f64| 2.0 * h * t + 7.0 * h;
    let zeta_k = learner.zeta().to_vec();
    let d = zeta_k.len();
    let (mut actor_cols, mut next_cols, mut on_cols) = (0.0, 0.0, 0.0);
    let (mut n, mut next_states) = (0.0, std::collections::BTreeSet::new());
    for ep in &batch.episodes {
        for t in 0..ep.len() {
            let s = ep.s[t] as usize;
            let pert: Vec<f64> = ep.zeta[t * d..(t + 1) * d].iter().map(|&z| z as f64).collect();
            for &a in sets.of(s) {
                let tp = terms(s, a, &pert);
                // The actor pass, the critic's values at the same columns and the actor's backprop.
                actor_cols += 2.0 * fwd(tp) + bwd(tp);
                if !ep.explore {
                    // The ζ-estimate: actor and critic forward, the critic's input gradient.
                    let tk = terms(s, a, &zeta_k);
                    on_cols += 2.0 * fwd(tk) + 5.0 * h + 2.0 * h * features.width() as f64;
                }
            }
            // The critic's TD step: forward and backprop of the taken pair.
            let taken = terms(s, ep.a[t] as usize, &pert);
            n += fwd(taken) + bwd(taken);
            let s2 = ep.s2[t] as usize;
            if !sets.terminal(s2) {
                next_states.insert(s2);
            }
        }
    }
    for &s2 in &next_states {
        // The target's values and the policy row at ζ_k of every successor.
        next_cols += sets.of(s2).iter().map(|&a| 2.0 * fwd(terms(s2, a, &zeta_k))).sum::<f64>();
    }
    let params = learner.actor().n_params() as f64;
    let steps = config.critic_steps as f64;
    // The actor pass and step; the ζ-estimate; the critic steps; Adam and Polyak.
    [actor_cols, on_cols, steps * (n + next_cols), (steps + 1.0) * 14.0 * params + steps * 3.0 * params]
}

fn bench(c: &mut Criterion) {
    // As the binaries do: the learner's buffers are reused, not faulted in again every iteration.
    envpg_ac::memory::retain_freed_memory();
    let config = AcConfig::bundled("uav").expect("bundled preset");
    let registry = envpg_envs::registry();
    let env = registry.load("uav271", &[]).expect("bundled instance");
    let spec = RunSpec::new(&env, 1, config.clone());
    let (_, mut learner) = spec.start_on(&env).expect("valid spec");
    let net = env.sampler();
    let streams = Streams::new(spec.seed);
    let sets = learner.action_sets().clone();
    advance(net, &mut learner, &config, &streams, 500).expect("valid batches");
    let k = learner.k();
    let zeta = learner.zeta().to_vec();
    let mut table = learner.policy_table();
    table.full();
    let episodes = run_iteration(net, &sets, &mut table, &zeta, &config, &streams, k);
    let transitions: usize = episodes.iter().map(|e| e.len()).sum();

    let mut g = c.benchmark_group("algorithm1_uav271_k1");
    g.throughput(Throughput::Elements(transitions as u64));
    g.bench_function("rollout_sampling", |b| {
        b.iter(|| run_iteration(net, &sets, &mut table, black_box(&zeta), &config, &streams, k))
    });
    g.throughput(Throughput::Elements(sets.n_pairs() as u64));
    g.bench_function("policy_table", |b| {
        b.iter(|| {
            let mut t = learner.policy_table();
            t.full().len()
        })
    });
    g.throughput(Throughput::Elements(1));
    let batch = Batch { k, episodes };
    let parts = update_flops(&learner, &batch, &config);
    let flops: f64 = parts.iter().sum();
    let mut times: Vec<f64> = (0..200)
        .map(|_| {
            let mut l = learner.clone();
            let t = std::time::Instant::now();
            l.update(&batch).expect("valid");
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    println!(
        "learner update: {:.1} MFLOP counted from the shapes (actor pass and step {:.1}, ζ-estimate {:.1}, critic \
         steps {:.1}, optimisers {:.1}); median of 200 timed updates {:.3} ms = {:.1} GFLOP/s",
        flops / 1e6,
        parts[0] / 1e6,
        parts[1] / 1e6,
        parts[2] / 1e6,
        parts[3] / 1e6,
        median * 1e3,
        flops / median / 1e9
    );
    g.bench_function("learner_update", |b| {
        b.iter_batched(|| learner.clone(), |mut l| l.update(black_box(&batch)).expect("valid"), BatchSize::LargeInput)
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
