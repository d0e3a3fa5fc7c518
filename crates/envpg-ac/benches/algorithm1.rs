//! Algorithm 1 at the default sizes (`uav` preset, bundled instance, κ = 1), after 500
//! training iterations so that episodes have their trained lengths:
//! - `rollout_sampling`: one iteration's episodes (emulator + sampling from the policy table,
//!   per-step ζ perturbation), throughput in transitions;
//! - `policy_table`: the actor evaluated on every valid pair at ζ_k (once per iteration per
//!   worker), throughput in state–action pairs;
//! - `learner_update`: one learner iteration (critic, actor and ζ step) on that batch.
//!
//! `cargo bench -p envpg-ac --bench algorithm1`.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use envpg_ac::rollout::run_iteration;
use envpg_ac::trainer::{RunSpec, advance};
use envpg_ac::{AcConfig, Batch};
use envpg_core::Streams;

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
    g.bench_function("learner_update", |b| {
        b.iter_batched(|| learner.clone(), |mut l| l.update(black_box(&batch)).expect("valid"), BatchSize::LargeInput)
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
