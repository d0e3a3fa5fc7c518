//! Options shared by the experiment commands (`table`, `sweep`): Algorithm 1 settings
//! (preset + overrides), how runs are executed, and parsing of seed and value lists.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result};
use clap::Args;
use envpg_ac::AcConfig;
use envpg_ac::trainer::RunSpec;
use envpg_core::{Registry, ResultFile};
use envpg_report::{Alg1Runner, InProcess};

use crate::args::{InputError, Tools, input_err};

/// Algorithm 1 settings of an experiment.
#[derive(Debug, Clone, Args)]
pub struct SettingsArgs {
    /// Preset of Algorithm 1 settings (see launch/presets.toml) [default: the preset named like
    /// the environment (`uav`, `aac`), or `default` (the `uav` settings in the environment's
    /// units) for one without].
    #[arg(long)]
    pub preset: Option<String>,
    /// Preset file, searched before the program's and envpg's bundled presets (a preset may
    /// extend another with `base = "name"`).
    #[arg(long)]
    pub presets: Option<PathBuf>,
    /// Outer iterations of every Algorithm 1 run (shortcut for --set iterations=N).
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Override one setting, as in a preset file: `--set sigma=0.1 --set hidden=[64,64]`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
}

impl SettingsArgs {
    /// The validated settings for environment `env`.
    pub fn config(&self, registry: &Registry, env: &str) -> Result<AcConfig> {
        let mut c = AcConfig::for_env(registry, self.presets.as_deref(), self.preset.as_deref(), env)?;
        if let Some(n) = self.iterations {
            c = c.set("iterations", &n.to_string()).map_err(|e| InputError(e.to_string()))?;
        }
        for o in &self.overrides {
            let Some((k, v)) = o.split_once('=') else {
                return input_err(format!("--set {o:?}: expected KEY=VALUE"));
            };
            c = c.set(k.trim(), v.trim()).map_err(|e| InputError(format!("--set {o}: {e}")))?;
        }
        Ok(c)
    }
}

/// How Algorithm 1 runs are executed.
#[derive(Debug, Clone, Args)]
pub struct RunnerArgs {
    /// Run each Algorithm 1 run distributed: `envpg-launch --workers N` (learner + N worker
    /// processes over shared memory). Results equal the in-process ones.
    #[arg(long, conflicts_with = "in_process")]
    pub workers: Option<usize>,
    /// Run Algorithm 1 in this process (the default).
    #[arg(long)]
    pub in_process: bool,
    /// Independent runs at once [default: available cores, divided by the processes of one
    /// run with --workers].
    #[arg(long)]
    pub jobs: Option<usize>,
}

impl RunnerArgs {
    /// The runner and the number of parallel jobs.
    pub fn runner(&self, dir: &Path, tools: &Tools) -> Result<(Box<dyn Alg1Runner>, usize)> {
        let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
        if self.jobs == Some(0) {
            return input_err("--jobs must be at least 1");
        }
        match self.workers {
            None => Ok((Box::new(InProcess(tools.registry.clone())), self.jobs.unwrap_or(cores))),
            Some(0) => input_err("--workers must be at least 1"),
            Some(w) => {
                let launch = Launcher::find(w, dir, &tools.launcher)?;
                Ok((Box::new(launch), self.jobs.unwrap_or((cores / (w + 1)).max(1))))
            }
        }
    }
}

/// Runs Algorithm 1 through the launcher binary next to this one (or `$ENVPG_LAUNCH`).
#[derive(Debug)]
pub struct Launcher {
    exe: PathBuf,
    workers: usize,
    dir: PathBuf,
}

impl Launcher {
    fn find(workers: usize, dir: &Path, name: &str) -> Result<Self> {
        let exe = match std::env::var_os("ENVPG_LAUNCH") {
            Some(p) => PathBuf::from(p),
            None => std::env::current_exe()
                .context("locating this executable")?
                .with_file_name(format!("{name}{}", std::env::consts::EXE_SUFFIX)),
        };
        if !exe.is_file() {
            return input_err(format!(
                "--workers needs the {name} binary, not found at {} (build it with `cargo build \
                 --release --bin {name}`, or set ENVPG_LAUNCH)",
                exe.display()
            ));
        }
        Ok(Self { exe, workers, dir: dir.to_owned() })
    }
}

impl Alg1Runner for Launcher {
    fn run(&self, spec: &RunSpec, out: &Path) -> Result<ResultFile, String> {
        let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("run");
        let scratch = self.dir.join("runs").join(format!(".{stem}"));
        std::fs::create_dir_all(&scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
        // The exact settings travel as a one-preset file and the instance as its own file, so
        // the launched run is the spec, whatever the defaults of the launcher.
        let mut presets = toml::Table::new();
        presets.insert("run".into(), toml::Value::try_from(&spec.config).map_err(|e| e.to_string())?);
        let preset_path = scratch.join("preset.toml");
        let instance_path = scratch.join("instance.json");
        let write = |p: &Path, t: String| {
            envpg_core::io::write_atomic(p, t.as_bytes()).map_err(|e| format!("{}: {e}", p.display()))
        };
        write(&preset_path, toml::to_string(&presets).map_err(|e| e.to_string())?)?;
        write(&instance_path, serde_json::to_string_pretty(&spec.instance).map_err(|e| e.to_string())?)?;
        let output = Command::new(&self.exe)
            .arg("--workers")
            .arg(self.workers.to_string())
            .arg("--instance")
            .arg(&instance_path)
            .args(["--seed", &spec.seed.to_string()])
            .arg("--presets")
            .arg(&preset_path)
            .args(["--preset", "run", "--quiet", "--out"])
            .arg(out)
            .arg("--run-dir")
            .arg(scratch.join("run"))
            .output()
            .map_err(|e| format!("starting {}: {e}", self.exe.display()))?;
        if !output.status.success() {
            let err = String::from_utf8_lossy(&output.stderr);
            return Err(format!("envpg-launch failed ({}): {}", output.status, err.trim()));
        }
        let r = ResultFile::load(out).map_err(|e| e.to_string())?;
        let _ = std::fs::remove_dir_all(&scratch);
        Ok(r)
    }

    fn describe(&self) -> String {
        let name = self.exe.file_name().map_or("envpg-launch".into(), |n| n.to_string_lossy().into_owned());
        format!("Algorithm 1 distributed ({name} --workers {})", self.workers)
    }
}

/// Parses `KEY=V1,V2,…` (the columns of `--vary`).
pub fn parse_vary(text: &str) -> Result<envpg_report::Vary> {
    let bad = || InputError(format!("--vary {text:?}: expected KEY=V1,V2,… with numeric values"));
    let (key, values) = text.split_once('=').ok_or_else(bad)?;
    let values: Vec<f64> =
        values.split(',').map(|v| v.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    if key.trim().is_empty() || values.is_empty() {
        return Err(bad().into());
    }
    Ok(envpg_report::Vary { key: key.trim().to_owned(), values })
}

/// Parses seeds: `1..6` (inclusive) or `1,2,5`.
pub fn parse_seeds(text: &str) -> Result<Vec<u64>> {
    let bad = || InputError(format!("--seeds {text:?}: expected A..B or a comma-separated list"));
    if let Some((a, b)) = text.split_once("..") {
        let (a, b): (u64, u64) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
        if a > b {
            return Err(bad().into());
        }
        return Ok((a..=b).collect());
    }
    Ok(text.split(',').map(|t| t.trim().parse::<u64>()).collect::<Result<_, _>>().map_err(|_| bad())?)
}

/// Splits a value list on commas outside brackets, so `[64,64],[128]` is two values.
pub fn split_values(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut cur = String::new();
    for c in text.chars() {
        match c {
            '[' => depth += 1,
            ']' => depth -= 1,
            ',' if depth == 0 => {
                out.push(std::mem::take(&mut cur).trim().to_owned());
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    out.push(cur.trim().to_owned());
    out.into_iter().filter(|s| !s.is_empty()).collect()
}

/// The command line as typed (the program by its file name: `envpg`, or a user's own tools
/// binary), for reports.
pub fn command_line() -> String {
    let mut args = std::env::args();
    let program = args
        .next()
        .and_then(|p| std::path::Path::new(&p).file_name().map(|f| f.to_string_lossy().into_owned()))
        .unwrap_or_else(|| "envpg".into());
    format!("Command: `{program} {}`", args.collect::<Vec<_>>().join(" "))
}

/// One line about this machine, for reports.
pub fn machine_line() -> String {
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines().find(|l| l.starts_with("model name")).map(|l| l.split(':').nth(1).unwrap_or("").trim().to_owned())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    format!("Machine: {cores} cores ({cpu}), {} build.", if cfg!(debug_assertions) { "debug" } else { "release" })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_lists() {
        assert_eq!(parse_seeds("1..6").unwrap(), [1, 2, 3, 4, 5, 6]);
        assert_eq!(parse_seeds("3, 7").unwrap(), [3, 7]);
        assert!(parse_seeds("6..1").is_err());
        assert!(parse_seeds("a").is_err());
    }

    #[test]
    fn value_lists_keep_brackets_whole() {
        assert_eq!(split_values("0.01,0.1"), ["0.01", "0.1"]);
        assert_eq!(split_values("[64,64], [128]"), ["[64,64]", "[128]"]);
    }
}
