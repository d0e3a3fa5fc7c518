//! Rollouts across hosts (feature `multi-host`): a learner host with `--listen` and a worker
//! host with `worker --connect`, in two network namespaces joined by a veth pair where the
//! machine permits it (otherwise, said so, two processes on loopback). The run ends with the
//! in-process result; cutting the link mid-run (veth down, then up; on loopback: the worker
//! host frozen) does not change it; a host of another protocol version is refused; without
//! the feature the options say how to get it.
#![cfg(feature = "multi-host")]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_envpg-launch")
}

/// The launcher, with default run directories kept out of the source tree.
fn launcher() -> Command {
    let mut c = Command::new(exe());
    c.env("ENVPG_RUNS_DIR", std::env::temp_dir().join("envpg-test-runs"));
    c
}

/// Waits for `child` under a watchdog, reading its output meanwhile (a chatty child never
/// blocks on a full pipe).
fn wait(child: Child, limit: Duration, what: &str) -> Output {
    let pid = child.id() as i32;
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || tx.send(child.wait_with_output().expect("output")));
    match rx.recv_timeout(limit) {
        Ok(out) => out,
        Err(_) => {
            // SAFETY: a signal to a child we spawned and have not reaped.
            unsafe { libc::kill(pid, libc::SIGKILL) };
            let out = rx.recv().expect("output");
            panic!("watchdog: {what} still running after {limit:?}\nstderr:\n{}", String::from_utf8_lossy(&out.stderr));
        }
    }
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The problem every test runs: a tiny instance, the smoke preset, a little emulator cost so
/// the run lasts long enough to be cut.
fn problem(dir: &Path, iterations: u32) -> Vec<String> {
    let instance = dir.join("tiny.json");
    if !instance.exists() {
        let users: Vec<String> =
            (0..24).map(|i| format!("[{}, {}]", (i % 6) as f64 * 1.3, (i / 6) as f64 * 1.1)).collect();
        std::fs::write(
            &instance,
            format!("{{\"name\": \"tiny\", \"n_uav\": 3, \"users\": [{}], \"dest\": [9.0, 0.5]}}", users.join(", ")),
        )
        .unwrap();
    }
    [
        "--instance",
        instance.to_str().unwrap(),
        "--preset",
        "smoke",
        "--iterations",
        &iterations.to_string(),
        "--kappa",
        "0.9",
        "--seed",
        "5",
        "--quiet",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

fn in_process_result(dir: &Path, iterations: u32) -> envpg_core::ResultFile {
    in_process_result_with(dir, iterations, &[])
}

/// [`in_process_result`] with extra settings.
fn in_process_result_with(dir: &Path, iterations: u32, extra: &[&str]) -> envpg_core::ResultFile {
    let out = dir.join("local.json");
    let mut args = problem(dir, iterations);
    args.extend(["--in-process".into(), "--out".into(), out.display().to_string()]);
    args.extend(extra.iter().map(|s| s.to_string()));
    let o = wait(
        launcher().args(&args).stderr(Stdio::piped()).spawn().unwrap(),
        Duration::from_secs(120),
        "in-process run",
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    envpg_core::ResultFile::load(&out).unwrap()
}

/// Two hosts: network namespaces joined by a veth pair, or loopback.
struct Hosts {
    namespaces: Option<(String, String, String)>,
    learner_addr: String,
}

impl Hosts {
    fn new() -> Self {
        let tag = std::process::id() % 100_000;
        let (a, b, veth) = (format!("envpg-a{tag}"), format!("envpg-b{tag}"), format!("evp{tag}"));
        let net = 10 + tag % 200;
        let ok = |args: &[&str]| Command::new("ip").args(args).output().is_ok_and(|o| o.status.success());
        // ENVPG_TEST_LOOPBACK=1 exercises the fallback on machines that do have namespaces.
        let created = std::env::var_os("ENVPG_TEST_LOOPBACK").is_none()
            && ok(&["netns", "add", &a])
            && ok(&["netns", "add", &b])
            && ok(&["link", "add", &format!("{veth}a"), "type", "veth", "peer", "name", &format!("{veth}b")])
            && ok(&["link", "set", &format!("{veth}a"), "netns", &a])
            && ok(&["link", "set", &format!("{veth}b"), "netns", &b])
            && ok(&["-n", &a, "addr", "add", &format!("10.88.{net}.1/24"), "dev", &format!("{veth}a")])
            && ok(&["-n", &b, "addr", "add", &format!("10.88.{net}.2/24"), "dev", &format!("{veth}b")])
            && ok(&["-n", &a, "link", "set", &format!("{veth}a"), "up"])
            && ok(&["-n", &b, "link", "set", &format!("{veth}b"), "up"])
            && ok(&["-n", &a, "link", "set", "lo", "up"])
            && ok(&["-n", &b, "link", "set", "lo", "up"]);
        if created {
            return Self { namespaces: Some((a, b, veth)), learner_addr: format!("10.88.{net}.1:7447") };
        }
        let _ = Command::new("ip").args(["netns", "del", &a]).output();
        let _ = Command::new("ip").args(["netns", "del", &b]).output();
        eprintln!(
            "NOTE: network namespaces are not available here (needs root and iproute2's `ip netns`); \
             testing the bridge between two processes on loopback instead"
        );
        Self::loopback()
    }

    /// Both "hosts" on loopback.
    fn loopback() -> Self {
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        Self { namespaces: None, learner_addr: format!("127.0.0.1:{port}") }
    }

    fn command(&self, learner_side: bool) -> Command {
        match &self.namespaces {
            Some((a, b, _)) => {
                let mut c = Command::new("ip");
                c.args(["netns", "exec", if learner_side { a } else { b }, exe()]);
                c.env("ENVPG_RUNS_DIR", std::env::temp_dir().join("envpg-test-runs"));
                c
            }
            None => launcher(),
        }
    }

    fn learner(&self, args: &[String]) -> Child {
        self.command(true).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap()
    }

    fn worker_host(&self, workers: u32) -> Child {
        self.command(false)
            .args(["worker", "--connect", &format!("tcp/{}", self.learner_addr), "--workers", &workers.to_string()])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    }

    /// Cuts the link for `how_long`: the learner side of the veth goes down and up again; on
    /// loopback the worker host is frozen (SIGSTOP/SIGCONT) instead.
    fn cut(&self, worker_host: &Child, how_long: Duration) {
        match &self.namespaces {
            Some((a, _, veth)) => {
                let dev = format!("{veth}a");
                assert!(Command::new("ip").args(["-n", a, "link", "set", &dev, "down"]).status().unwrap().success());
                std::thread::sleep(how_long);
                assert!(Command::new("ip").args(["-n", a, "link", "set", &dev, "up"]).status().unwrap().success());
            }
            None => {
                let pid = worker_host.id() as i32;
                // SAFETY: signals to a child we spawned.
                unsafe { libc::kill(pid, libc::SIGSTOP) };
                std::thread::sleep(how_long);
                unsafe { libc::kill(pid, libc::SIGCONT) };
            }
        }
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        if let Some((a, b, _)) = &self.namespaces {
            let _ = Command::new("ip").args(["netns", "del", a]).output();
            let _ = Command::new("ip").args(["netns", "del", b]).output();
        }
    }
}

fn learner_args(
    dir: &Path,
    iterations: u32,
    local_workers: u32,
    hosts: &Hosts,
    extra: &[&str],
) -> (Vec<String>, PathBuf) {
    let out = dir.join("remote.json");
    let mut args = problem(dir, iterations);
    args.extend(
        [
            "--workers",
            &local_workers.to_string(),
            "--listen",
            &format!("tcp/{}", hosts.learner_addr),
            "--out",
            out.to_str().unwrap(),
            "--run-dir",
            dir.join("run").to_str().unwrap(),
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    args.extend(extra.iter().map(|s| s.to_string()));
    (args, out)
}

fn same_result(a: &envpg_core::ResultFile, b: &envpg_core::ResultFile) {
    assert_eq!(a.j, b.j);
    assert_eq!(a.zeta, b.zeta);
    assert_eq!(a.policy, b.policy);
    assert_eq!(a.history.as_ref().map(|h| h.len()), b.history.as_ref().map(|h| h.len()));
}

#[test]
fn remote_workers_across_a_network_boundary_give_the_in_process_result() {
    let dir = tempfile::tempdir().unwrap();
    let reference = in_process_result(dir.path(), 40);
    let hosts = Hosts::new();
    let (args, out) = learner_args(dir.path(), 40, 0, &hosts, &[]);
    let learner = hosts.learner(&args);
    let remote = hosts.worker_host(2);
    let lo = wait(learner, Duration::from_secs(180), "learner host");
    let ro = wait(remote, Duration::from_secs(60), "worker host");
    assert!(lo.status.success(), "learner host failed:\n{}\nworker host:\n{}", text(&lo.stderr), text(&ro.stderr));
    assert!(ro.status.success(), "worker host failed:\n{}", text(&ro.stderr));
    assert!(text(&ro.stderr).contains("joined run"), "{}", text(&ro.stderr));
    let r = envpg_core::ResultFile::load(&out).unwrap();
    same_result(&r, &reference);
    let bridge = &r.details.as_ref().unwrap()["bridge"];
    assert_eq!(bridge["hosts"], 1, "{bridge}");
    // Every worker is remote: every episode the learner used came across the bridge.
    let used = r.details.as_ref().unwrap()["link"]["episodes"].as_u64().unwrap();
    assert!(bridge["episodes"].as_u64().unwrap() >= used, "{bridge}");
}

#[test]
fn a_lagged_run_across_hosts_gives_the_in_process_result() {
    // Every worker on the other host, with a policy lag: batch k + 1 crosses the bridge while
    // the learner updates on batch k, and the result is the in-process one.
    let dir = tempfile::tempdir().unwrap();
    let reference = in_process_result_with(dir.path(), 40, &["--lag", "1"]);
    let hosts = Hosts::new();
    let (args, out) = learner_args(dir.path(), 40, 0, &hosts, &["--lag", "1"]);
    let learner = hosts.learner(&args);
    let remote = hosts.worker_host(2);
    let lo = wait(learner, Duration::from_secs(180), "learner host");
    let ro = wait(remote, Duration::from_secs(60), "worker host");
    assert!(lo.status.success(), "learner host failed:\n{}\nworker host:\n{}", text(&lo.stderr), text(&ro.stderr));
    let r = envpg_core::ResultFile::load(&out).unwrap();
    assert_eq!(r.config.as_ref().unwrap()["lag"], 1);
    same_result(&r, &reference);
    assert!(r.details.as_ref().unwrap()["bridge"]["episodes"].as_u64().unwrap() > 0);
}

/// Collects a child's stderr in the background, so a test can react to what it says.
fn watch_stderr(child: &mut Child) -> Arc<Mutex<String>> {
    let text = Arc::new(Mutex::new(String::new()));
    let sink = text.clone();
    let mut err = child.stderr.take().expect("stderr piped");
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(n) = err.read(&mut buf) {
            if n == 0 {
                break;
            }
            sink.lock().unwrap().push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    });
    text
}

/// Runs with a worker host, cuts the link once that host has sent episodes and the learner has
/// checkpointed since (mid-run), and checks the result is the in-process one.
fn cut_mid_run(local_workers: u32) {
    let dir = tempfile::tempdir().unwrap();
    let iterations = 600;
    let reference = in_process_result(dir.path(), iterations);
    let hosts = Hosts::new();
    // A short worker timeout makes the learner notice the cut quickly; the emulator cost
    // makes the run last long enough to be cut.
    let (args, out) = learner_args(
        dir.path(),
        iterations,
        local_workers,
        &hosts,
        &["--emulator-cost-us", "200", "--worker-timeout-ms", "800", "--checkpoint-every", "10"],
    );
    let learner = hosts.learner(&args);
    let mut remote = hosts.worker_host(1);
    let remote_err = watch_stderr(&mut remote);
    let start = Instant::now();
    while !remote_err.lock().unwrap().contains("first episodes sent") {
        assert!(start.elapsed() < Duration::from_secs(120), "watchdog: no episodes from the worker host in 120 s");
        std::thread::sleep(Duration::from_millis(20));
    }
    let contributing = std::time::SystemTime::now();
    let checkpoint = dir.path().join("run").join("checkpoint.bin");
    while !std::fs::metadata(&checkpoint).and_then(|m| m.modified()).is_ok_and(|t| t > contributing) {
        assert!(start.elapsed() < Duration::from_secs(120), "watchdog: no checkpoint after the first remote episodes");
        std::thread::sleep(Duration::from_millis(20));
    }
    // Longer than the bridge's 3 s link lease: the zenoh session breaks and reconnects.
    hosts.cut(&remote, Duration::from_secs(5));
    let lo = wait(learner, Duration::from_secs(300), "learner host");
    let ro = wait(remote, Duration::from_secs(60), "worker host");
    let remote_err = remote_err.lock().unwrap().clone();
    assert!(lo.status.success(), "learner host failed:\n{}\nworker host:\n{remote_err}", text(&lo.stderr));
    assert!(ro.status.success(), "worker host failed:\n{remote_err}\nlearner host:\n{}", text(&lo.stderr));
    let r = envpg_core::ResultFile::load(&out).unwrap();
    same_result(&r, &reference);
    let details = r.details.as_ref().unwrap();
    eprintln!("after the cut: link {} bridge {}", details["link"], details["bridge"]);
    assert!(details["bridge"]["episodes"].as_u64().unwrap() > 0, "the remote host never contributed");
    assert!(details["link"]["workers_lost"].as_u64().unwrap() >= 1, "the cut went unnoticed");
}

#[test]
fn cutting_the_link_mid_run_keeps_the_result_as_local_workers_take_over() {
    cut_mid_run(1);
}

#[test]
fn cutting_the_link_mid_run_keeps_the_result_as_the_learner_waits_for_the_host() {
    // No local worker: the learner waits for the host to come back and rejoin.
    cut_mid_run(0);
}

/// Runs a worker host that the learner at `hosts` must turn away (`extra` says why), under a
/// watchdog; returns its exit code and stderr.
fn refused_worker_host(hosts: &Hosts, extra: &[&str], what: &str) -> (Option<i32>, String) {
    let o = wait(
        launcher()
            .args(["worker", "--connect", &format!("tcp/{}", hosts.learner_addr)])
            .args(extra)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
        Duration::from_secs(90),
        what,
    );
    (o.status.code(), text(&o.stderr))
}

#[test]
fn a_worker_host_of_another_protocol_version_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let reference = in_process_result(dir.path(), 30);
    // Every worker is remote, so the learner waits while the wrong host is turned away.
    let hosts = Hosts::loopback();
    let (args, out) = learner_args(dir.path(), 30, 0, &hosts, &[]);
    let learner = hosts.learner(&args);
    let (code, err) = refused_worker_host(&hosts, &["--protocol-version", "99"], "worker host of another version");
    assert_eq!(code, Some(2), "{err}");
    let ours = format!("v{}", envpg_protocol::PROTOCOL_VERSION);
    assert!(err.contains(&ours) && err.contains("v99"), "{err}");
    // The run is not corrupted: a host of the right version joins and it ends as in-process.
    let remote = hosts.worker_host(1);
    let lo = wait(learner, Duration::from_secs(120), "learner host");
    let ro = wait(remote, Duration::from_secs(60), "worker host");
    assert!(lo.status.success(), "learner host failed:\n{}\nworker host:\n{}", text(&lo.stderr), text(&ro.stderr));
    same_result(&envpg_core::ResultFile::load(&out).unwrap(), &reference);
}

#[test]
fn bad_endpoints_are_input_errors() {
    for args in [
        vec!["--listen", "7447", "--preset", "smoke"],
        vec!["--listen", "tcp/localhost", "--preset", "smoke"],
        vec!["worker", "--connect", "udp/1.2.3.4:5"],
    ] {
        let o = launcher().args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o.stderr));
        assert!(text(&o.stderr).contains("expected tcp/HOST:PORT"), "{}", text(&o.stderr));
    }
    // Nobody listening: a clear error, not a hang.
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let o = wait(
        launcher()
            .args(["worker", "--connect", &format!("tcp/127.0.0.1:{port}"), "--join-timeout-s", "2"])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
        Duration::from_secs(60),
        "worker host without a learner",
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("no learner answered"), "{}", text(&o.stderr));
}

/// What the rogue host of [`a_rogue_host_changes_nothing`] sent.
#[derive(Debug, Default)]
struct Attacks {
    /// Iterations it attacked.
    iterations: u64,
    /// Messages sent.
    messages: u64,
}

/// A host that joins the run like a worker host, then, in every iteration whose tasks it sees
/// on the way down, sends everything a broken or hostile host could: bytes that decode to
/// nothing, messages claiming a local worker's id, episodes nobody asked for (its own ids,
/// stale and future iterations, unknown episodes, duplicates), and malformed copies of an
/// episode handed to the real worker host. (Well-formed copies of that episode are what no
/// learner can tell from the real one: see docs/training.md.)
fn rogue_host(endpoint: String, stop: Arc<std::sync::atomic::AtomicBool>) -> Attacks {
    use envpg_bridge::wire::{Down, EpisodeMsg, HelloMsg, Step, Up, encode};
    use envpg_bridge::{RemoteBridge, RemoteConfig};
    use envpg_protocol::{PROTOCOL_VERSION, hello_kind};
    let config = |workers| RemoteConfig {
        connect: endpoint.clone(),
        host: "rogue".into(),
        workers,
        join_timeout: Duration::from_secs(60),
        protocol: PROTOCOL_VERSION,
    };
    let bridge = RemoteBridge::join(&config(2)).expect("the rogue joins");
    let own = bridge.joined().id_base;
    let d = bridge.joined().zeta_dim as usize;
    let cap = bridge.joined().episode_cap as usize;
    let mut attacks = Attacks::default();
    let step = |s: u32, cost: f32| Step { s, a: 0, s2: 0, cost, zeta: vec![0.5; d] };
    let episode = |worker_id: u32, k: u64, episode: (u32, u32), steps: Vec<Step>| {
        Up::Episode(EpisodeMsg { worker_id, k, episode, seq: 0, capped: false, zeta_dim: d as u32, steps })
    };
    let mut attacked = std::collections::BTreeSet::new();
    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
        let t = match bridge.recv_raw(Duration::from_millis(200)).expect("receive") {
            Some(Down::Info(i)) if i.finished => break,
            Some(Down::Tasks(t)) if !(own..own + 2).contains(&t.worker_id) && !t.episodes.is_empty() => t,
            _ => continue,
        };
        if !attacked.insert(t.k) {
            continue;
        }
        let (k, real, handed) = (t.k, t.worker_id, t.episodes[0]);
        let one = || vec![step(0, 1.0)];
        let valid = encode("up", &episode(own, k, handed, one())).unwrap();
        let mut msgs: Vec<Vec<u8>> = vec![vec![], vec![0xff; 64], valid[..valid.len() / 2].to_vec()];
        let mut bad_zeta = one();
        bad_zeta[0].zeta.push(1.0);
        for msg in [
            // A local worker's id: leaving, and delivering.
            Up::Hello(HelloMsg {
                protocol: PROTOCOL_VERSION,
                kind: hello_kind::LEAVE,
                worker_id: 0,
                pid: 1,
                incarnation: 0,
                detail: 0,
            }),
            episode(0, k, handed, one()),
            // Not asked for: its own id, a stale and a future iteration, an unknown episode, twice each.
            episode(own, k, handed, one()),
            episode(own, k, handed, one()),
            episode(real, k.wrapping_sub(1), handed, one()),
            episode(real, k + 1_000_000, handed, one()),
            episode(real, k, (7, 999_999), one()),
            episode(real, k, (7, 999_999), one()),
            // Malformed copies of the real host's episode: a step with too many ζ entries, over
            // the cap, a NaN cost, a state out of range.
            episode(real, k, handed, bad_zeta),
            episode(real, k, handed, (0..=cap).map(|_| step(0, 1.0)).collect()),
            episode(real, k, handed, vec![step(0, f32::NAN)]),
            episode(real, k, handed, vec![step(u32::MAX, 1.0)]),
        ] {
            msgs.push(encode("up", &msg).unwrap());
        }
        for m in msgs {
            bridge.send_raw(m).expect("send");
            attacks.messages += 1;
        }
        attacks.iterations += 1;
    }
    attacks
}

#[test]
fn a_rogue_host_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let iterations = 300;
    let reference = in_process_result(dir.path(), iterations);
    let hosts = Hosts::loopback();
    let (args, out) = learner_args(dir.path(), iterations, 1, &hosts, &["--emulator-cost-us", "200"]);
    let learner = hosts.learner(&args);
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let endpoint = format!("tcp/{}", hosts.learner_addr);
    let rogue = {
        let stop = stop.clone();
        std::thread::spawn(move || rogue_host(endpoint, stop))
    };
    let remote = hosts.worker_host(1);
    // A host asking for more worker ids than a host gets is refused by the learner host.
    let (code, err) = refused_worker_host(&hosts, &["--workers", "5000"], "worker host of too many workers");
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("refused this host: a host runs 1 to 1000 workers"), "{err}");
    let lo = wait(learner, Duration::from_secs(180), "learner host");
    let ro = wait(remote, Duration::from_secs(60), "worker host");
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let attacks = rogue.join().expect("the rogue host's thread");
    assert!(lo.status.success(), "learner host failed:\n{}\nworker host:\n{}", text(&lo.stderr), text(&ro.stderr));
    assert!(ro.status.success(), "worker host failed:\n{}", text(&ro.stderr));
    let r = envpg_core::ResultFile::load(&out).unwrap();
    same_result(&r, &reference);
    let details = r.details.as_ref().unwrap();
    let (bridge, link) = (&details["bridge"], &details["link"]);
    eprintln!("rogue {attacks:?}\nbridge {bridge}\nlink {link}");
    assert!(attacks.iterations >= 5, "the rogue attacked only {attacks:?}: the run ended too soon to test anything");
    assert_eq!(bridge["hosts"], 2, "{bridge}");
    assert_eq!(bridge["joins_refused"], 1, "{bridge}");
    for counter in ["malformed", "foreign_ids", "unasked"] {
        assert!(bridge[counter].as_u64().unwrap() >= attacks.iterations, "{counter}: {bridge}");
    }
    // The NaN cost and the state out of range passed the bridge (it cannot tell them) and the
    // learner refused them, or counted them as duplicates of the real one.
    let refused = link["refused"].as_u64().unwrap() + link["duplicates"].as_u64().unwrap();
    assert!(refused >= attacks.iterations, "{link}");
    assert!(bridge["episodes"].as_u64().unwrap() > 0, "the real worker host never contributed: {bridge}");
}
