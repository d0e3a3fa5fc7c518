//! Exact ζ-gradient vs central differences on the bundled instance, side by side, plus the
//! pieces of one oracle evaluation. `cargo bench -p envpg-model --bench gradient`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use envpg_model::{
    Form, GradientKind, Objective, Snapshot, corollary_gradient, horizon_gradient, solve_horizon, solve_soft,
};

const ZETA: [f64; 10] = [5.0, 6.0, 3.0, 4.5, 6.5, 3.0, 7.5, 6.5, 8.0, 2.0];

fn bench(c: &mut Criterion) {
    for kappa in [1.0, 0.85] {
        let env = envpg_envs::registry().load("uav271", &[("kappa".into(), kappa)]).unwrap();
        let net = env.model().unwrap();
        let alpha = 0.2;
        let snap = Snapshot::build(net, &ZETA);
        let sol = solve_soft(&snap, alpha, None).unwrap();
        let mut g = c.benchmark_group(format!("uav271_kappa{kappa}"));
        g.bench_function("snapshot_build", |b| b.iter(|| Snapshot::build(net, black_box(&ZETA))));
        g.bench_function("soft_ssp_solve", |b| b.iter(|| solve_soft(&snap, alpha, Some(&sol.pi)).unwrap()));
        g.bench_function("corollary_gradient_pass", |b| {
            b.iter(|| corollary_gradient(net, &ZETA, &snap, &sol).unwrap())
        });
        g.bench_function("horizon_solve", |b| b.iter(|| solve_horizon(&snap, alpha, 6, None).unwrap()));
        // The hot levels of an anneal use the finite-horizon form at a high temperature.
        let hot = 20.0;
        let hsol = solve_horizon(&snap, hot, 6, None).unwrap();
        g.bench_function("horizon_gradient_pass", |b| b.iter(|| horizon_gradient(net, &ZETA, &snap, &hsol).unwrap()));
        let obj = Objective::new(net, hot, Form::Horizon(6));
        g.bench_function("value_and_gradient_horizon", |b| {
            b.iter(|| obj.value_grad(black_box(&ZETA), Some(&sol.pi)).unwrap())
        });
        for kind in [GradientKind::Exact, GradientKind::Fd] {
            let mut obj = Objective::new(net, alpha, Form::Ssp);
            obj.gradient = kind;
            g.bench_function(format!("value_and_gradient_{kind:?}").to_lowercase(), |b| {
                b.iter(|| obj.value_grad(black_box(&ZETA), Some(&sol.pi)).unwrap())
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
