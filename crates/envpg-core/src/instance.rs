//! Instance files: one JSON object naming its environment, its parameters and the fields that
//! environment defines.
//!
//! ```json
//! {"env": "flpo", "name": "flpo-n10m4", "params": {"kappa": 1.0, "eta": 100.0}, "agents": [...], ...}
//! ```
//!
//! - `env` names a registered environment; a file without it is a UAV instance (`"uav"`), as
//!   every file was before environments were pluggable.
//! - `params` holds the environment's numeric parameters; missing ones take the environment's
//!   defaults and `--env-param KEY=VALUE` overrides them. A key the environment does not have
//!   is an error.
//! - Every other field belongs to the environment, which reads it with [`InstanceFile::field`]
//!   and refuses fields it does not know ([`InstanceFile::expect_fields`]).
//!
//! Parsing is strict everywhere: duplicate keys at any depth, non-finite numbers and malformed
//! values are errors naming the file and the field. [`InstanceFile::canonical`] is the form a
//! result file stores: every field, the environment's name and *every* parameter actually
//! used, so the result can be recomputed from the file alone.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::de::{DeserializeOwned, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};
use serde_json::{Map, Value};

/// The environment of an instance file without an `env` field.
pub const DEFAULT_ENV: &str = "uav";

/// One numeric parameter of an environment.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// Its key in `params` and in `--env-param KEY=VALUE`.
    pub name: &'static str,
    /// The value when the instance does not set it.
    pub default: f64,
    /// One line about it, for `--help`-style listings.
    pub about: &'static str,
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
    /// The file is not a well-formed JSON object (syntax, duplicate keys, non-finite numbers).
    #[error("malformed instance file {path}: {reason}")]
    Parse {
        /// The file (or `<inline>`).
        path: PathBuf,
        /// What is wrong, with line and column where known.
        reason: String,
    },
    /// The object parsed but a field has an invalid value.
    #[error("invalid instance {path}: field `{field}`: {reason}")]
    Invalid {
        /// The file (or `<inline>`).
        path: PathBuf,
        /// The offending field, e.g. `users[3]` or `params.kappa`.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// The file names an environment that is not registered.
    #[error("instance {path} is for environment {env:?}, which is not registered (known: {known})")]
    UnknownEnv {
        /// The file.
        path: PathBuf,
        /// The name in the file.
        env: String,
        /// Registered names.
        known: String,
    },
    /// A parameter (in the file's `params` or given with `--env-param`) the environment does
    /// not have.
    #[error("{origin}: environment `{env}` has no parameter {key:?} (its parameters: {known})")]
    UnknownParam {
        /// Where the key came from (the file, or `--env-param`).
        origin: String,
        /// The environment.
        env: String,
        /// The key.
        key: String,
        /// The environment's parameters.
        known: String,
    },
    /// An instance of one environment where another was expected.
    #[error("{path} is an instance of environment `{found}`, but `{expected}` is expected here")]
    WrongEnv {
        /// The file.
        path: PathBuf,
        /// The environment needed.
        expected: String,
        /// The environment of the file.
        found: String,
    },
}

/// An instance file as read and checked by the registry: its environment, name, resolved
/// parameters and the remaining fields, which the environment interprets.
#[derive(Debug, Clone, PartialEq)]
pub struct InstanceFile {
    origin: PathBuf,
    env: String,
    name: String,
    params: BTreeMap<String, f64>,
    fields: Map<String, Value>,
}

impl InstanceFile {
    /// Parses `text` (from `origin`, named in errors) without resolving parameters: `env`,
    /// `name` and the raw `params` are split off, everything else stays a field.
    pub fn parse(text: &str, origin: impl AsRef<Path>) -> Result<Self, InstanceError> {
        let origin = origin.as_ref().to_owned();
        let value = strict_value(text).map_err(|reason| InstanceError::Parse { path: origin.clone(), reason })?;
        Self::from_value(value, origin)
    }

    /// As [`InstanceFile::parse`], from a JSON value (e.g. the instance stored in a result file).
    pub fn from_value(value: Value, origin: impl AsRef<Path>) -> Result<Self, InstanceError> {
        let origin = origin.as_ref().to_owned();
        let invalid =
            |field: &str, reason: String| InstanceError::Invalid { path: origin.clone(), field: field.into(), reason };
        let Value::Object(mut fields) = value else {
            return Err(InstanceError::Parse { path: origin, reason: "expected a JSON object".into() });
        };
        let env = match fields.remove("env") {
            None => DEFAULT_ENV.to_owned(),
            Some(Value::String(s)) if !s.trim().is_empty() => s,
            Some(v) => return Err(invalid("env", format!("must be a non-empty string, got {v}"))),
        };
        let name = match fields.remove("name") {
            Some(Value::String(s)) if !s.trim().is_empty() => s,
            Some(v) => return Err(invalid("name", format!("must be a non-empty string, got {v}"))),
            None => return Err(invalid("name", "is missing".into())),
        };
        let mut params = BTreeMap::new();
        match fields.remove("params") {
            None => {}
            Some(Value::Object(p)) => {
                for (k, v) in p {
                    let x = v
                        .as_f64()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| invalid(&format!("params.{k}"), format!("must be a finite number, got {v}")))?;
                    params.insert(k, x);
                }
            }
            Some(v) => return Err(invalid("params", format!("must be an object of numbers, got {v}"))),
        }
        Ok(Self { origin, env, name, params, fields })
    }

    /// Fills in the defaults of `specs`, applies `overrides` (from `--env-param`) and refuses
    /// keys `specs` does not name.
    pub fn resolve_params(&mut self, specs: &[ParamSpec], overrides: &[(String, f64)]) -> Result<(), InstanceError> {
        let known = || specs.iter().map(|p| p.name).collect::<Vec<_>>().join(", ");
        let unknown = |origin: String, key: &str| InstanceError::UnknownParam {
            origin,
            env: self.env.clone(),
            key: key.to_owned(),
            known: if specs.is_empty() { "none".into() } else { known() },
        };
        if let Some(k) = self.params.keys().find(|k| !specs.iter().any(|p| p.name == k.as_str())) {
            return Err(unknown(format!("instance {}", self.origin.display()), k));
        }
        for (k, v) in overrides {
            if !specs.iter().any(|p| p.name == k.as_str()) {
                return Err(unknown("--env-param".into(), k));
            }
            if !v.is_finite() {
                return Err(InstanceError::Invalid {
                    path: "--env-param".into(),
                    field: k.clone(),
                    reason: format!("must be a finite number, got {v}"),
                });
            }
            self.params.insert(k.clone(), *v);
        }
        for p in specs {
            self.params.entry(p.name.to_owned()).or_insert(p.default);
        }
        Ok(())
    }

    /// Where the instance came from (a path, or `<bundled NAME>`).
    pub fn origin(&self) -> &Path {
        &self.origin
    }
    /// The environment's name.
    pub fn env(&self) -> &str {
        &self.env
    }
    /// The instance's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Every parameter (after [`InstanceFile::resolve_params`]: every one the environment has).
    pub fn params(&self) -> &BTreeMap<String, f64> {
        &self.params
    }
    /// A resolved parameter; an error naming it if it is missing (an environment asking for a
    /// parameter it did not declare).
    pub fn param(&self, key: &str) -> Result<f64, InstanceError> {
        self.params.get(key).copied().ok_or_else(|| self.invalid(&format!("params.{key}"), "is missing".into()))
    }
    /// The fields other than `env`, `name` and `params`.
    pub fn fields(&self) -> &Map<String, Value> {
        &self.fields
    }

    /// An [`InstanceError::Invalid`] naming this file and `field`.
    pub fn invalid(&self, field: &str, reason: String) -> InstanceError {
        InstanceError::Invalid { path: self.origin.clone(), field: field.to_owned(), reason }
    }

    /// A required field, deserialized.
    pub fn field<T: DeserializeOwned>(&self, key: &str) -> Result<T, InstanceError> {
        match self.fields.get(key) {
            Some(v) => T::deserialize(v).map_err(|e| self.invalid(key, e.to_string())),
            None => Err(self.invalid(key, "is missing".into())),
        }
    }

    /// An optional field, deserialized.
    pub fn optional_field<T: DeserializeOwned>(&self, key: &str) -> Result<Option<T>, InstanceError> {
        self.fields.get(key).map(|v| T::deserialize(v).map_err(|e| self.invalid(key, e.to_string()))).transpose()
    }

    /// Refuses any field not in `known` (besides `env`, `name` and `params`).
    pub fn expect_fields(&self, known: &[&str]) -> Result<(), InstanceError> {
        match self.fields.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => Err(self.invalid(
                k,
                format!("unknown field for environment `{}` (its fields: {})", self.env, known.join(", ")),
            )),
            None => Ok(()),
        }
    }

    /// The canonical JSON of the instance: its fields, `env`, `name` and every parameter.
    pub fn canonical(&self) -> Value {
        let mut out = self.fields.clone();
        out.insert("env".into(), Value::String(self.env.clone()));
        out.insert("name".into(), Value::String(self.name.clone()));
        let params: Map<String, Value> = self.params.iter().map(|(k, v)| (k.clone(), Value::from(*v))).collect();
        out.insert("params".into(), Value::Object(params));
        Value::Object(out)
    }
}

/// The parameter overrides of a command line: every `--env-param KEY=VALUE`, then the
/// `--kappa`/`--eta` shorthands. An error names the malformed argument.
pub fn param_overrides(params: &[String], kappa: Option<f64>, eta: Option<f64>) -> Result<Vec<(String, f64)>, String> {
    let mut out = Vec::new();
    for p in params {
        let Some((k, v)) = p.split_once('=') else {
            return Err(format!("--env-param {p:?}: expected KEY=VALUE"));
        };
        let Ok(x) = v.trim().parse::<f64>() else {
            return Err(format!("--env-param {p:?}: {:?} is not a number", v.trim()));
        };
        out.push((k.trim().to_owned(), x));
    }
    out.extend(kappa.map(|k| ("kappa".to_owned(), k)));
    out.extend(eta.map(|e| ("eta".to_owned(), e)));
    Ok(out)
}

/// Reads 2-D points from a field: a list of `[x, y]` pairs of finite numbers, each named in
/// errors (`users[3]`).
pub fn points(file: &InstanceFile, key: &str) -> Result<Vec<[f64; 2]>, InstanceError> {
    let raw: Vec<Vec<f64>> = file.field(key)?;
    raw.iter()
        .enumerate()
        .map(|(i, p)| match p.as_slice() {
            [x, y] if x.is_finite() && y.is_finite() => Ok([*x, *y]),
            [_, _] => Err(file.invalid(&format!("{key}[{i}]"), format!("coordinates must be finite, got {p:?}"))),
            _ => Err(file.invalid(&format!("{key}[{i}]"), format!("must be a pair [x, y], got {p:?}"))),
        })
        .collect()
}

/// Parses JSON text, refusing duplicate keys at any depth and numbers out of f64 range.
fn strict_value(text: &str) -> Result<Value, String> {
    let mut de = serde_json::Deserializer::from_str(text);
    let v = Strict::deserialize(&mut de).map_err(|e| e.to_string())?;
    de.end().map_err(|e| e.to_string())?;
    Ok(v.0)
}

/// A JSON value whose objects may not repeat a key.
struct Strict(Value);

impl<'de> Deserialize<'de> for Strict {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(StrictVisitor).map(Strict)
    }
}

struct StrictVisitor;

impl<'de> Visitor<'de> for StrictVisitor {
    type Value = Value;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Value, E> {
        serde_json::Number::from_f64(v).map(Value::Number).ok_or_else(|| E::custom(format!("number {v} is not finite")))
    }
    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_owned()))
    }
    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }
    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut out = Vec::new();
        while let Some(Strict(v)) = seq.next_element()? {
            out.push(v);
        }
        Ok(Value::Array(out))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut out = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            if out.contains_key(&key) {
                return Err(serde::de::Error::custom(format!("duplicate field `{key}`")));
            }
            let Strict(v) = map.next_value()?;
            out.insert(key, v);
        }
        Ok(Value::Object(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<InstanceFile, InstanceError> {
        InstanceFile::parse(text, "t.json")
    }

    const SPECS: [ParamSpec; 2] =
        [ParamSpec { name: "kappa", default: 1.0, about: "" }, ParamSpec { name: "eta", default: 100.0, about: "" }];

    #[test]
    fn a_file_without_env_is_a_uav_instance_and_params_take_defaults() {
        let mut f = parse(r#"{"name":"a","n_uav":2}"#).unwrap();
        assert_eq!(f.env(), "uav");
        f.resolve_params(&SPECS, &[("eta".into(), 50.0)]).unwrap();
        assert_eq!((f.param("kappa").unwrap(), f.param("eta").unwrap()), (1.0, 50.0));
        let c = f.canonical();
        assert_eq!(c["env"], "uav");
        assert_eq!(c["params"]["eta"], 50.0);
        assert_eq!(c["n_uav"], 2);
        let again = InstanceFile::from_value(c.clone(), "r.json").unwrap();
        assert_eq!(again.canonical(), c, "the canonical form is a fixed point");
    }

    #[test]
    fn duplicate_keys_at_any_depth_are_refused_naming_the_file() {
        let e = parse(r#"{"name":"a","n_uav":2,"n_uav":3}"#).unwrap_err().to_string();
        assert!(e.contains("t.json") && e.contains("duplicate field `n_uav`"), "{e}");
        let e = parse(r#"{"name":"a","params":{"kappa":1,"kappa":2}}"#).unwrap_err().to_string();
        assert!(e.contains("duplicate field `kappa`"), "{e}");
    }

    #[test]
    fn unknown_params_are_named_with_the_known_ones() {
        let mut f = parse(r#"{"name":"a","params":{"kapa":1}}"#).unwrap();
        let e = f.resolve_params(&SPECS, &[]).unwrap_err().to_string();
        assert!(e.contains("\"kapa\"") && e.contains("kappa, eta") && e.contains("t.json"), "{e}");
        let mut f = parse(r#"{"name":"a"}"#).unwrap();
        let e = f.resolve_params(&SPECS, &[("x".into(), 1.0)]).unwrap_err().to_string();
        assert!(e.contains("--env-param") && e.contains("\"x\""), "{e}");
    }

    #[test]
    fn malformed_params_and_names_are_named() {
        for (text, field) in [
            (r#"{"name":"a","params":{"kappa":"high"}}"#, "params.kappa"),
            (r#"{"name":"a","params":[1]}"#, "params"),
            (r#"{"name":""}"#, "name"),
            (r#"{"n_uav":2}"#, "name"),
            (r#"{"name":"a","env":3}"#, "env"),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(&format!("`{field}`")), "{text}: {e}");
        }
        assert!(matches!(parse("[1]"), Err(InstanceError::Parse { .. })));
        assert!(matches!(parse(r#"{"name":"a","x":1e400}"#), Err(InstanceError::Parse { .. })));
    }

    #[test]
    fn points_and_fields_are_checked_by_name() {
        let f = parse(r#"{"name":"a","users":[[0,1],[2,3,4]],"extra":1}"#).unwrap();
        let e = points(&f, "users").unwrap_err().to_string();
        assert!(e.contains("`users[1]`"), "{e}");
        let e = f.expect_fields(&["users"]).unwrap_err().to_string();
        assert!(e.contains("`extra`") && e.contains("unknown field"), "{e}");
        assert!(f.field::<usize>("n_uav").unwrap_err().to_string().contains("`n_uav`: is missing"));
    }
}
