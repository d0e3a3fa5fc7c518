//! Forward and backward throughput of the MLP at the sizes Algorithm 1 uses.
//! `cargo bench -p envpg-nn --bench mlp`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use envpg_nn::{Cache, Inputs, Mlp, MlpSpec};
use rand::SeedableRng;
use rand_chacha::ChaCha12Rng;

fn bench(c: &mut Criterion) {
    let cols = 1385;
    for hidden in [vec![128usize], vec![64, 64]] {
        let spec = MlpSpec { onehot: vec![277, 6], dense: 17, hidden: hidden.clone() };
        let mlp = Mlp::<f32>::new(spec, &mut ChaCha12Rng::seed_from_u64(1), false);
        let onehot: Vec<u32> = (0..cols).flat_map(|i| [(i % 277) as u32, (i % 6) as u32]).collect();
        let dense: Vec<f32> = (0..cols * 17).map(|i| ((i as f32) * 0.1).sin()).collect();
        let x = Inputs::full(&onehot, &dense, cols);
        let name: Vec<String> = hidden.iter().map(|h| h.to_string()).collect();
        let mut g = c.benchmark_group(format!("mlp_{}", name.join("x")));
        g.throughput(Throughput::Elements(cols as u64));
        let mut cache = Cache::default();
        let mut out = vec![0.0f32; cols];
        g.bench_function("forward", |b| b.iter(|| mlp.forward(black_box(&x), &mut cache, &mut out)));
        let dout = vec![1.0f32; cols];
        let mut grad = vec![0.0f32; mlp.n_params()];
        let mut di = vec![0.0f32; cols * 17];
        mlp.forward(&x, &mut cache, &mut out);
        g.bench_function("backward", |b| {
            b.iter(|| mlp.backward(black_box(&x), &cache, &dout, Some(&mut grad), Some(&mut di)))
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
