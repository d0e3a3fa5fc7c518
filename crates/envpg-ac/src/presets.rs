//! Presets: named `[tables]` of Algorithm 1 settings in TOML files.
//!
//! [`Presets`] searches, in order, a user's file (`--presets FILE`), the preset files a program
//! bundled with its registry ([`envpg_core::Registry::presets`]) and envpg's own
//! `launch/presets.toml` ([`BUNDLED_PRESETS`]); the first table of the name wins. A table may
//! start from another with `base = "name"` and change only what differs (a base of its own
//! name is looked up in the files after it, so a user's `[aac]` can extend the bundled one).
//! Keys that no table of the chain sets keep [`AcConfig::default`].

use std::path::{Path, PathBuf};

use envpg_core::Registry;

use crate::config::{AcConfig, ConfigError};

/// envpg's preset file (`launch/presets.toml`), compiled in so every binary works from any
/// directory.
pub const BUNDLED_PRESETS: &str = include_str!("../../../launch/presets.toml");

/// The preset of an environment that has none of its own: the `uav` settings, scale-free.
pub const DEFAULT_PRESET: &str = "default";

/// How long a chain of `base` presets may be (longer means a cycle).
const MAX_BASE_DEPTH: usize = 16;

/// A preset could not be used.
#[derive(Debug, thiserror::Error)]
pub enum PresetError {
    /// Unreadable file.
    #[error("cannot read preset file {path}: {err}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        err: std::io::Error,
    },
    /// Not valid TOML, or unknown keys.
    #[error("malformed preset file {path}: {err}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The TOML error.
        err: toml::de::Error,
    },
    /// No file has a preset of that name.
    #[error("no preset named {name:?} in {searched} (presets: {available})")]
    Missing {
        /// The requested name.
        name: String,
        /// The files searched, in order.
        searched: String,
        /// Names present in any of them.
        available: String,
    },
    /// A preset's `base` is not a string, or the chain of bases is a cycle.
    #[error("preset {name:?} in {path}: {reason}")]
    Base {
        /// The file.
        path: PathBuf,
        /// The preset.
        name: String,
        /// The problem.
        reason: String,
    },
    /// The preset's values are invalid.
    #[error("preset {name:?} in {path}: {err}")]
    Invalid {
        /// The file of the named preset.
        path: PathBuf,
        /// The preset.
        name: String,
        /// The problem.
        err: ConfigError,
    },
}

/// Preset files in search order (see the module docs).
#[derive(Debug, Clone)]
pub struct Presets {
    files: Vec<(PathBuf, toml::Table)>,
}

impl Presets {
    /// envpg's bundled presets alone.
    pub fn bundled() -> Self {
        Self::from_texts(&[]).expect("the bundled presets.toml parses (tested)")
    }

    /// The registry's preset files, then envpg's.
    pub fn of(registry: &Registry) -> Result<Self, PresetError> {
        Self::from_texts(registry.preset_files())
    }

    fn from_texts(texts: &[&str]) -> Result<Self, PresetError> {
        let mut files = Vec::with_capacity(texts.len() + 1);
        for (i, text) in texts.iter().enumerate() {
            files.push(parse(text, PathBuf::from(format!("<the program's preset file {}>", i + 1)))?);
        }
        files.push(parse(BUNDLED_PRESETS, PathBuf::from("<bundled presets.toml>"))?);
        Ok(Self { files })
    }

    /// The same search with the file at `path` first (`--presets FILE`).
    pub fn with_file(self, path: &Path) -> Result<Self, PresetError> {
        let text = std::fs::read_to_string(path).map_err(|err| PresetError::Io { path: path.to_owned(), err })?;
        self.with_text(&text, path)
    }

    /// The same search with `text` (read from `path`) first.
    pub fn with_text(mut self, text: &str, path: &Path) -> Result<Self, PresetError> {
        self.files.insert(0, parse(text, path.to_owned())?);
        Ok(self)
    }

    /// Whether some file has a preset `name`.
    pub fn has(&self, name: &str) -> bool {
        self.files.iter().any(|(_, t)| t.contains_key(name))
    }

    /// The validated settings of preset `name`.
    pub fn get(&self, name: &str) -> Result<AcConfig, PresetError> {
        let (table, i) = self.resolve(name, 0, 0)?;
        let path = &self.files[i].0;
        let cfg: AcConfig =
            toml::Value::Table(table).try_into().map_err(|err| PresetError::Parse { path: path.clone(), err })?;
        cfg.validate().map_err(|err| PresetError::Invalid { path: path.clone(), name: name.to_owned(), err })?;
        Ok(cfg)
    }

    /// The settings for environment `env`: preset `name` when given, else the preset named like
    /// the environment, else [`DEFAULT_PRESET`].
    pub fn for_env(&self, name: Option<&str>, env: &str) -> Result<AcConfig, PresetError> {
        match name {
            Some(n) => self.get(n),
            None if self.has(env) => self.get(env),
            None => self.get(DEFAULT_PRESET),
        }
    }

    /// Table `name` from the first file at or after `from` that has it, its `base` chain merged
    /// in; with the index of that file.
    fn resolve(&self, name: &str, from: usize, depth: usize) -> Result<(toml::Table, usize), PresetError> {
        let Some(i) = (from..self.files.len()).find(|&i| self.files[i].1.contains_key(name)) else {
            return Err(self.missing(name));
        };
        let (path, file) = &self.files[i];
        let bad = |reason: String| PresetError::Base { path: path.clone(), name: name.to_owned(), reason };
        let mut table = match &file[name] {
            toml::Value::Table(t) => t.clone(),
            other => return Err(bad(format!("is a {}, not a table of settings", other.type_str()))),
        };
        let Some(base) = table.remove("base") else {
            return Ok((table, i));
        };
        let toml::Value::String(base) = base else {
            return Err(bad(format!("`base` must name a preset, got {base}")));
        };
        if depth >= MAX_BASE_DEPTH {
            return Err(bad(format!("the chain of `base` presets is a cycle (through {base:?})")));
        }
        let start = if base == name { i + 1 } else { 0 };
        let (mut merged, _) = self.resolve(&base, start, depth + 1).map_err(|e| match e {
            PresetError::Missing { .. } => bad(format!("its base {base:?} is not a preset")),
            other => other,
        })?;
        merged.extend(table);
        Ok((merged, i))
    }

    fn missing(&self, name: &str) -> PresetError {
        let mut available: Vec<&str> = self.files.iter().flat_map(|(_, t)| t.keys().map(String::as_str)).collect();
        available.sort_unstable();
        available.dedup();
        PresetError::Missing {
            name: name.to_owned(),
            searched: self.files.iter().map(|(p, _)| p.display().to_string()).collect::<Vec<_>>().join(", "),
            available: available.join(", "),
        }
    }
}

fn parse(text: &str, path: PathBuf) -> Result<(PathBuf, toml::Table), PresetError> {
    match toml::from_str(text) {
        Ok(t) => Ok((path, t)),
        Err(err) => Err(PresetError::Parse { path, err }),
    }
}

impl AcConfig {
    /// Preset `name` from `text`, read from `path` (its `base` presets may also come from
    /// envpg's).
    pub fn from_preset_str(text: &str, path: &Path, name: &str) -> Result<Self, PresetError> {
        Presets::bundled().with_text(text, path)?.get(name)
    }

    /// Preset `name` of envpg's bundled preset file.
    pub fn bundled(name: &str) -> Result<Self, PresetError> {
        Presets::bundled().get(name)
    }

    /// The settings a program with `registry` uses for environment `env`: preset `name` (or the
    /// environment's own, or [`DEFAULT_PRESET`]) from the file `file` if given, the registry's
    /// preset files and envpg's, in that order.
    pub fn for_env(
        registry: &Registry,
        file: Option<&Path>,
        name: Option<&str>,
        env: &str,
    ) -> Result<Self, PresetError> {
        let mut presets = Presets::of(registry)?;
        if let Some(f) = file {
            presets = presets.with_file(f)?;
        }
        presets.for_env(name, env)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ZetaEstimator;

    #[test]
    fn presets_override_defaults_and_reject_unknown_keys() {
        let text = "[fast]\niterations = 10\nsigma = 0.1\nzeta_estimator = \"sampled\"\n[other]\nepisodes = 3\n";
        let c = AcConfig::from_preset_str(text, Path::new("p.toml"), "fast").unwrap();
        assert_eq!((c.iterations, c.sigma, c.zeta_estimator), (10, 0.1, ZetaEstimator::Sampled));
        assert_eq!(c.episodes, AcConfig::default().episodes);
        let e = AcConfig::from_preset_str("[x]\nsigmaa = 1\n", Path::new("p.toml"), "x").unwrap_err();
        assert!(e.to_string().contains("unknown field `sigmaa`"), "{e}");
        let e = AcConfig::from_preset_str(text, Path::new("p.toml"), "nope").unwrap_err();
        assert!(e.to_string().contains("fast") && e.to_string().contains("other"), "{e}");
        let e = AcConfig::from_preset_str("[x]\nsigma = -1.0\n", Path::new("p.toml"), "x").unwrap_err();
        assert!(e.to_string().contains("sigma"), "{e}");
    }

    #[test]
    fn bundled_presets_load() {
        for name in ["uav", "uav-large", "default", "aac", "paper", "smoke"] {
            AcConfig::bundled(name).unwrap();
        }
        assert_eq!(AcConfig::bundled("uav").unwrap(), AcConfig::default());
    }

    #[test]
    fn a_preset_extends_its_base_and_a_base_of_its_own_name_is_the_next_files() {
        let text = "[wide]\nbase = \"default\"\nsigma = 0.1\n[default]\nbase = \"default\"\nepisodes = 7\n";
        let p = Presets::bundled().with_text(text, Path::new("p.toml")).unwrap();
        let bundled = AcConfig::bundled(DEFAULT_PRESET).unwrap();
        // `[default]` here extends the bundled `[default]`; `[wide]` extends that one.
        let d = p.get("default").unwrap();
        assert_eq!(d, AcConfig { episodes: 7, ..bundled.clone() });
        assert_eq!(p.get("wide").unwrap(), AcConfig { sigma: 0.1, ..d });
        // The environment's own preset wins over the default; an explicit name over both.
        let p = p.with_text("[queues]\nbase = \"wide\"\niterations = 9\n", Path::new("q.toml")).unwrap();
        assert_eq!(p.for_env(None, "queues").unwrap().iterations, 9);
        assert_eq!(p.for_env(None, "other").unwrap().episodes, 7);
        assert_eq!(p.for_env(Some("uav"), "queues").unwrap(), AcConfig::default());
    }

    #[test]
    fn bad_bases_are_named() {
        let get = |text: &str| Presets::bundled().with_text(text, Path::new("p.toml")).unwrap().get("a").unwrap_err();
        let e = get("[a]\nbase = \"b\"\n[b]\nbase = \"a\"\n").to_string();
        assert!(e.contains("cycle"), "{e}");
        let e = get("[a]\nbase = \"nope\"\n").to_string();
        assert!(e.contains("\"a\"") && e.contains("base \"nope\" is not a preset"), "{e}");
        let e = get("[a]\nbase = 3\n").to_string();
        assert!(e.contains("must name a preset"), "{e}");
        let e = get("a = 3\n").to_string();
        assert!(e.contains("not a table"), "{e}");
    }

    #[test]
    fn registered_presets_come_before_envpgs_and_a_users_file_before_both() {
        let reg = Registry::new().presets("[default]\nbase = \"default\"\nepisodes = 5\n");
        assert_eq!(AcConfig::for_env(&reg, None, None, "anything").unwrap().episodes, 5);
        let dir = std::env::temp_dir().join(format!("envpg-presets-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("p.toml");
        std::fs::write(&f, "[default]\nbase = \"default\"\nepisodes = 6\n").unwrap();
        assert_eq!(AcConfig::for_env(&reg, Some(&f), None, "anything").unwrap().episodes, 6);
        let _ = std::fs::remove_dir_all(&dir);
        let bad = Registry::new().presets("[x\n");
        assert!(matches!(AcConfig::for_env(&bad, None, None, "e"), Err(PresetError::Parse { .. })));
    }
}
