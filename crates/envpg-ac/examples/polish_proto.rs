use envpg_ac::ActionSets;
use envpg_core::{ParamMdp, ResultFile, UavNetwork};
use envpg_core::{Purpose, Streams};
use envpg_model::{evaluate::evaluate, snapshot::Snapshot};

fn jhat(net: &UavNetwork, greedy: &[usize], zeta: &[f64], reps: u64, base: u64) -> f64 {
    let n_users = net.n_users();
    let mut tot = 0.0;
    for u in 0..n_users {
        for r in 0..reps {
            let mut rng = Streams::new(base).stream(Purpose::Other, u as u64, r);
            let mut s = u;
            for _ in 0..25 {
                let (s2, c) = net.step(s, greedy[s], zeta, &mut rng);
                tot += c;
                if net.is_terminal(s2) {
                    break;
                }
                s = s2;
            }
        }
    }
    tot / (n_users as f64 * reps as f64)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let r: ResultFile = serde_json::from_str(&std::fs::read_to_string(&args[1]).unwrap()).unwrap();
    let reps: u64 = args.get(2).map_or(8, |s| s.parse().unwrap());
    let iters: usize = args.get(3).map_or(60, |s| s.parse().unwrap());
    let h: f64 = args.get(4).map_or(0.005, |s| s.parse().unwrap());
    let net = UavNetwork::new(r.instance.clone(), r.kappa, r.eta).unwrap();
    let sets = ActionSets::new(&net);
    let greedy: Vec<usize> = r
        .policy
        .iter()
        .map(|row| row.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0)
        .chain([0])
        .collect();
    let exact = |z: &[f64]| {
        let snap = Snapshot::build(&net, z);
        let mut pairs = vec![0.0; sets.n_pairs()];
        for s in 0..net.n_states() - 1 {
            let i = sets.of(s).iter().position(|&a| a == greedy[s]).unwrap();
            pairs[sets.first(s) + i] = 1.0;
        }
        evaluate(&snap, &pairs, 0.0).map(|v| v.j).unwrap_or(f64::INFINITY)
    };
    let mut zeta = r.zeta.clone();
    println!("start exact {:.4} file J {:?}", exact(&zeta), r.j);
    let mut step = 0.05;
    let t0 = std::time::Instant::now();
    for it in 0..iters {
        let base = 1000 + it as u64 * 7919;
        let j0 = jhat(&net, &greedy, &zeta, reps, base);
        let mut g = vec![0.0; zeta.len()];
        for i in 0..zeta.len() {
            let mut zp = zeta.clone();
            zp[i] += h;
            let mut zm = zeta.clone();
            zm[i] -= h;
            g[i] = (jhat(&net, &greedy, &zp, reps, base) - jhat(&net, &greedy, &zm, reps, base)) / (2.0 * h);
        }
        let gn = g.iter().map(|x| x * x).sum::<f64>().sqrt();
        // backtracking on the same streams
        let mut accepted = false;
        for _ in 0..6 {
            let zn: Vec<f64> = zeta.iter().zip(&g).map(|(z, gi)| z - step * gi / gn).collect();
            let jn = jhat(&net, &greedy, &zn, reps, base);
            if jn < j0 {
                zeta = zn;
                step *= 1.5;
                accepted = true;
                break;
            }
            step *= 0.5;
        }
        if !accepted {
            step = step.max(0.002) * 8.0;
        }
        if it % 5 == 0 || it + 1 == iters {
            println!(
                "it {it} j0 {j0:.4} |g| {gn:.3} step {step:.4} acc {accepted} exact {:.4} t {:.1}s",
                exact(&zeta),
                t0.elapsed().as_secs_f64()
            );
        }
    }
}
