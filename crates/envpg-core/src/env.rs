//! [`Env`]: a registered environment — the sampler, plus the optional model, feature map and
//! picture of a design — and [`Sketch`], that picture.

use std::sync::Arc;

use crate::features::FeatureMap;
use crate::mdp::{ModelMdp, ParamMdp};

/// An environment as envpg's tools hold it: the black-box sampler ([`ParamMdp`]) with optional
/// capabilities. Each accessor returns `None` unless the environment provides it.
///
/// Model-free training is handed the sampler alone (`&dyn ParamMdp`, to which any `&dyn Env`
/// coerces), so it cannot reach the model even by accident; the model scores results for the
/// report and drives the oracle.
pub trait Env: ParamMdp {
    /// The exact model, if the environment has one (needed by the oracle and exact evaluation).
    fn model(&self) -> Option<&dyn ModelMdp> {
        None
    }
    /// The environment's own dense network inputs, if any (otherwise Algorithm 1 uses one-hot
    /// state and action inputs and the ζ block).
    fn feature_map(&self) -> Option<Arc<dyn FeatureMap>> {
        None
    }
    /// A 2-D picture of the design `zeta` with the deterministic policy `actions` (one global
    /// action per state; entries of terminal states are unused), for `envpg plot`.
    fn sketch(&self, zeta: &[f64], actions: &[usize]) -> Option<Sketch> {
        let _ = (zeta, actions);
        None
    }
}

/// A 2-D picture of a design, drawn by `envpg plot` and `envpg table`: fixed points coloured by
/// a group, the design's markers, labelled landmarks and arrows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sketch {
    /// Fixed points (users, data points, agents), small dots.
    pub points: Vec<SketchPoint>,
    /// The design (relays, centres, facilities), large coloured markers.
    pub markers: Vec<SketchMarker>,
    /// Fixed labelled places (destinations), black squares.
    pub landmarks: Vec<SketchLandmark>,
    /// Arrows (the next hop of a relay, an agent's route).
    pub arrows: Vec<SketchArrow>,
}

/// A fixed point of a [`Sketch`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SketchPoint {
    /// Position.
    pub xy: [f64; 2],
    /// Colour group (the marker it is assigned to), if any.
    pub group: Option<usize>,
}

/// A design marker of a [`Sketch`]; its colour is that of the points whose group is its index.
#[derive(Debug, Clone, PartialEq)]
pub struct SketchMarker {
    /// Position.
    pub xy: [f64; 2],
    /// Label drawn beside it.
    pub label: String,
}

/// A labelled landmark of a [`Sketch`].
#[derive(Debug, Clone, PartialEq)]
pub struct SketchLandmark {
    /// Position.
    pub xy: [f64; 2],
    /// Label drawn beside it.
    pub label: String,
}

/// An arrow of a [`Sketch`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SketchArrow {
    /// Tail.
    pub from: [f64; 2],
    /// Head.
    pub to: [f64; 2],
    /// Drawn bold (a hop the policy uses) rather than faint.
    pub strong: bool,
}
