//! `uav` — the UAV relay network of the paper's Section V.
//!
//! States: users `0..N`, UAVs `N..N+M`, destination `N+M` (terminal, cost-free).
//! Global actions: `0..M` = "send to UAV j", `M` = "send to the destination".
//! From a user the valid actions are the M UAVs; from UAV j the other UAVs and the destination.
//! ζ = the UAV positions `(x₀, y₀, x₁, y₁, …)`, unbounded.
//!
//! Transition kernel ([`crate::hop`]): the target of the chosen action with probability κ,
//! otherwise one of the targets of the *other* valid actions of `s`, drawn from the Gibbs
//! distribution `q(s') ∝ exp(−η‖x_{s'} − x_s‖²)`. The cost is `‖x_{s'} − x_s‖²` of the hop
//! actually taken; μ is uniform over the users.
//!
//! Instance files: `{"name", "n_uav", "users": [[x, y], …], "dest": [x, y]}`, with `"env":
//! "uav"` optional and `params` κ (`kappa`, default 1) and η (`eta`, default 100).

use std::sync::Arc;

use envpg_core::instance::points;
use envpg_core::{
    DesignElement, Env, EnvRng, EnvSpec, FeatureMap, InstanceError, InstanceFile, ModelMdp, OracleHints, ParamMdp,
    ParamSpec, Sketch, SketchLandmark, SketchMarker, SketchPoint, ZetaSpace,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, Normal, Uniform};
use serde::{Deserialize, Serialize};

use crate::hop::{HopNetwork, Place};

/// Largest number of UAVs an instance may have ([`crate::MAX_DESIGN_POINTS`]).
pub const MAX_UAVS: usize = crate::MAX_DESIGN_POINTS;

/// The bundled instance of the paper (`launch/instances/uav271.json`).
pub const UAV271: &str = include_str!("../../../launch/instances/uav271.json");

/// The fields of a UAV instance: fixed users, the number of UAVs and the destination.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UavInstance {
    /// Human-readable name.
    pub name: String,
    /// Number of UAVs M (ζ has 2M entries).
    pub n_uav: usize,
    /// User positions.
    pub users: Vec<[f64; 2]>,
    /// Destination position.
    pub dest: [f64; 2],
}

impl UavInstance {
    /// Number of users N.
    pub fn n_users(&self) -> usize {
        self.users.len()
    }

    /// The users' bounding box `([min_x, min_y], [max_x, max_y])`.
    pub fn user_bbox(&self) -> ([f64; 2], [f64; 2]) {
        bbox(&self.users)
    }

    /// The squared diagonal of the bounding box of users and destination: the natural scale of
    /// hop costs, used to pick default temperatures.
    pub fn cost_scale(&self) -> f64 {
        let (mut lo, mut hi) = self.user_bbox();
        for k in 0..2 {
            lo[k] = lo[k].min(self.dest[k]);
            hi[k] = hi[k].max(self.dest[k]);
        }
        ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2)).max(1e-12)
    }

    /// The instance as JSON text (`"env": "uav"`, default parameters).
    pub fn to_json_pretty(&self) -> String {
        let mut v = serde_json::to_value(self).expect("instance serializes");
        v.as_object_mut().expect("object").insert("env".into(), "uav".into());
        serde_json::to_string_pretty(&v).expect("instance serializes")
    }
}

/// The bounding box of `points`.
pub fn bbox(points: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for u in points {
        for k in 0..2 {
            lo[k] = lo[k].min(u[k]);
            hi[k] = hi[k].max(u[k]);
        }
    }
    (lo, hi)
}

/// The UAV relay network with fixed κ and η; ζ is supplied per call.
#[derive(Debug, Clone)]
pub struct UavNetwork {
    instance: UavInstance,
    hop: HopNetwork,
    space: ZetaSpace,
}

impl UavNetwork {
    /// Builds the network for `instance` with target probability `kappa` and concentration `eta`;
    /// out-of-range values are errors naming the field (origin `<inline>`).
    pub fn new(instance: UavInstance, kappa: f64, eta: f64) -> Result<Self, InstanceError> {
        let invalid = |field: &str, reason: String| InstanceError::Invalid {
            path: "<inline>".into(),
            field: field.into(),
            reason,
        };
        check_instance(&instance).map_err(|(f, r)| invalid(&f, r))?;
        check_kappa_eta(kappa, eta).map_err(|(f, r)| invalid(f, r))?;
        Ok(Self::build(instance, kappa, eta))
    }

    fn build(instance: UavInstance, kappa: f64, eta: f64) -> Self {
        let n = instance.n_users();
        let m = instance.n_uav;
        let mut places: Vec<Place> = instance.users.iter().map(|&u| Place::Fixed(u)).collect();
        places.extend((0..m).map(|j| Place::Zeta(2 * j)));
        places.push(Place::Fixed(instance.dest));
        let uav = |j: usize| n + j;
        let dest = n + m;
        let mut moves: Vec<Vec<(usize, usize)>> = (0..n).map(|_| (0..m).map(|a| (a, uav(a))).collect()).collect();
        for j in 0..m {
            moves.push((0..=m).filter(|&a| a != j).map(|a| (a, if a < m { uav(a) } else { dest })).collect());
        }
        moves.push(Vec::new());
        let hop = HopNetwork::new(m + 1, kappa, eta, places, moves);
        let (c, l) = hop.fixed_frame();
        let d = 2 * m;
        let space = ZetaSpace::with_scales(
            ZetaSpace::point_names("uav", m),
            vec![f64::NEG_INFINITY; d],
            vec![f64::INFINITY; d],
            (0..d).map(|i| c[i % 2]).collect(),
            vec![l; d],
        )
        .expect("valid design space");
        Self { instance, hop, space }
    }

    /// The instance.
    pub fn instance(&self) -> &UavInstance {
        &self.instance
    }
    /// κ, the probability of reaching the intended target.
    pub fn kappa(&self) -> f64 {
        self.hop.kappa()
    }
    /// η, the concentration of off-target moves.
    pub fn eta(&self) -> f64 {
        self.hop.eta()
    }
    /// Number of users N.
    pub fn n_users(&self) -> usize {
        self.instance.n_users()
    }
    /// Number of UAVs M.
    pub fn n_uav(&self) -> usize {
        self.instance.n_uav
    }
    /// The destination state `N + M`.
    pub fn dest_state(&self) -> usize {
        self.n_users() + self.n_uav()
    }
    /// The state of UAV `j`.
    pub fn uav_state(&self, j: usize) -> usize {
        self.n_users() + j
    }
    /// The UAV index of state `s`, if it is a UAV.
    pub fn uav_of(&self, s: usize) -> Option<usize> {
        let n = self.n_users();
        (s >= n && s < n + self.n_uav()).then(|| s - n)
    }
    /// The destination action `M`.
    pub fn dest_action(&self) -> usize {
        self.n_uav()
    }
    /// The state action `a` aims at (the same from every state).
    pub fn action_target(&self, a: usize) -> usize {
        if a < self.n_uav() { self.uav_state(a) } else { self.dest_state() }
    }
    /// The position of state `s` at design `zeta`.
    pub fn position(&self, s: usize, zeta: &[f64]) -> [f64; 2] {
        self.hop.position(s, zeta)
    }
    /// The hop kernel.
    pub fn hop(&self) -> &HopNetwork {
        &self.hop
    }

    /// The relay chain from the users' centroid to the destination: UAV j at fraction j/M of the
    /// way (observable coordinates only).
    pub fn relay_chain(&self) -> Vec<f64> {
        let inst = &self.instance;
        let m = inst.n_uav;
        let n = inst.n_users() as f64;
        let c = inst.users.iter().fold([0.0, 0.0], |a, u| [a[0] + u[0] / n, a[1] + u[1] / n]);
        let dst = inst.dest;
        (0..m)
            .flat_map(|j| {
                let t = j as f64 / m as f64;
                [c[0] + t * (dst[0] - c[0]), c[1] + t * (dst[1] - c[1])]
            })
            .collect()
    }
}

fn check_instance(inst: &UavInstance) -> Result<(), (String, String)> {
    if inst.name.trim().is_empty() {
        return Err(("name".into(), "must be a non-empty string".into()));
    }
    if inst.n_uav < 2 {
        return Err(("n_uav".into(), format!("must be at least 2, got {}", inst.n_uav)));
    }
    if inst.n_uav > MAX_UAVS {
        return Err(("n_uav".into(), format!("at most {MAX_UAVS} UAVs are supported, got {}", inst.n_uav)));
    }
    if inst.users.is_empty() {
        return Err(("users".into(), "must contain at least one user".into()));
    }
    for (i, u) in inst.users.iter().enumerate() {
        if !(u[0].is_finite() && u[1].is_finite()) {
            return Err((format!("users[{i}]"), format!("coordinates must be finite, got {u:?}")));
        }
    }
    if !(inst.dest[0].is_finite() && inst.dest[1].is_finite()) {
        return Err(("dest".into(), format!("coordinates must be finite, got {:?}", inst.dest)));
    }
    Ok(())
}

/// κ ∈ (0, 1] and η ≥ 0, both finite (shared with `flpo`).
pub(crate) fn check_kappa_eta(kappa: f64, eta: f64) -> Result<(), (&'static str, String)> {
    if !(kappa.is_finite() && kappa > 0.0 && kappa <= 1.0) {
        return Err(("params.kappa", format!("kappa must be in (0, 1], got {kappa}")));
    }
    if !(eta.is_finite() && eta >= 0.0) {
        return Err(("params.eta", format!("eta must be finite and non-negative, got {eta}")));
    }
    Ok(())
}

/// The parameters κ and η of a hop kernel (shared with `flpo`).
pub(crate) fn hop_params() -> Vec<ParamSpec> {
    vec![
        ParamSpec {
            name: "kappa",
            default: 1.0,
            about: "probability that a hop reaches its intended target, in (0, 1]",
        },
        ParamSpec { name: "eta", default: 100.0, about: "concentration η ≥ 0 of the off-target Gibbs kernel" },
    ]
}

impl EnvSpec for UavNetwork {
    const NAME: &'static str = "uav";
    const ABOUT: &'static str = "UAV relay network (the paper's Section V): users → UAVs (ζ) → destination";

    fn params() -> Vec<ParamSpec> {
        hop_params()
    }

    fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError> {
        file.expect_fields(&["n_uav", "users", "dest"])?;
        let inst = UavInstance {
            name: file.name().to_owned(),
            n_uav: file.field("n_uav")?,
            users: points(file, "users")?,
            dest: file.field("dest")?,
        };
        check_instance(&inst).map_err(|(f, r)| file.invalid(&f, r))?;
        let (kappa, eta) = (file.param("kappa")?, file.param("eta")?);
        check_kappa_eta(kappa, eta).map_err(|(f, r)| file.invalid(f, r))?;
        Ok(Self::build(inst, kappa, eta))
    }
}

impl ParamMdp for UavNetwork {
    fn n_states(&self) -> usize {
        self.n_users() + self.n_uav() + 1
    }
    fn n_actions(&self) -> usize {
        self.n_uav() + 1
    }
    fn zeta_space(&self) -> &ZetaSpace {
        &self.space
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        self.hop.valid_actions(s)
    }
    fn is_terminal(&self, s: usize) -> bool {
        s == self.dest_state()
    }
    fn sample_initial(&self, rng: &mut EnvRng) -> usize {
        rng.random_range(0..self.n_users())
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        self.hop.step(s, a, zeta, rng)
    }
    /// The squared extent of users and destination.
    fn cost_scale(&self) -> f64 {
        self.instance.cost_scale()
    }
    /// A uniformly drawn UAV: the relay states μ only reaches through the policy.
    fn sample_exploring_start(&self, rng: &mut EnvRng) -> usize {
        self.uav_state(rng.random_range(0..self.n_uav()))
    }
    /// Uniform over the users' bounding box, x then y per UAV.
    fn random_design(&self, rng: &mut EnvRng) -> Vec<f64> {
        let (lo, hi) = self.instance.user_bbox();
        let ux = Uniform::new_inclusive(lo[0], hi[0]).expect("finite box");
        let uy = Uniform::new_inclusive(lo[1], hi[1]).expect("finite box");
        (0..self.n_uav()).flat_map(|_| [ux.sample(rng), uy.sample(rng)]).collect()
    }
    /// UAVs at the k-means centres of the users ([`crate::cluster::kmeans`]), x then y per UAV.
    fn clustered_design(&self, rng: &mut EnvRng) -> Option<Vec<f64>> {
        Some(crate::cluster::kmeans(&self.instance.users, self.n_uav(), rng).into_iter().flatten().collect())
    }
    fn heuristic_design(&self) -> Option<Vec<f64>> {
        Some(self.relay_chain())
    }
    fn design_elements(&self) -> Vec<DesignElement> {
        self.hop.design_elements()
    }
    fn relocate(&self, _element: &DesignElement, zeta: &[f64], from: usize, to: usize) -> Option<Vec<f64>> {
        Some(self.hop.relocation(zeta, from, to))
    }
}

impl ModelMdp for UavNetwork {
    fn initial_distribution(&self) -> Vec<(usize, f64)> {
        let n = self.n_users();
        (0..n).map(|i| (i, 1.0 / n as f64)).collect()
    }
    crate::hop::hop_model_paths!();
    /// A hot start at 10× the squared extent of the instance, warm starts at 0.5, down to 10⁻³;
    /// M + 1 stages hold every simple route through the UAVs.
    fn oracle_hints(&self) -> OracleHints {
        OracleHints {
            cost_scale: self.instance.cost_scale(),
            warm_alpha0: 0.5,
            alpha_min: 1e-3,
            horizon: self.n_uav() + 1,
        }
    }
}

impl Env for UavNetwork {
    fn model(&self) -> Option<&dyn ModelMdp> {
        Some(self)
    }
    fn feature_map(&self) -> Option<Arc<dyn FeatureMap>> {
        Some(self.hop.features())
    }
    /// Users coloured by the UAV they send to, the UAVs, the destination and each UAV's next
    /// hop (bold where a user's route passes).
    fn sketch(&self, zeta: &[f64], actions: &[usize]) -> Option<Sketch> {
        let n = self.n_users();
        let users: Vec<usize> = (0..n).collect();
        Some(Sketch {
            points: (0..n).map(|u| SketchPoint { xy: self.instance.users[u], group: Some(actions[u]) }).collect(),
            markers: (0..self.n_uav())
                .map(|j| SketchMarker { xy: [zeta[2 * j], zeta[2 * j + 1]], label: format!("U{}", j + 1) })
                .collect(),
            landmarks: vec![SketchLandmark { xy: self.instance.dest, label: "dest".into() }],
            arrows: self.hop.policy_arrows(zeta, actions, &users),
        })
    }
}

/// Parameters of [`generate`].
#[derive(Debug, Clone)]
pub struct GenerateSpec {
    /// Instance name.
    pub name: String,
    /// Number of users.
    pub n_users: usize,
    /// Number of UAVs.
    pub n_uav: usize,
    /// Number of user clusters.
    pub clusters: usize,
    /// Side of the square region `[0, side]²`.
    pub side: f64,
    /// Standard deviation of users around their cluster centre.
    pub spread: f64,
    /// Seed of the generator.
    pub seed: u64,
}

/// Generates a seeded instance with clustered users in `[0, side]²` and the destination near
/// the lower-right corner (as in the bundled instance).
pub fn generate(spec: &GenerateSpec) -> Result<UavInstance, InstanceError> {
    let invalid = |field: &str, reason: String| InstanceError::Invalid {
        path: "<generated>".into(),
        field: field.to_owned(),
        reason,
    };
    if spec.n_users == 0 {
        return Err(invalid("users", "need at least one user".into()));
    }
    if spec.clusters == 0 {
        return Err(invalid("clusters", "need at least one cluster".into()));
    }
    if !(spec.side.is_finite() && spec.side > 0.0) {
        return Err(invalid("side", format!("must be finite and positive, got {}", spec.side)));
    }
    if !(spec.spread.is_finite() && spec.spread >= 0.0) {
        return Err(invalid("spread", format!("must be finite and non-negative, got {}", spec.spread)));
    }
    let mut rng = ChaCha12Rng::seed_from_u64(spec.seed);
    let centre = Uniform::new(0.1 * spec.side, 0.8 * spec.side).expect("valid range");
    let noise = Normal::new(0.0, spec.spread).expect("valid spread");
    let centres: Vec<[f64; 2]> =
        (0..spec.clusters).map(|_| [centre.sample(&mut rng), centre.sample(&mut rng)]).collect();
    let users = (0..spec.n_users)
        .map(|i| {
            let c = centres[i % spec.clusters];
            [
                (c[0] + noise.sample(&mut rng)).clamp(0.0, spec.side),
                (c[1] + noise.sample(&mut rng)).clamp(0.0, spec.side),
            ]
        })
        .collect();
    let inst =
        UavInstance { name: spec.name.clone(), n_uav: spec.n_uav, users, dest: [0.95 * spec.side, 0.05 * spec.side] };
    check_instance(&inst).map_err(|(f, r)| invalid(&f, r))?;
    Ok(inst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use envpg_core::{Outcomes, Purpose, Registry, Streams};

    fn small(kappa: f64) -> UavNetwork {
        let inst = UavInstance {
            name: "t".into(),
            n_uav: 3,
            users: vec![[0.0, 0.0], [1.0, 0.5], [0.3, 1.2]],
            dest: [2.0, 2.0],
        };
        UavNetwork::new(inst, kappa, 100.0).unwrap()
    }
    const ZETA: [f64; 6] = [0.2, 0.1, 0.9, 0.9, 1.5, 1.4];

    fn registry() -> Registry {
        Registry::new().register::<UavNetwork>()
    }

    #[test]
    fn layout_matches_the_paper() {
        let net = small(0.9);
        assert_eq!(net.n_states(), 3 + 3 + 1);
        assert_eq!(net.valid_actions(0), &[0, 1, 2]);
        assert_eq!(net.valid_actions(4), &[0, 2, 3]); // UAV 1: other UAVs + destination
        assert!(net.valid_actions(6).is_empty() && net.is_terminal(6));
        assert_eq!(net.zeta_space().names()[2], "uav1.x");
    }

    #[test]
    fn rows_sum_to_one_and_kappa_one_is_deterministic() {
        let mut o = Outcomes::default();
        for kappa in [1.0, 0.85] {
            let net = small(kappa);
            for s in 0..6 {
                for &a in net.valid_actions(s) {
                    net.outcomes(s, a, &ZETA, false, &mut o);
                    let sum: f64 = o.prob.iter().sum();
                    assert!((sum - 1.0).abs() < 1e-15, "{sum}");
                    if kappa == 1.0 {
                        assert_eq!(o.next, vec![net.action_target(a)]);
                    }
                }
            }
        }
    }

    #[test]
    fn off_target_softmax_is_stable_for_large_eta() {
        // Targets far apart: the naive e/(Σe − e_a) form gives 0/0 here.
        let inst = UavInstance { name: "t".into(), n_uav: 3, users: vec![[0.0, 0.0]], dest: [50.0, 50.0] };
        let net = UavNetwork::new(inst, 0.5, 100.0).unwrap();
        let zeta = [0.1, 0.0, 30.0, 0.0, 31.0, 0.0];
        let mut o = Outcomes::default();
        net.outcomes(0, 0, &zeta, true, &mut o);
        assert!(o.prob.iter().chain(&o.dprob).all(|p| p.is_finite()));
        // The nearer of the two other UAVs takes essentially all the off-target mass.
        assert!((o.prob[1] - 0.5).abs() < 1e-12 && o.prob[2] < 1e-300);
    }

    #[test]
    fn derivatives_match_central_differences() {
        envpg_core::checks::outcome_derivatives(&small(0.85), &ZETA, 1e-6, 1e-6);
        envpg_core::checks::outcome_derivatives(&small(1.0), &ZETA, 1e-6, 1e-6);
    }

    #[test]
    fn shared_state_path_matches_per_action_outcomes_and_dense_gradients() {
        for kappa in [1.0, 0.85] {
            envpg_core::checks::state_paths(&small(kappa), &ZETA);
        }
    }

    #[test]
    fn sampler_frequencies_match_the_model() {
        let net = small(0.7);
        envpg_core::checks::sampler_frequencies(&net, 4, 2, &ZETA, 200_000); // UAV 1 aiming at UAV 2
        envpg_core::checks::sampler_frequencies(&net, 0, 1, &ZETA, 50_000);
    }

    #[test]
    fn feature_chain_rule_matches_central_differences() {
        let net = small(1.0);
        envpg_core::checks::feature_chain(&net, &*net.feature_map().unwrap(), &ZETA);
    }

    #[test]
    fn instances_load_with_defaults_and_refuse_bad_fields_naming_them() {
        let reg = registry();
        let file = |text: &str| InstanceFile::parse(text, "t.json").unwrap();
        let env = reg.build(file(r#"{"name":"a","n_uav":2,"users":[[0,0],[1,2]],"dest":[3,4]}"#), &[]).unwrap();
        assert_eq!((env.name, env.param("kappa"), env.param("eta")), ("uav", Some(1.0), Some(100.0)));
        assert_eq!(env.sampler().zeta_dim(), 4);
        for (text, field) in [
            (r#"{"name":"a","n_uav":1,"users":[[0,0]],"dest":[3,4]}"#, "n_uav"),
            (r#"{"name":"a","n_uav":2,"users":[],"dest":[3,4]}"#, "users"),
            (r#"{"name":"a","n_uav":2,"users":[[0,0,1]],"dest":[3,4]}"#, "users[0]"),
            (r#"{"name":"a","n_uav":2,"users":[[0,0]],"dest":[3,4],"x":1}"#, "x"),
            (r#"{"name":"a","n_uav":2,"users":[[0,0]]}"#, "dest"),
            (r#"{"name":"a","n_uav":2,"users":[[0,0]],"dest":[3,4],"params":{"kappa":0}}"#, "params.kappa"),
            (r#"{"name":"a","n_uav":2,"users":[[0,0]],"dest":[3,4],"params":{"eta":-1}}"#, "params.eta"),
        ] {
            let e = reg.build(file(text), &[]).unwrap_err().to_string();
            assert!(e.contains(&format!("`{field}`")) && e.contains("t.json"), "{text}: {e}");
        }
        let e = reg.build(file(r#"{"name":"a","n_uav":2,"users":[[0,0]],"dest":[3,4]}"#), &[("kappa".into(), 2.0)]);
        assert!(e.unwrap_err().to_string().contains("params.kappa"));
    }

    #[test]
    fn generate_is_seeded_and_valid() {
        let spec =
            GenerateSpec { name: "g".into(), n_users: 50, n_uav: 3, clusters: 4, side: 10.0, spread: 0.5, seed: 7 };
        let a = generate(&spec).unwrap();
        let b = generate(&spec).unwrap();
        assert_eq!(a, b);
        let c = generate(&GenerateSpec { seed: 8, ..spec }).unwrap();
        assert_ne!(a, c);
        let env = registry().build(InstanceFile::parse(&a.to_json_pretty(), "g").unwrap(), &[]).unwrap();
        assert_eq!(env.sampler().n_states(), 50 + 3 + 1);
    }

    #[test]
    fn clustered_designs_put_a_uav_on_each_group_of_users_reproducibly() {
        // Two far-apart groups and two UAVs: every draw puts one UAV at each group's mean.
        let users = vec![[0.0, 0.0], [0.2, 0.0], [0.1, 0.3], [9.0, 9.0], [9.4, 9.0]];
        let net =
            UavNetwork::new(UavInstance { name: "g".into(), n_uav: 2, users, dest: [5.0, 0.0] }, 1.0, 100.0).unwrap();
        for seed in 0..10 {
            let draw = || net.clustered_design(&mut Streams::new(seed).stream(Purpose::Zeta0, 1, 0)).unwrap();
            let z = draw();
            assert_eq!(z, draw(), "seed {seed}");
            let mut uavs = [[z[0], z[1]], [z[2], z[3]]];
            uavs.sort_by(|a, b| a[0].total_cmp(&b[0]));
            assert!((uavs[0][0] - 0.1).abs() < 1e-12 && (uavs[0][1] - 0.1).abs() < 1e-12, "{uavs:?}");
            assert!((uavs[1][0] - 9.2).abs() < 1e-12 && (uavs[1][1] - 9.0).abs() < 1e-12, "{uavs:?}");
        }
    }

    #[test]
    fn random_designs_cover_the_users_box_reproducibly() {
        let net = small(1.0);
        let mut r = Streams::new(3).stream(Purpose::Zeta0, 0, 0);
        let z = net.random_design(&mut r);
        let mut again = Streams::new(3).stream(Purpose::Zeta0, 0, 0);
        assert_eq!(z, net.random_design(&mut again));
        let (lo, hi) = net.instance().user_bbox();
        for j in 0..3 {
            assert!((lo[0]..=hi[0]).contains(&z[2 * j]) && (lo[1]..=hi[1]).contains(&z[2 * j + 1]));
        }
    }
}
