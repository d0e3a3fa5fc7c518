//! `flpo` — facility location with path optimisation (the LearningFLPO benchmark, arXiv
//! 2507.22338; `../shared/envs.md`).
//!
//! N agents each travel from their start `x_i` to one of D destinations through any number of
//! M facilities whose positions are the design, ζ = `(f₀ₓ, f₀ᵧ, f₁ₓ, …)` inside a box.
//!
//! - States: `0 … N−1` agent i at its start; then `N + d·M + j` = at facility j, bound for
//!   destination d; then `N + D·M + d` = arrived at destination d (terminal, cost-free). μ is
//!   uniform over the agents.
//! - Actions: `0 … M−1` = hop to facility j, `M` = hop to my destination. From a start: every
//!   facility and the destination (a direct hop is allowed); from facility state (j, d): every
//!   other facility and destination d.
//! - Transition ([`crate::hop`]): with probability κ the hop reaches its target, otherwise one
//!   of the state's *other* targets ∝ `exp(−η‖x_{s'} − x_s‖²)`; hopping to a facility keeps
//!   the destination. Cost: the squared distance travelled. J = mean over agents of the
//!   expected cost to arrive.
//!
//! Instance files: `{"env": "flpo", "name", "facilities": M, "agents": [{"start": [x, y],
//! "dest": d}, …], "destinations": [[x, y], …], "bounds": [[xmin, xmax], [ymin, ymax]],
//! "initial_facilities": [[x, y], …]}` (the last two optional: the unit box, no starting
//! design), `params` κ (`kappa`, default 1) and η (`eta`, default 100).

use std::sync::Arc;

use envpg_core::instance::points;
use envpg_core::{
    DesignElement, Env, EnvRng, EnvSpec, FeatureMap, InstanceError, InstanceFile, ModelMdp, OracleHints, ParamMdp,
    ParamSpec, Sketch, SketchLandmark, SketchMarker, SketchPoint, ZetaSpace,
};
use rand::RngExt;
use serde::Deserialize;

use crate::hop::{HopNetwork, Place};
use crate::uav::{bbox, check_kappa_eta, hop_params};

/// The bundled benchmark instance `N10_M4_ends2_seed3` (`launch/instances/flpo-n10m4.json`).
pub const FLPO_N10M4: &str = include_str!("../../../launch/instances/flpo-n10m4.json");

/// One agent of an instance.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Agent {
    /// Start position.
    pub start: [f64; 2],
    /// Index of its destination.
    pub dest: usize,
}

/// Facility location with path optimisation.
#[derive(Debug, Clone)]
pub struct Flpo {
    agents: Vec<Agent>,
    destinations: Vec<[f64; 2]>,
    m: usize,
    initial: Option<Vec<f64>>,
    hop: HopNetwork,
    space: ZetaSpace,
}

impl Flpo {
    /// Number of agents N.
    pub fn n_agents(&self) -> usize {
        self.agents.len()
    }
    /// Number of facilities M.
    pub fn n_facilities(&self) -> usize {
        self.m
    }
    /// Number of destinations D.
    pub fn n_destinations(&self) -> usize {
        self.destinations.len()
    }
    /// The state "at facility `j`, bound for destination `d`".
    pub fn facility_state(&self, j: usize, d: usize) -> usize {
        self.n_agents() + d * self.m + j
    }
    /// The terminal state "arrived at destination `d`".
    pub fn arrived_state(&self, d: usize) -> usize {
        self.n_agents() + self.n_destinations() * self.m + d
    }
    /// The hop kernel.
    pub fn hop(&self) -> &HopNetwork {
        &self.hop
    }
}

impl EnvSpec for Flpo {
    const NAME: &'static str = "flpo";
    const ABOUT: &'static str =
        "facility location with path optimization (LearningFLPO): agents → facilities (ζ) → destinations";

    fn params() -> Vec<ParamSpec> {
        hop_params()
    }

    fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError> {
        file.expect_fields(&["facilities", "agents", "destinations", "bounds", "initial_facilities"])?;
        let m: usize = file.field("facilities")?;
        if m == 0 {
            return Err(file.invalid("facilities", "must be at least 1".into()));
        }
        if m > crate::MAX_DESIGN_POINTS {
            let max = crate::MAX_DESIGN_POINTS;
            return Err(file.invalid("facilities", format!("at most {max} facilities are supported, got {m}")));
        }
        let agents: Vec<Agent> = file.field("agents")?;
        let destinations = points(file, "destinations")?;
        if agents.is_empty() {
            return Err(file.invalid("agents", "must contain at least one agent".into()));
        }
        if destinations.is_empty() {
            return Err(file.invalid("destinations", "must contain at least one destination".into()));
        }
        for (i, a) in agents.iter().enumerate() {
            if !(a.start[0].is_finite() && a.start[1].is_finite()) {
                return Err(file.invalid(&format!("agents[{i}].start"), format!("must be finite, got {:?}", a.start)));
            }
            if a.dest >= destinations.len() {
                return Err(file.invalid(
                    &format!("agents[{i}].dest"),
                    format!("is {} but there are {} destinations", a.dest, destinations.len()),
                ));
            }
        }
        let bounds: [[f64; 2]; 2] = file.optional_field("bounds")?.unwrap_or([[0.0, 1.0], [0.0, 1.0]]);
        for (k, b) in bounds.iter().enumerate() {
            if !(b[0].is_finite() && b[1].is_finite() && b[0] < b[1]) {
                return Err(file.invalid(&format!("bounds[{k}]"), format!("must be finite with min < max, got {b:?}")));
            }
        }
        let (kappa, eta) = (file.param("kappa")?, file.param("eta")?);
        check_kappa_eta(kappa, eta).map_err(|(f, r)| file.invalid(f, r))?;
        let mut env = Self::build(agents, destinations, m, bounds, kappa, eta);
        if file.fields().contains_key("initial_facilities") {
            let init = points(file, "initial_facilities")?;
            if init.len() != m {
                return Err(file.invalid("initial_facilities", format!("has {} points, expected {m}", init.len())));
            }
            let z: Vec<f64> = init.iter().flatten().copied().collect();
            env.space.check(&z).map_err(|e| file.invalid("initial_facilities", e.to_string()))?;
            env.initial = Some(z);
        }
        Ok(env)
    }
}

impl Flpo {
    fn build(
        agents: Vec<Agent>,
        destinations: Vec<[f64; 2]>,
        m: usize,
        bounds: [[f64; 2]; 2],
        kappa: f64,
        eta: f64,
    ) -> Self {
        let (n, dn) = (agents.len(), destinations.len());
        let fac = |j: usize, d: usize| n + d * m + j;
        let arrived = |d: usize| n + dn * m + d;
        let mut places: Vec<Place> = agents.iter().map(|a| Place::Fixed(a.start)).collect();
        let mut moves: Vec<Vec<(usize, usize)>> = agents
            .iter()
            .map(|a| (0..m).map(|j| (j, fac(j, a.dest))).chain([(m, arrived(a.dest))]).collect())
            .collect();
        for d in 0..dn {
            for j in 0..m {
                places.push(Place::Zeta(2 * j));
                moves.push((0..m).filter(|&k| k != j).map(|k| (k, fac(k, d))).chain([(m, arrived(d))]).collect());
            }
        }
        places.extend(destinations.iter().map(|&p| Place::Fixed(p)));
        moves.extend((0..dn).map(|_| Vec::new()));
        let hop = HopNetwork::new(m + 1, kappa, eta, places, moves);
        let (c, l) = hop.fixed_frame();
        let space = ZetaSpace::with_scales(
            ZetaSpace::point_names("f", m),
            (0..2 * m).map(|i| bounds[i % 2][0]).collect(),
            (0..2 * m).map(|i| bounds[i % 2][1]).collect(),
            (0..2 * m).map(|i| c[i % 2]).collect(),
            vec![l; 2 * m],
        )
        .expect("valid design space");
        Self { agents, destinations, m, initial: None, hop, space }
    }
}

impl ParamMdp for Flpo {
    fn n_states(&self) -> usize {
        self.hop.n_states()
    }
    fn n_actions(&self) -> usize {
        self.m + 1
    }
    fn zeta_space(&self) -> &ZetaSpace {
        &self.space
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        self.hop.valid_actions(s)
    }
    fn is_terminal(&self, s: usize) -> bool {
        s >= self.arrived_state(0)
    }
    fn sample_initial(&self, rng: &mut EnvRng) -> usize {
        rng.random_range(0..self.n_agents())
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        self.hop.step(s, a, zeta, rng)
    }
    /// The squared extent of agents and destinations.
    fn cost_scale(&self) -> f64 {
        let pts: Vec<[f64; 2]> = self.agents.iter().map(|a| a.start).chain(self.destinations.iter().copied()).collect();
        let (lo, hi) = bbox(&pts);
        ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2)).max(1e-12)
    }
    /// A uniformly drawn facility state (any facility, any destination).
    fn sample_exploring_start(&self, rng: &mut EnvRng) -> usize {
        self.n_agents() + rng.random_range(0..self.m * self.n_destinations())
    }
    /// The benchmark's starting design (`initial_facilities`), if the instance has one.
    fn heuristic_design(&self) -> Option<Vec<f64>> {
        self.initial.clone()
    }
    fn design_elements(&self) -> Vec<DesignElement> {
        self.hop.design_elements()
    }
    fn relocate(&self, _element: &DesignElement, zeta: &[f64], from: usize, to: usize) -> Option<Vec<f64>> {
        let mut z = self.hop.relocation(zeta, from, to);
        for (c, v) in z.iter_mut().enumerate() {
            *v = v.clamp(self.space.lower()[c], self.space.upper()[c]);
        }
        Some(z)
    }
}

impl ModelMdp for Flpo {
    fn initial_distribution(&self) -> Vec<(usize, f64)> {
        let n = self.n_agents();
        (0..n).map(|i| (i, 1.0 / n as f64)).collect()
    }
    crate::hop::hop_model_paths!();
    /// Costs of the order of the squared extent of agents and destinations; M + 1 stages hold
    /// every simple route through the facilities.
    fn oracle_hints(&self) -> OracleHints {
        OracleHints::from_cost_scale(self.cost_scale(), self.m + 1)
    }
}

impl Env for Flpo {
    fn model(&self) -> Option<&dyn ModelMdp> {
        Some(self)
    }
    fn feature_map(&self) -> Option<Arc<dyn FeatureMap>> {
        Some(self.hop.features())
    }
    /// Agents coloured by the first facility of their greedy route, the facilities, the
    /// destinations and every agent's route.
    fn sketch(&self, zeta: &[f64], actions: &[usize]) -> Option<Sketch> {
        let agents: Vec<usize> = (0..self.n_agents()).collect();
        Some(Sketch {
            points: self
                .agents
                .iter()
                .enumerate()
                .map(|(i, a)| SketchPoint { xy: a.start, group: (actions[i] < self.m).then_some(actions[i]) })
                .collect(),
            markers: (0..self.m)
                .map(|j| SketchMarker { xy: [zeta[2 * j], zeta[2 * j + 1]], label: format!("F{}", j + 1) })
                .collect(),
            landmarks: self
                .destinations
                .iter()
                .enumerate()
                .map(|(d, &xy)| SketchLandmark { xy, label: format!("d{d}") })
                .collect(),
            arrows: self.hop.route_arrows(zeta, actions, &agents),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use envpg_core::Registry;

    fn registry() -> Registry {
        Registry::new().register::<Flpo>().bundle("flpo-n10m4", FLPO_N10M4)
    }

    fn small(kappa: f64) -> Flpo {
        let text = format!(
            r#"{{"env":"flpo","name":"t","facilities":3,"params":{{"kappa":{kappa},"eta":20}},
                "agents":[{{"start":[0.1,0.2],"dest":0}},{{"start":[0.8,0.3],"dest":1}},{{"start":[0.5,0.9],"dest":0}}],
                "destinations":[[0.9,0.9],[0.2,0.8]],"bounds":[[0.05,0.95],[0.05,0.95]]}}"#
        );
        let mut file = InstanceFile::parse(&text, "t.json").unwrap();
        file.resolve_params(&Flpo::params(), &[]).unwrap();
        Flpo::from_instance(&file).unwrap()
    }
    const ZETA: [f64; 6] = [0.3, 0.4, 0.6, 0.5, 0.45, 0.75];

    #[test]
    fn layout_follows_the_definition() {
        let env = small(0.9);
        assert_eq!(env.n_states(), 3 + 2 * 3 + 2);
        // An agent may hop to every facility (bound for its destination) or straight home.
        assert_eq!(env.valid_actions(1), &[0, 1, 2, 3]);
        assert_eq!(
            env.hop().targets(1),
            &[env.facility_state(0, 1), env.facility_state(1, 1), env.facility_state(2, 1), env.arrived_state(1)]
        );
        // From a facility: every other facility, keeping the destination, or the destination.
        let f = env.facility_state(1, 0);
        assert_eq!(env.valid_actions(f), &[0, 2, 3]);
        assert_eq!(env.hop().targets(f), &[env.facility_state(0, 0), env.facility_state(2, 0), env.arrived_state(0)]);
        assert!(env.is_terminal(env.arrived_state(1)) && !env.is_terminal(f));
        assert_eq!(env.zeta_space().lower(), &[0.05; 6]);
    }

    #[test]
    fn the_model_passes_the_environment_checks() {
        for kappa in [1.0, 0.9] {
            let env = small(kappa);
            envpg_core::checks::outcome_derivatives(&env, &ZETA, 1e-6, 1e-6);
            envpg_core::checks::state_paths(&env, &ZETA);
            envpg_core::checks::feature_chain(&env, &*env.feature_map().unwrap(), &ZETA);
        }
        let env = small(0.7);
        envpg_core::checks::sampler_frequencies(&env, 0, 1, &ZETA, 100_000);
        envpg_core::checks::sampler_frequencies(&env, env.facility_state(2, 1), 0, &ZETA, 100_000);
    }

    #[test]
    fn the_bundled_benchmark_loads_with_its_starting_design() {
        let env = registry().load("flpo-n10m4", &[]).unwrap();
        let s = env.sampler();
        assert_eq!((s.n_states(), s.n_actions(), s.zeta_dim()), (10 + 2 * 4 + 2, 5, 8));
        assert_eq!(env.param("kappa"), Some(1.0));
        let z = s.heuristic_design().unwrap();
        assert_eq!(z[..2], [0.7639706134796143, 0.257718563079834]);
    }

    #[test]
    fn bad_instances_are_named_by_field() {
        let reg = registry();
        let base = r#""env":"flpo","name":"t","facilities":2,"destinations":[[0.5,0.5]]"#;
        for (extra, field) in [
            (r#","agents":[]"#, "agents"),
            (r#","agents":[{"start":[0,0],"dest":3}]"#, "agents[0].dest"),
            (r#","agents":[{"start":[0,0],"dest":0,"x":1}]"#, "agents"),
            (r#","agents":[{"start":[0,0],"dest":0}],"bounds":[[1,0],[0,1]]"#, "bounds[0]"),
            (r#","agents":[{"start":[0,0],"dest":0}],"initial_facilities":[[0.5,0.5]]"#, "initial_facilities"),
            (r#","agents":[{"start":[0,0],"dest":0}],"initial_facilities":[[0.5,0.5],[2,0.5]]"#, "initial_facilities"),
            (r#","agents":[{"start":[0,0],"dest":0}],"params":{"kappa":1.5}"#, "params.kappa"),
        ] {
            let text = format!("{{{base}{extra}}}");
            let e = reg.build(InstanceFile::parse(&text, "t.json").unwrap(), &[]).unwrap_err().to_string();
            assert!(e.contains(&format!("`{field}`")), "{text}: {e}");
        }
        // A huge count is refused before anything is allocated for it.
        let huge = base.replace(r#""facilities":2"#, r#""facilities":4294967296"#);
        let text = format!(r#"{{{huge},"agents":[{{"start":[0,0],"dest":0}}]}}"#);
        let e = reg.build(InstanceFile::parse(&text, "t.json").unwrap(), &[]).unwrap_err().to_string();
        assert!(e.contains("`facilities`") && e.contains("at most 32"), "{text}: {e}");
    }
}
