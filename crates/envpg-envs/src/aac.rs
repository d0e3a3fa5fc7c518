//! `aac` — autonomy-aware clustering (Srivastava, Basiri, Salapaka, arXiv 2509.25775;
//! `../shared/envs.md`).
//!
//! N data points are assigned to K clusters whose centres are the design,
//! ζ = `(y₀ₓ, y₀ᵧ, y₁ₓ, …)`. A point assigned to cluster j lands there with probability
//! `1 − dev`, and otherwise (its *autonomy*) in another cluster k ≠ j with probability
//! `dev · exp(−u_k/T) / Σ_{k'≠j} exp(−u_{k'}/T)`, `u_k = w_cluster‖y_j − y_k‖² +
//! w_point‖x_i − y_k‖²`; landing in k costs `‖x_i − y_k‖²`. One step: J is the mean over
//! points of the expected cost (the paper's distortion).
//!
//! - States: `0 … N−1` the points (file order), then `N … N+K−1` = "landed in cluster k"
//!   (terminal, cost-free). μ is uniform over the points.
//! - Actions: `0 … K−1` = "assign to cluster j"; every point allows all K.
//!
//! Instance files: `{"env": "aac", "name", "clusters": K, "points": [[x, y], …], "bounds":
//! [[xmin, xmax], [ymin, ymax]]}` (bounds optional: the points' bounding box), `params`
//! `deviation` (default 0), `w_cluster` (1), `w_point` (0), `temperature` (1).

use std::sync::Arc;

use envpg_core::instance::points;
use envpg_core::{
    Env, EnvRng, EnvSpec, FeatureMap, InstanceError, InstanceFile, ModelMdp, OracleHints, Outcomes, ParamMdp,
    ParamSpec, Sketch, SketchMarker, SketchPoint, ZetaSpace,
};
use rand::RngExt;

use crate::hop::dist2;
use crate::uav::bbox;

thread_local! {
    /// Scratch of [`Aac::outcomes`]: the landing distribution, ∂z and its mean.
    static SCRATCH: std::cell::RefCell<[Vec<f64>; 3]> = Default::default();
}

/// The bundled data set of the paper (`launch/instances/aac1800.json`).
pub const AAC1800: &str = include_str!("../../../launch/instances/aac1800.json");

/// Autonomy-aware clustering.
#[derive(Debug, Clone)]
pub struct Aac {
    points: Vec<[f64; 2]>,
    k: usize,
    dev: f64,
    w_cluster: f64,
    w_point: f64,
    temperature: f64,
    actions: Vec<usize>,
    space: ZetaSpace,
    center: [f64; 2],
    scale: f64,
}

impl Aac {
    /// Number of points N.
    pub fn n_points(&self) -> usize {
        self.points.len()
    }
    /// Number of clusters K.
    pub fn n_clusters(&self) -> usize {
        self.k
    }
    /// The points.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }
    /// The state "landed in cluster `k`".
    pub fn landed_state(&self, k: usize) -> usize {
        self.points.len() + k
    }

    #[inline]
    fn centre(zeta: &[f64], k: usize) -> [f64; 2] {
        [zeta[2 * k], zeta[2 * k + 1]]
    }

    /// Whether a point can land elsewhere than where it is assigned.
    fn deviates(&self) -> bool {
        self.dev > 0.0 && self.k > 1
    }

    /// The landing distribution of point `i` assigned to `j`, written into `p` (length K).
    fn landing(&self, i: usize, j: usize, zeta: &[f64], p: &mut [f64]) {
        p.iter_mut().for_each(|x| *x = 0.0);
        if !self.deviates() {
            p[j] = 1.0;
            return;
        }
        let yj = Self::centre(zeta, j);
        // Softmax of −u/T over k ≠ j, shifted by its maximum: T = 0.01 underflows otherwise.
        let mut mx = f64::NEG_INFINITY;
        for (k, pk) in p.iter_mut().enumerate() {
            if k != j {
                let yk = Self::centre(zeta, k);
                *pk = -(self.w_cluster * dist2(yj, yk) + self.w_point * dist2(self.points[i], yk)) / self.temperature;
                mx = mx.max(*pk);
            }
        }
        let mut sum = 0.0;
        for (k, pk) in p.iter_mut().enumerate() {
            if k != j {
                *pk = (*pk - mx).exp();
                sum += *pk;
            }
        }
        for (k, pk) in p.iter_mut().enumerate() {
            *pk = if k == j { 1.0 - self.dev } else { self.dev * *pk / sum };
        }
    }

    /// [`Aac::outcomes`] with the landing distribution, ∂z and its mean in `scratch`: allocated
    /// on every call, they cost an oracle restart more than the arithmetic around them.
    fn outcomes_with(
        &self,
        s: usize,
        a: usize,
        zeta: &[f64],
        grad: bool,
        out: &mut Outcomes,
        scratch: &mut [Vec<f64>; 3],
    ) {
        let [p, dz, mean] = scratch;
        out.clear();
        let (d, k_n, x) = (zeta.len(), self.k, self.points[s]);
        p.clear();
        p.resize(k_n, 0.0);
        self.landing(s, a, zeta, p);
        for (k, &pk) in p.iter().enumerate() {
            let yk = Self::centre(zeta, k);
            out.push(self.landed_state(k), pk, dist2(x, yk), grad, d);
            if grad {
                let dc = out.last_dcost(d);
                dc[2 * k] = 2.0 * (yk[0] - x[0]);
                dc[2 * k + 1] = 2.0 * (yk[1] - x[1]);
            }
        }
        if grad && self.deviates() {
            // p_k = dev·q_k, q = softmax_{k≠j}(z), z_k = −u_k/T: ∂q_k = q_k (∂z_k − Σ_l q_l ∂z_l).
            let yj = Self::centre(zeta, a);
            dz.clear();
            dz.resize(k_n * d, 0.0);
            for k in (0..k_n).filter(|&k| k != a) {
                let yk = Self::centre(zeta, k);
                for c in 0..2 {
                    let toward = 2.0 * self.w_cluster * (yj[c] - yk[c]) / self.temperature;
                    dz[k * d + 2 * a + c] -= toward;
                    dz[k * d + 2 * k + c] += toward - 2.0 * self.w_point * (yk[c] - x[c]) / self.temperature;
                }
            }
            mean.clear();
            mean.resize(d, 0.0);
            for k in (0..k_n).filter(|&k| k != a) {
                let q = p[k] / self.dev;
                for i in 0..d {
                    mean[i] += q * dz[k * d + i];
                }
            }
            for k in (0..k_n).filter(|&k| k != a) {
                for i in 0..d {
                    out.dprob[k * d + i] = p[k] * (dz[k * d + i] - mean[i]);
                }
            }
        }
    }
}

impl EnvSpec for Aac {
    const NAME: &'static str = "aac";
    const ABOUT: &'static str = "autonomy-aware clustering: points assigned to clusters (centres ζ) may land elsewhere";

    fn params() -> Vec<ParamSpec> {
        vec![
            ParamSpec {
                name: "deviation",
                default: 0.0,
                about: "probability dev ∈ [0, 1) that a point lands elsewhere",
            },
            ParamSpec {
                name: "w_cluster", default: 1.0, about: "weight of ‖y_j − y_k‖² in the deviation kernel"
            },
            ParamSpec { name: "w_point", default: 0.0, about: "weight of ‖x_i − y_k‖² in the deviation kernel" },
            ParamSpec { name: "temperature", default: 1.0, about: "temperature T > 0 of the deviation kernel" },
        ]
    }

    fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError> {
        file.expect_fields(&["clusters", "points", "bounds"])?;
        let k: usize = file.field("clusters")?;
        if k == 0 {
            return Err(file.invalid("clusters", "must be at least 1".into()));
        }
        if k > crate::MAX_DESIGN_POINTS {
            let max = crate::MAX_DESIGN_POINTS;
            return Err(file.invalid("clusters", format!("at most {max} clusters are supported, got {k}")));
        }
        let pts = points(file, "points")?;
        if pts.is_empty() {
            return Err(file.invalid("points", "must contain at least one point".into()));
        }
        let (lo, hi) = bbox(&pts);
        let bounds: [[f64; 2]; 2] = file.optional_field("bounds")?.unwrap_or([[lo[0], hi[0]], [lo[1], hi[1]]]);
        for (c, b) in bounds.iter().enumerate() {
            if !(b[0].is_finite() && b[1].is_finite() && b[0] <= b[1]) {
                return Err(file.invalid(&format!("bounds[{c}]"), format!("must be finite with min ≤ max, got {b:?}")));
            }
        }
        let dev = file.param("deviation")?;
        if !(0.0..1.0).contains(&dev) {
            return Err(file.invalid("params.deviation", format!("must be in [0, 1), got {dev}")));
        }
        let temperature = file.param("temperature")?;
        if temperature <= 0.0 {
            return Err(file.invalid("params.temperature", format!("must be > 0, got {temperature}")));
        }
        let (w_cluster, w_point) = (file.param("w_cluster")?, file.param("w_point")?);
        for (name, w) in [("params.w_cluster", w_cluster), ("params.w_point", w_point)] {
            if w < 0.0 {
                return Err(file.invalid(name, format!("must be >= 0, got {w}")));
            }
        }
        let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let scale = (((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2)).sqrt() / 2.0).max(1e-9);
        let space = ZetaSpace::with_scales(
            ZetaSpace::point_names("c", k),
            (0..2 * k).map(|i| bounds[i % 2][0]).collect(),
            (0..2 * k).map(|i| bounds[i % 2][1]).collect(),
            (0..2 * k).map(|i| center[i % 2]).collect(),
            vec![scale; 2 * k],
        )
        .map_err(|e| file.invalid("bounds", e.to_string()))?;
        Ok(Self {
            points: pts,
            k,
            dev,
            w_cluster,
            w_point,
            temperature,
            actions: (0..k).collect(),
            space,
            center,
            scale,
        })
    }
}

impl ParamMdp for Aac {
    fn n_states(&self) -> usize {
        self.points.len() + self.k
    }
    fn n_actions(&self) -> usize {
        self.k
    }
    fn zeta_space(&self) -> &ZetaSpace {
        &self.space
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        if s < self.points.len() { &self.actions } else { &[] }
    }
    fn is_terminal(&self, s: usize) -> bool {
        s >= self.points.len()
    }
    /// The squared extent of the points.
    fn cost_scale(&self) -> f64 {
        (2.0 * self.scale).powi(2)
    }
    fn sample_initial(&self, rng: &mut EnvRng) -> usize {
        rng.random_range(0..self.points.len())
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        debug_assert!(s < self.points.len() && a < self.k, "({s}, {a}) is not a valid pair");
        // One uniform decides whether the point deviates, one more where it lands.
        let u: f64 = rng.random();
        let k = if u < 1.0 - self.dev || !self.deviates() {
            a
        } else {
            let mut p = [0.0f64; 64];
            let mut heap = Vec::new();
            let p: &mut [f64] = if self.k <= 64 {
                &mut p[..self.k]
            } else {
                heap.resize(self.k, 0.0);
                &mut heap
            };
            self.landing(s, a, zeta, p);
            let mut r: f64 = rng.random::<f64>() * self.dev;
            let mut pick = a;
            for (k, &pk) in p.iter().enumerate() {
                if k == a {
                    continue;
                }
                pick = k;
                if r < pk {
                    break;
                }
                r -= pk;
            }
            pick
        };
        (self.landed_state(k), dist2(self.points[s], Self::centre(zeta, k)))
    }
}

impl ModelMdp for Aac {
    fn initial_distribution(&self) -> Vec<(usize, f64)> {
        let n = self.points.len();
        (0..n).map(|i| (i, 1.0 / n as f64)).collect()
    }

    /// One outcome per cluster, in cluster order (those whose probability underflows to 0
    /// stay, with zero derivative).
    fn outcomes(&self, s: usize, a: usize, zeta: &[f64], grad: bool, out: &mut Outcomes) {
        SCRATCH.with(|cell| self.outcomes_with(s, a, zeta, grad, out, &mut cell.borrow_mut()))
    }

    /// Every point's K actions, each with one outcome per cluster: the landed states, whatever
    /// ζ, so the successors are written here and [`Aac::outcome_values`] fills in the rest.
    fn all_outcomes(
        &self,
        zeta: &[f64],
        next: &mut Vec<usize>,
        prob: &mut Vec<f64>,
        cost: &mut Vec<f64>,
        ends: &mut Vec<usize>,
    ) {
        for _ in 0..self.points.len() * self.k {
            next.extend((0..self.k).map(|k| self.landed_state(k)));
            ends.push(next.len());
        }
        self.outcome_values(zeta, prob, cost);
    }

    /// The landing probabilities and costs of every point's actions, as [`Aac::outcomes`]
    /// computes them, in one pass without its per-action buffers: the successors are the
    /// landed states at every ζ.
    fn outcome_values(&self, zeta: &[f64], prob: &mut Vec<f64>, cost: &mut Vec<f64>) -> bool {
        let mut p = vec![0.0; self.k];
        for (i, &x) in self.points.iter().enumerate() {
            for a in 0..self.k {
                self.landing(i, a, zeta, &mut p);
                prob.extend_from_slice(&p);
                cost.extend((0..self.k).map(|k| dist2(x, Self::centre(zeta, k))));
            }
        }
        true
    }

    /// Costs of the order of the squared extent of the points; one stage (every episode is
    /// one step).
    fn oracle_hints(&self) -> OracleHints {
        OracleHints::from_cost_scale(self.cost_scale(), 1)
    }
}

/// The features of assigning point i to cluster j: `[x̃_i, ỹ_j, (y_j − x_i)/L, ‖y_j − x_i‖²/L²,
/// ‖y_k − x_i‖²/L² for every k]`, with `x̃ = (x − c)/L` over the points' frame. The distances to
/// every centre are where a deviating point may land; no one-hot state (the features
/// generalise across points).
#[derive(Debug, Clone)]
struct AacFeatures {
    points: Vec<[f64; 2]>,
    k: usize,
    center: [f64; 2],
    scale: f64,
}

impl FeatureMap for AacFeatures {
    fn onehot_state(&self) -> bool {
        false
    }
    fn dim(&self) -> usize {
        7 + self.k
    }
    fn write(&self, s: usize, a: usize, zeta: &[f64], out: &mut [f32]) {
        let (c, l) = (self.center, self.scale);
        let x = self.points[s];
        let y = Aac::centre(zeta, a);
        out[0] = ((x[0] - c[0]) / l) as f32;
        out[1] = ((x[1] - c[1]) / l) as f32;
        out[2] = ((y[0] - c[0]) / l) as f32;
        out[3] = ((y[1] - c[1]) / l) as f32;
        out[4] = ((y[0] - x[0]) / l) as f32;
        out[5] = ((y[1] - x[1]) / l) as f32;
        out[6] = (dist2(x, y) / (l * l)) as f32;
        for k in 0..self.k {
            out[7 + k] = (dist2(x, Aac::centre(zeta, k)) / (l * l)) as f32;
        }
    }
    fn chain(&self, s: usize, a: usize, zeta: &[f64], g: &[f32], scale: f64, out: &mut [f64]) {
        let l = self.scale;
        let x = self.points[s];
        let y = Aac::centre(zeta, a);
        let g = |i: usize| g[i] as f64 * scale;
        for c in 0..2 {
            out[2 * a + c] += (g(2 + c) + g(4 + c)) / l + 2.0 * (y[c] - x[c]) / (l * l) * g(6);
        }
        for k in 0..self.k {
            let yk = Aac::centre(zeta, k);
            for c in 0..2 {
                out[2 * k + c] += 2.0 * (yk[c] - x[c]) / (l * l) * g(7 + k);
            }
        }
    }
}

impl Env for Aac {
    fn model(&self) -> Option<&dyn ModelMdp> {
        Some(self)
    }
    fn feature_map(&self) -> Option<Arc<dyn FeatureMap>> {
        Some(Arc::new(AacFeatures { points: self.points.clone(), k: self.k, center: self.center, scale: self.scale }))
    }
    /// Points coloured by their assigned cluster, and the centres.
    fn sketch(&self, zeta: &[f64], actions: &[usize]) -> Option<Sketch> {
        Some(Sketch {
            points: self
                .points
                .iter()
                .enumerate()
                .map(|(i, &xy)| SketchPoint { xy, group: Some(actions[i]) })
                .collect(),
            markers: (0..self.k)
                .map(|j| SketchMarker { xy: Self::centre(zeta, j), label: format!("C{}", j + 1) })
                .collect(),
            ..Sketch::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use envpg_core::Registry;

    fn small(dev: f64, temperature: f64, w_point: f64) -> Aac {
        let text = format!(
            r#"{{"env":"aac","name":"t","clusters":3,"points":[[0.1,0.2],[0.8,0.3],[0.5,0.9],[0.4,0.4]],
                "params":{{"deviation":{dev},"temperature":{temperature},"w_point":{w_point}}}}}"#
        );
        let mut file = InstanceFile::parse(&text, "t.json").unwrap();
        file.resolve_params(&Aac::params(), &[]).unwrap();
        Aac::from_instance(&file).unwrap()
    }
    const ZETA: [f64; 6] = [0.3, 0.4, 0.6, 0.5, 0.45, 0.75];

    #[test]
    fn the_model_passes_the_environment_checks() {
        for (dev, t, wp) in [(0.4, 100.0, 0.0), (0.4, 0.05, 0.0), (0.2, 0.5, 0.5), (0.0, 1.0, 0.0)] {
            let env = small(dev, t, wp);
            envpg_core::checks::outcome_derivatives(&env, &ZETA, 1e-6, 1e-6);
            envpg_core::checks::state_paths(&env, &ZETA);
            envpg_core::checks::feature_chain(&env, &*env.feature_map().unwrap(), &ZETA);
            envpg_core::checks::sampler_frequencies(&env, 1, 2, &ZETA, 100_000);
        }
    }

    #[test]
    fn a_sharp_kernel_sends_deviations_to_the_nearest_other_centre_without_underflow() {
        let env = small(0.4, 0.001, 0.0);
        let mut o = Outcomes::default();
        env.outcomes(0, 0, &[0.0, 0.0, 0.1, 0.0, 5.0, 5.0], true, &mut o);
        assert!(o.prob.iter().chain(&o.dprob).all(|p| p.is_finite()));
        assert!((o.prob[0] - 0.6).abs() < 1e-15 && (o.prob[1] - 0.4).abs() < 1e-12 && o.prob[2] < 1e-300);
    }

    #[test]
    fn the_bundled_data_set_loads_and_bad_fields_are_named() {
        let reg = Registry::new().register::<Aac>().bundle("aac1800", AAC1800);
        let env = reg.load("aac1800", &[]).unwrap();
        let s = env.sampler();
        assert_eq!((s.n_states(), s.n_actions(), s.zeta_dim()), (1800 + 4, 4, 8));
        assert_eq!((env.param("deviation"), env.param("temperature")), (Some(0.4), Some(100.0)));
        let base = r#""env":"aac","name":"t","points":[[0,0],[1,1]]"#;
        for (extra, field) in [
            (r#","clusters":0"#, "clusters"),
            (r#","clusters":4294967296"#, "clusters"),
            (r#","clusters":2,"params":{"deviation":1}"#, "params.deviation"),
            (r#","clusters":2,"params":{"temperature":0}"#, "params.temperature"),
            (r#","clusters":2,"params":{"w_point":-1}"#, "params.w_point"),
            (r#","clusters":2,"bounds":[[0,1]]"#, "bounds"),
        ] {
            let text = format!("{{{base}{extra}}}");
            let e = reg.build(InstanceFile::parse(&text, "t.json").unwrap(), &[]).unwrap_err().to_string();
            assert!(e.contains(&format!("`{field}`")), "{text}: {e}");
        }
    }
}
