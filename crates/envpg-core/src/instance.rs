//! Instance files: `{"name", "n_uav", "users": [[x, y], …], "dest": [x, y]}`.
//!
//! Loading is strict: unknown or duplicate keys, non-finite numbers, an empty user list or fewer
//! than two UAVs are rejected with an error naming the file and the field.

use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution, Normal, Uniform};
use serde::{Deserialize, Serialize};

/// The bundled default instance (the paper's network, `launch/instances/uav271.json`),
/// compiled in so binaries work from any directory.
pub const BUNDLED_JSON: &str = include_str!("../../../launch/instances/uav271.json");

/// The name by which the bundled instance is selected on command lines.
pub const BUNDLED_NAME: &str = "uav271";

/// Largest number of UAVs an instance may have (ζ travels in fixed-size protocol headers).
pub const MAX_UAVS: usize = 32;

/// A UAV relay-network instance: fixed users, the number of UAVs and the destination.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Instance {
    /// Human-readable name.
    pub name: String,
    /// Number of UAVs M (ζ has 2M entries).
    pub n_uav: usize,
    /// User positions.
    pub users: Vec<[f64; 2]>,
    /// Destination position.
    pub dest: [f64; 2],
}

/// Why an instance could not be loaded or is invalid.
#[derive(Debug, thiserror::Error)]
pub enum InstanceError {
    /// The file could not be read.
    #[error("cannot read instance file {path}: {err}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error (kept out of the error chain: it is already in the message).
        err: std::io::Error,
    },
    /// The file is not a well-formed instance object (syntax, types, unknown or duplicate keys).
    #[error("malformed instance file {path}: {err}")]
    Parse {
        /// The file (or `<inline>`).
        path: PathBuf,
        /// The JSON error, with line and column.
        err: serde_json::Error,
    },
    /// The object parsed but a field has an invalid value.
    #[error("invalid instance {path}: field `{field}`: {reason}")]
    Invalid {
        /// The file (or `<inline>`).
        path: PathBuf,
        /// The offending field, e.g. `users[3]`.
        field: String,
        /// What is wrong.
        reason: String,
    },
}

impl Instance {
    /// The bundled default instance.
    pub fn bundled() -> Self {
        Self::from_json_str(BUNDLED_JSON, "<bundled uav271>").expect("bundled instance is valid")
    }

    /// Loads `spec`: the bundled instance's name (`uav271`) or a path to an instance file.
    pub fn resolve(spec: &str) -> Result<Self, InstanceError> {
        if spec == BUNDLED_NAME && !Path::new(spec).exists() { Ok(Self::bundled()) } else { Self::load(spec) }
    }

    /// Reads and validates an instance file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, InstanceError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|err| InstanceError::Io { path: path.to_owned(), err })?;
        Self::from_json_str(&text, path)
    }

    /// Parses and validates an instance from JSON text; `origin` names it in errors.
    pub fn from_json_str(text: &str, origin: impl AsRef<Path>) -> Result<Self, InstanceError> {
        let origin = origin.as_ref();
        let inst: Instance =
            serde_json::from_str(text).map_err(|err| InstanceError::Parse { path: origin.to_owned(), err })?;
        inst.validate_as(origin)?;
        Ok(inst)
    }

    /// Validates an instance that came from elsewhere (e.g. embedded in a result file).
    pub fn from_value(value: serde_json::Value, origin: impl AsRef<Path>) -> Result<Self, InstanceError> {
        let origin = origin.as_ref();
        let inst: Instance =
            serde_json::from_value(value).map_err(|err| InstanceError::Parse { path: origin.to_owned(), err })?;
        inst.validate_as(origin)?;
        Ok(inst)
    }

    /// Checks the invariants; `origin` names the instance in errors.
    pub fn validate_as(&self, origin: &Path) -> Result<(), InstanceError> {
        let invalid = |field: String, reason: String| InstanceError::Invalid { path: origin.to_owned(), field, reason };
        if self.name.trim().is_empty() {
            return Err(invalid("name".into(), "must be a non-empty string".into()));
        }
        if self.n_uav < 2 {
            return Err(invalid("n_uav".into(), format!("must be at least 2, got {}", self.n_uav)));
        }
        if self.n_uav > MAX_UAVS {
            return Err(invalid("n_uav".into(), format!("at most {MAX_UAVS} UAVs are supported, got {}", self.n_uav)));
        }
        if self.users.is_empty() {
            return Err(invalid("users".into(), "must contain at least one user".into()));
        }
        for (i, u) in self.users.iter().enumerate() {
            if !(u[0].is_finite() && u[1].is_finite()) {
                return Err(invalid(format!("users[{i}]"), format!("coordinates must be finite, got {u:?}")));
            }
        }
        if !(self.dest[0].is_finite() && self.dest[1].is_finite()) {
            return Err(invalid("dest".into(), format!("coordinates must be finite, got {:?}", self.dest)));
        }
        Ok(())
    }

    /// Number of users N.
    pub fn n_users(&self) -> usize {
        self.users.len()
    }

    /// Dimension of ζ (2M).
    pub fn zeta_dim(&self) -> usize {
        2 * self.n_uav
    }

    /// The users' bounding box `([min_x, min_y], [max_x, max_y])`.
    pub fn user_bbox(&self) -> ([f64; 2], [f64; 2]) {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for u in &self.users {
            for k in 0..2 {
                lo[k] = lo[k].min(u[k]);
                hi[k] = hi[k].max(u[k]);
            }
        }
        (lo, hi)
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

    /// Serializes to pretty JSON.
    pub fn to_json_pretty(&self) -> String {
        serde_json::to_string_pretty(self).expect("instance serializes")
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
pub fn generate(spec: &GenerateSpec) -> Result<Instance, InstanceError> {
    let origin = Path::new("<generated>");
    let invalid = |field: &str, reason: String| InstanceError::Invalid {
        path: origin.to_owned(),
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
        Instance { name: spec.name.clone(), n_uav: spec.n_uav, users, dest: [0.95 * spec.side, 0.05 * spec.side] };
    inst.validate_as(origin)?;
    Ok(inst)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Instance, InstanceError> {
        Instance::from_json_str(text, "t.json")
    }

    #[test]
    fn accepts_a_well_formed_instance() {
        let i = parse(r#"{"name":"a","n_uav":2,"users":[[0,0],[1,2]],"dest":[3,4]}"#).unwrap();
        assert_eq!(i.n_users(), 2);
        assert_eq!(i.zeta_dim(), 4);
    }

    #[test]
    fn rejects_duplicate_keys_naming_file_and_field() {
        let e = parse(r#"{"name":"a","n_uav":2,"n_uav":3,"users":[[0,0]],"dest":[3,4]}"#).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("t.json") && msg.contains("duplicate field `n_uav`"), "{msg}");
    }

    #[test]
    fn rejects_unknown_keys() {
        let e = parse(r#"{"name":"a","n_uav":2,"users":[[0,0]],"dest":[3,4],"x":1}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field `x`"), "{e}");
    }

    #[test]
    fn rejects_empty_users_and_too_few_uavs() {
        let e = parse(r#"{"name":"a","n_uav":2,"users":[],"dest":[3,4]}"#).unwrap_err();
        assert!(e.to_string().contains("field `users`"), "{e}");
        let e = parse(r#"{"name":"a","n_uav":1,"users":[[0,0]],"dest":[3,4]}"#).unwrap_err();
        assert!(e.to_string().contains("field `n_uav`"), "{e}");
    }

    #[test]
    fn rejects_non_finite_and_malformed_points() {
        let e = parse(r#"{"name":"a","n_uav":2,"users":[[0,1e400]],"dest":[3,4]}"#).unwrap_err();
        assert!(e.to_string().contains("t.json"), "{e}");
        let e = parse(r#"{"name":"a","n_uav":2,"users":[[0,0,1]],"dest":[3,4]}"#).unwrap_err();
        assert!(e.to_string().contains("malformed"), "{e}");
        let inst = Instance { name: "a".into(), n_uav: 2, users: vec![[f64::NAN, 0.0]], dest: [0.0, 0.0] };
        let e = inst.validate_as(Path::new("x")).unwrap_err();
        assert!(e.to_string().contains("users[0]"), "{e}");
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
        assert_eq!(a.n_users(), 50);
    }

    #[test]
    fn bundled_instance_loads() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../launch/instances/uav271.json");
        let i = Instance::load(path).unwrap();
        assert_eq!((i.n_users(), i.n_uav), (271, 5));
        assert_eq!(Instance::bundled(), i);
        assert_eq!(Instance::resolve("uav271").unwrap(), i);
    }
}
