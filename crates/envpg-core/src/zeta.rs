//! [`ZetaSpace`]: what the design parameter ζ is — its dimension, coordinate names, box bounds,
//! and a typical origin and length per coordinate (the scale of network inputs and steps).

use rand::RngExt;
use serde::{Deserialize, Serialize};

use crate::rng::StreamRng;

/// The design space of an environment.
///
/// Bounds may be infinite (an unconstrained coordinate). Everything that moves ζ respects
/// them: Algorithm 1 projects its steps and perturbations, the polish and the oracle's
/// optimiser stay inside, and a design given on the command line outside them is refused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ZetaSpace {
    names: Vec<String>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    origin: Vec<f64>,
    scale: Vec<f64>,
}

/// Why a design or a design space is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZetaError {
    /// Wrong number of coordinates.
    #[error("ζ has {got} entries, this environment's design has {expected} ({names})")]
    Length {
        /// Entries needed.
        expected: usize,
        /// Entries given.
        got: usize,
        /// The coordinate names, for the message.
        names: String,
    },
    /// A coordinate is NaN or infinite.
    #[error("ζ coordinate {name} (entry {index}) is not finite ({value})")]
    NotFinite {
        /// Entry index.
        index: usize,
        /// Coordinate name.
        name: String,
        /// The value.
        value: f64,
    },
    /// A coordinate lies outside its bounds.
    #[error("ζ coordinate {name} (entry {index}) = {value} is outside its bounds [{lower}, {upper}]")]
    OutOfBounds {
        /// Entry index.
        index: usize,
        /// Coordinate name.
        name: String,
        /// The value.
        value: f64,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// The space itself is ill-formed (mismatched lengths, lower > upper, NaN bounds).
    #[error("invalid design space: {0}")]
    Space(String),
}

impl ZetaSpace {
    /// A space with the given names and bounds; the origin of each coordinate is the middle of
    /// its bounds and its scale half their width (0 and 1 where a bound is infinite).
    pub fn new(names: Vec<String>, lower: Vec<f64>, upper: Vec<f64>) -> Result<Self, ZetaError> {
        let origin = lower
            .iter()
            .zip(&upper)
            .map(|(&l, &u)| if l.is_finite() && u.is_finite() { 0.5 * (l + u) } else { 0.0 })
            .collect();
        let scale = lower
            .iter()
            .zip(&upper)
            .map(|(&l, &u)| if l.is_finite() && u.is_finite() && u > l { 0.5 * (u - l) } else { 1.0 })
            .collect();
        Self::with_scales(names, lower, upper, origin, scale)
    }

    /// An unbounded space with the given names.
    pub fn unbounded(names: Vec<String>) -> Self {
        let d = names.len();
        Self::new(names, vec![f64::NEG_INFINITY; d], vec![f64::INFINITY; d]).expect("unbounded space is valid")
    }

    /// A space with explicit origins and scales (positive, finite) per coordinate.
    pub fn with_scales(
        names: Vec<String>,
        lower: Vec<f64>,
        upper: Vec<f64>,
        origin: Vec<f64>,
        scale: Vec<f64>,
    ) -> Result<Self, ZetaError> {
        let d = names.len();
        if [lower.len(), upper.len(), origin.len(), scale.len()].iter().any(|&n| n != d) {
            return Err(ZetaError::Space(format!("{d} names but bounds/origin/scale of other lengths")));
        }
        for i in 0..d {
            if lower[i].is_nan() || upper[i].is_nan() || lower[i] > upper[i] || lower[i] == f64::INFINITY {
                return Err(ZetaError::Space(format!(
                    "coordinate {} has bounds [{}, {}]",
                    names[i], lower[i], upper[i]
                )));
            }
            if !(scale[i].is_finite() && scale[i] > 0.0 && origin[i].is_finite()) {
                return Err(ZetaError::Space(format!(
                    "coordinate {} has origin {} and scale {}",
                    names[i], origin[i], scale[i]
                )));
            }
        }
        Ok(Self { names, lower, upper, origin, scale })
    }

    /// Names `{prefix}{j}.x`, `{prefix}{j}.y` for `points` 2-D points: the layout of every
    /// geometric design in envpg (`[x₀, y₀, x₁, y₁, …]`).
    pub fn point_names(prefix: &str, points: usize) -> Vec<String> {
        (0..points).flat_map(|j| [format!("{prefix}{j}.x"), format!("{prefix}{j}.y")]).collect()
    }

    /// Dimension of ζ.
    pub fn dim(&self) -> usize {
        self.names.len()
    }
    /// Coordinate names.
    pub fn names(&self) -> &[String] {
        &self.names
    }
    /// Lower bounds.
    pub fn lower(&self) -> &[f64] {
        &self.lower
    }
    /// Upper bounds.
    pub fn upper(&self) -> &[f64] {
        &self.upper
    }
    /// The typical centre of each coordinate.
    pub fn origin(&self) -> &[f64] {
        &self.origin
    }
    /// The typical length of each coordinate.
    pub fn scale(&self) -> &[f64] {
        &self.scale
    }
    /// Whether any coordinate has a finite bound.
    pub fn is_bounded(&self) -> bool {
        self.lower.iter().chain(&self.upper).any(|b| b.is_finite())
    }

    /// Checks a design: right length, finite, inside the bounds.
    pub fn check(&self, zeta: &[f64]) -> Result<(), ZetaError> {
        if zeta.len() != self.dim() {
            return Err(ZetaError::Length { expected: self.dim(), got: zeta.len(), names: self.describe_names() });
        }
        for (i, &z) in zeta.iter().enumerate() {
            let name = self.names[i].clone();
            if !z.is_finite() {
                return Err(ZetaError::NotFinite { index: i, name, value: z });
            }
            if z < self.lower[i] || z > self.upper[i] {
                return Err(ZetaError::OutOfBounds {
                    index: i,
                    name,
                    value: z,
                    lower: self.lower[i],
                    upper: self.upper[i],
                });
            }
        }
        Ok(())
    }

    fn describe_names(&self) -> String {
        if self.names.len() <= 8 {
            self.names.join(", ")
        } else {
            format!("{}, …, {}", self.names[..4].join(", "), self.names[self.names.len() - 1])
        }
    }

    /// Moves `zeta` into the box (coordinate-wise clamp); unbounded coordinates are untouched.
    pub fn project(&self, zeta: &mut [f64]) {
        for ((z, &l), &u) in zeta.iter_mut().zip(&self.lower).zip(&self.upper) {
            if *z < l {
                *z = l;
            } else if *z > u {
                *z = u;
            }
        }
    }

    /// `zeta` moved by Gaussian noise of standard deviation `relative · scale[i]` on each
    /// coordinate, one draw per coordinate in order, and projected into the box: a start near a
    /// design that may descend into another basin.
    pub fn kick(&self, zeta: &[f64], relative: f64, rng: &mut StreamRng) -> Vec<f64> {
        let mut z: Vec<f64> = zeta
            .iter()
            .zip(&self.scale)
            .map(|(&z, &s)| z + relative * s * rng.sample::<f64, _>(rand_distr::StandardNormal))
            .collect();
        self.project(&mut z);
        z
    }

    /// A design drawn uniformly over the bounds, one coordinate after another; an unbounded
    /// coordinate is drawn over `origin ± scale`.
    pub fn sample(&self, rng: &mut StreamRng) -> Vec<f64> {
        (0..self.dim())
            .map(|i| {
                let (l, u) = if self.lower[i].is_finite() && self.upper[i].is_finite() {
                    (self.lower[i], self.upper[i])
                } else {
                    (self.origin[i] - self.scale[i], self.origin[i] + self.scale[i])
                };
                if u > l { rng.random_range(l..=u) } else { l }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Streams};

    fn space() -> ZetaSpace {
        ZetaSpace::new(vec!["a".into(), "b".into()], vec![0.0, f64::NEG_INFINITY], vec![1.0, f64::INFINITY]).unwrap()
    }

    #[test]
    fn checks_length_finiteness_and_bounds_naming_the_coordinate() {
        let s = space();
        assert!(s.check(&[0.5, -1e9]).is_ok());
        assert!(matches!(s.check(&[0.5]), Err(ZetaError::Length { expected: 2, got: 1, .. })));
        let e = s.check(&[1.5, 0.0]).unwrap_err();
        assert!(e.to_string().contains("coordinate a") && e.to_string().contains("[0, 1]"), "{e}");
        assert!(matches!(s.check(&[0.5, f64::NAN]), Err(ZetaError::NotFinite { index: 1, .. })));
    }

    #[test]
    fn projection_clamps_bounded_coordinates_only() {
        let s = space();
        let mut z = [-0.25, 1e300];
        s.project(&mut z);
        assert_eq!(z, [0.0, 1e300]);
    }

    #[test]
    fn samples_stay_inside_and_are_reproducible() {
        let s = space();
        let mut r1 = Streams::new(1).stream(Purpose::Zeta0, 0, 0);
        let mut r2 = Streams::new(1).stream(Purpose::Zeta0, 0, 0);
        for _ in 0..100 {
            let z = s.sample(&mut r1);
            assert_eq!(z, s.sample(&mut r2));
            assert!((0.0..=1.0).contains(&z[0]) && (-1.0..=1.0).contains(&z[1]));
        }
    }

    #[test]
    fn kicks_scale_with_each_coordinate_stay_inside_and_are_reproducible() {
        let s = ZetaSpace::with_scales(
            vec!["a".into(), "b".into()],
            vec![0.0, f64::NEG_INFINITY],
            vec![1.0, f64::INFINITY],
            vec![0.5, 0.0],
            vec![0.5, 4.0],
        )
        .unwrap();
        let (mut r1, mut r2) =
            (Streams::new(3).stream(Purpose::Other, 0, 0), Streams::new(3).stream(Purpose::Other, 0, 0));
        let n = 4000;
        let (mut sum, mut sq) = (0.0, 0.0);
        for _ in 0..n {
            let z = s.kick(&[0.999, 10.0], 0.25, &mut r1);
            assert_eq!(z, s.kick(&[0.999, 10.0], 0.25, &mut r2));
            assert!((0.0..=1.0).contains(&z[0]), "{z:?}");
            sum += z[1] - 10.0;
            sq += (z[1] - 10.0).powi(2);
        }
        // Coordinate b: N(0, (0.25 · 4)²); mean within 4 standard errors, sd within 5%.
        let (mean, sd) = (sum / n as f64, (sq / n as f64 - (sum / n as f64).powi(2)).sqrt());
        assert!(mean.abs() < 4.0 / (n as f64).sqrt(), "mean {mean}");
        assert!((sd - 1.0).abs() < 0.05, "sd {sd}");
        assert_eq!(s.kick(&[0.5, 1.0], 0.0, &mut r1), vec![0.5, 1.0], "no noise, no move");
    }

    #[test]
    fn rejects_inverted_or_nan_bounds() {
        assert!(ZetaSpace::new(vec!["a".into()], vec![1.0], vec![0.0]).is_err());
        assert!(ZetaSpace::new(vec!["a".into()], vec![f64::NAN], vec![0.0]).is_err());
        assert!(ZetaSpace::new(vec!["a".into()], vec![0.0], vec![1.0, 2.0]).is_err());
    }
}
