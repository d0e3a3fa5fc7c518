//! [`Registry`]: the environments a program knows, by name, with their bundled instances, and
//! [`LoadedEnv`]: one environment built from one instance.
//!
//! Adding an environment is one call: implement [`EnvSpec`] for your type and
//! `registry.register::<MyEnv>()`. Every envpg tool then takes its instances with
//! `--instance FILE` (`"env": "my-env"` in the file).

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;
use std::sync::Arc;

use serde_json::Value;

use crate::env::Env;
use crate::instance::{InstanceError, InstanceFile, ParamSpec};
use crate::mdp::{ModelMdp, ParamMdp};

/// A registrable environment: its name, its parameters and how it is built from an instance.
pub trait EnvSpec: Env + Sized + 'static {
    /// The name instance files use in `"env"`.
    const NAME: &'static str;
    /// One line about the environment.
    const ABOUT: &'static str;
    /// Its numeric parameters (the `params` of instance files), with defaults.
    fn params() -> Vec<ParamSpec>;
    /// Builds the environment from a parsed instance whose parameters are resolved (every
    /// parameter of [`EnvSpec::params`] is present). Checks every field it reads, and refuses
    /// fields it does not know, with errors naming the file and the field.
    fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError>;
}

type Build = Arc<dyn Fn(&InstanceFile) -> Result<Arc<dyn Env>, InstanceError> + Send + Sync>;

#[derive(Clone)]
struct Entry {
    name: &'static str,
    about: &'static str,
    params: Vec<ParamSpec>,
    build: Build,
}

/// The registered environments and bundled instances of a program.
#[derive(Clone, Default)]
pub struct Registry {
    entries: Vec<Entry>,
    bundled: BTreeMap<String, &'static str>,
    presets: Vec<&'static str>,
}

impl fmt::Debug for Registry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Registry")
            .field("envs", &self.entries.iter().map(|e| e.name).collect::<Vec<_>>())
            .field("bundled", &self.bundled.keys().collect::<Vec<_>>())
            .field("preset_files", &self.presets.len())
            .finish()
    }
}

/// A model-only operation on an environment without a model.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` has no model: the oracle and exact evaluation need one")]
pub struct NoModel(pub String);

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers `T` (replacing an environment of the same name).
    pub fn register<T: EnvSpec>(mut self) -> Self {
        self.entries.retain(|e| e.name != T::NAME);
        let build: Build = Arc::new(|f: &InstanceFile| Ok(Arc::new(T::from_instance(f)?) as Arc<dyn Env>));
        self.entries.push(Entry { name: T::NAME, about: T::ABOUT, params: T::params(), build });
        self
    }

    /// Makes the instance `json` available by `name` on command lines (`--instance NAME`).
    pub fn bundle(mut self, name: &str, json: &'static str) -> Self {
        self.bundled.insert(name.to_owned(), json);
        self
    }

    /// Bundles a file of Algorithm 1 presets (TOML `[name]` tables, as `launch/presets.toml`)
    /// with the program: a preset named like an environment becomes that environment's default
    /// settings. Files bundled later are searched first, and all before envpg's own presets.
    /// The text is parsed where settings are read (`envpg-ac`), so an error names the preset.
    pub fn presets(mut self, toml: &'static str) -> Self {
        self.presets.insert(0, toml);
        self
    }

    /// The bundled preset files, most recently bundled first.
    pub fn preset_files(&self) -> &[&'static str] {
        &self.presets
    }

    /// Registered environments: (name, one line about it, parameters).
    pub fn envs(&self) -> Vec<(&'static str, &'static str, &[ParamSpec])> {
        self.entries.iter().map(|e| (e.name, e.about, e.params.as_slice())).collect()
    }

    /// Names of the bundled instances.
    pub fn bundled(&self) -> Vec<&str> {
        self.bundled.keys().map(String::as_str).collect()
    }

    /// The parameters of environment `env`, if registered.
    pub fn params_of(&self, env: &str) -> Option<&[ParamSpec]> {
        self.entries.iter().find(|e| e.name == env).map(|e| e.params.as_slice())
    }

    /// Loads `spec` — a bundled instance's name, or a path — with parameter `overrides`.
    pub fn load(&self, spec: &str, overrides: &[(String, f64)]) -> Result<LoadedEnv, InstanceError> {
        let (text, origin) = self.read(spec)?;
        self.build(InstanceFile::parse(&text, &origin)?, overrides)
    }

    /// The text of `spec` and its origin for messages.
    fn read(&self, spec: &str) -> Result<(String, std::path::PathBuf), InstanceError> {
        match self.bundled.get(spec) {
            Some(text) if !Path::new(spec).exists() => Ok(((*text).to_owned(), format!("<bundled {spec}>").into())),
            _ => {
                let path = Path::new(spec);
                let text =
                    std::fs::read_to_string(path).map_err(|err| InstanceError::Io { path: path.to_owned(), err })?;
                Ok((text, path.to_owned()))
            }
        }
    }

    /// Rebuilds an environment from an instance stored in a result file or a run description
    /// (`origin` names it in errors).
    pub fn from_value(&self, instance: &Value, origin: impl AsRef<Path>) -> Result<LoadedEnv, InstanceError> {
        self.build(InstanceFile::from_value(instance.clone(), origin)?, &[])
    }

    /// Builds the environment of a parsed instance.
    pub fn build(&self, mut file: InstanceFile, overrides: &[(String, f64)]) -> Result<LoadedEnv, InstanceError> {
        let Some(entry) = self.entries.iter().find(|e| e.name == file.env()) else {
            return Err(InstanceError::UnknownEnv {
                path: file.origin().to_owned(),
                env: file.env().to_owned(),
                known: self.entries.iter().map(|e| e.name).collect::<Vec<_>>().join(", "),
            });
        };
        file.resolve_params(&entry.params, overrides)?;
        let env = (entry.build)(&file)?;
        Ok(LoadedEnv { env, name: entry.name, title: file.name().to_owned(), instance: file.canonical() })
    }
}

/// One environment built from one instance: the environment itself, and the canonical form of
/// the instance (every field and every parameter in use) that result files store.
#[derive(Clone)]
pub struct LoadedEnv {
    /// The environment.
    pub env: Arc<dyn Env>,
    /// The environment's registered name.
    pub name: &'static str,
    /// The instance's name.
    pub title: String,
    /// The canonical instance.
    pub instance: Value,
}

impl fmt::Debug for LoadedEnv {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LoadedEnv").field("env", &self.name).field("instance", &self.title).finish()
    }
}

impl LoadedEnv {
    /// The sampler: all model-free code may touch.
    pub fn sampler(&self) -> &dyn ParamMdp {
        &*self.env
    }

    /// The sampler, shared.
    pub fn shared_sampler(&self) -> Arc<dyn ParamMdp> {
        self.env.clone()
    }

    /// The model, or the error every model-only command reports.
    pub fn model(&self) -> Result<&dyn ModelMdp, NoModel> {
        self.env.model().ok_or_else(|| NoModel(self.name.to_owned()))
    }

    /// A parameter of the instance.
    pub fn param(&self, key: &str) -> Option<f64> {
        self.instance.get("params").and_then(|p| p.get(key)).and_then(Value::as_f64)
    }

    /// Every parameter of the instance.
    pub fn params(&self) -> BTreeMap<String, f64> {
        self.instance
            .get("params")
            .and_then(Value::as_object)
            .map(|p| p.iter().filter_map(|(k, v)| Some((k.clone(), v.as_f64()?))).collect())
            .unwrap_or_default()
    }

    /// The parameters as `k = v` text, for titles and tables.
    pub fn params_text(&self) -> String {
        self.params().iter().map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>().join(", ")
    }

    /// Refuses anything but environment `expected`.
    pub fn expect_env(&self, expected: &str, origin: impl AsRef<Path>) -> Result<(), InstanceError> {
        if self.name == expected {
            Ok(())
        } else {
            Err(InstanceError::WrongEnv {
                path: origin.as_ref().to_owned(),
                expected: expected.to_owned(),
                found: self.name.to_owned(),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::Env;
    use crate::mdp::EnvRng;
    use crate::zeta::ZetaSpace;

    /// One state, one action, no model; `params.c` is its cost.
    struct Toy(ZetaSpace, f64);

    impl ParamMdp for Toy {
        fn n_states(&self) -> usize {
            2
        }
        fn n_actions(&self) -> usize {
            1
        }
        fn zeta_space(&self) -> &ZetaSpace {
            &self.0
        }
        fn valid_actions(&self, s: usize) -> &[usize] {
            if s == 0 { &[0] } else { &[] }
        }
        fn is_terminal(&self, s: usize) -> bool {
            s == 1
        }
        fn sample_initial(&self, _: &mut EnvRng) -> usize {
            0
        }
        fn step(&self, _: usize, _: usize, z: &[f64], _: &mut EnvRng) -> (usize, f64) {
            (1, self.1 + z[0] * z[0])
        }
    }
    impl Env for Toy {}
    impl EnvSpec for Toy {
        const NAME: &'static str = "toy";
        const ABOUT: &'static str = "a toy";
        fn params() -> Vec<ParamSpec> {
            vec![ParamSpec { name: "c", default: 1.0, about: "cost" }]
        }
        fn from_instance(file: &InstanceFile) -> Result<Self, InstanceError> {
            file.expect_fields(&["width"])?;
            let w: f64 = file.field("width")?;
            Ok(Toy(ZetaSpace::new(vec!["z".into()], vec![-w], vec![w]).unwrap(), file.param("c")?))
        }
    }

    const TOY: &str = r#"{"env": "toy", "name": "t", "width": 2}"#;

    fn registry() -> Registry {
        Registry::new().register::<Toy>().bundle("t", TOY)
    }

    #[test]
    fn loads_bundled_instances_with_overrides_into_a_canonical_instance() {
        let env = registry().load("t", &[("c".into(), 3.0)]).unwrap();
        assert_eq!((env.name, env.title.as_str(), env.param("c")), ("toy", "t", Some(3.0)));
        assert_eq!(env.instance["params"]["c"], 3.0);
        assert_eq!(env.sampler().zeta_space().upper(), &[2.0]);
        let again = registry().from_value(&env.instance, "r.json").unwrap();
        assert_eq!(again.instance, env.instance, "a stored instance rebuilds the same environment");
        let no_model = env.model().err().expect("no model").to_string();
        assert_eq!(no_model, "`toy` has no model: the oracle and exact evaluation need one");
    }

    #[test]
    fn unknown_environments_parameters_and_wrong_environments_are_named() {
        let r = registry();
        let bad = InstanceFile::parse(r#"{"env": "nope", "name": "x"}"#, "x.json").unwrap();
        let e = r.build(bad, &[]).unwrap_err().to_string();
        assert!(e.contains("\"nope\"") && e.contains("x.json") && e.contains("known: toy"), "{e}");
        let e = r.load("t", &[("d".into(), 1.0)]).unwrap_err().to_string();
        assert!(e.contains("--env-param") && e.contains("\"d\"") && e.contains("c"), "{e}");
        let e = r.load("/no/such/file.json", &[]).unwrap_err().to_string();
        assert!(e.contains("/no/such/file.json"), "{e}");
        let env = r.load("t", &[]).unwrap();
        assert!(env.expect_env("toy", "t").is_ok());
        let e = env.expect_env("uav", "t.json").unwrap_err().to_string();
        assert!(e.contains("`toy`") && e.contains("`uav`"), "{e}");
        // A file without `env` is a UAV instance, which this registry does not know.
        let legacy = InstanceFile::parse(r#"{"name": "u", "n_uav": 2}"#, "u.json").unwrap();
        assert!(r.build(legacy, &[]).unwrap_err().to_string().contains("\"uav\""));
    }
}
