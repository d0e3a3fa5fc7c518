//! [`LearnerBridge`]: the learner host's end of the bridge.
//!
//! It opens the run's iceoryx2 services like a worker would (a proxy that never joins
//! itself), and relays: run info, weights and the tasks of remote workers go down to zenoh;
//! remote hellos and episodes come up and are published to the learner as if local. It
//! answers join requests (handing each host a distinct worker-id base) and "latest" requests
//! of hosts resyncing after a link loss.

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use envpg_protocol::{PROTOCOL_VERSION, hello_kind, run_id_bytes};
use envpg_transport::{WorkerEnd, ipc};
use serde::Serialize;
use zenoh::Wait;
use zenoh::bytes::ZBytes;
use zenoh::pubsub::Publisher;
use zenoh::query::Queryable;

use crate::BridgeError;
use crate::session::{Inbox, err, open, routes};
use crate::wire::{
    Down, HelloMsg, Info, JOIN_KEY, JoinReply, JoinRequest, Tasks, Up, Weights, decode, down_key, encode, latest_key,
    peek_version, up_key,
};

/// Worker id of the proxy itself (it never joins, so the learner never assigns it work).
const PROXY_ID: u32 = u32::MAX - 1;

/// How often the bridge checks, when idle, that its routes to remote hosts still exist.
const ROUTE_CHECK: Duration = Duration::from_secs(1);

/// Ids of the first joining host start here; each host gets its own block.
pub const ID_BLOCK: u32 = 1000;

/// How the learner host's bridge is set up.
#[derive(Debug, Clone)]
pub struct LearnerBridgeConfig {
    /// zenoh endpoint to listen on, e.g. `tcp/0.0.0.0:7447`.
    pub listen: String,
    /// The run id.
    pub run_id: String,
    /// The run's description handed to joining hosts (the launcher's `run.json`).
    pub run: String,
    /// Episodes per iteration.
    pub episodes_per_iteration: u32,
    /// How long to wait for the learner's services.
    pub open_timeout: Duration,
}

/// Traffic through the bridge.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BridgeStats {
    /// Hosts that joined.
    pub hosts: u32,
    /// Messages sent down (info, weights, tasks).
    pub down: u64,
    /// Episodes relayed up.
    pub episodes: u64,
    /// Transitions relayed up.
    pub transitions: u64,
    /// Hellos relayed up.
    pub hellos: u64,
    /// Messages from remote hosts that could not be decoded (dropped).
    pub malformed: u64,
}

#[derive(Debug)]
struct Shared {
    template: JoinReply,
    next_block: u32,
    latest: Vec<ZBytes>,
    hosts: u32,
}

/// The learner host's end of the bridge.
pub struct LearnerBridge {
    session: zenoh::Session,
    last_route_check: Instant,
    proxy: WorkerEnd<ipc::Service>,
    down: Publisher<'static>,
    up: Inbox,
    _join: Queryable<()>,
    _latest: Queryable<()>,
    shared: Arc<Mutex<Shared>>,
    remote: BTreeSet<u32>,
    info: Option<Info>,
    /// The latest weights message, encoded once: sent, then kept for resync answers.
    weights: Option<ZBytes>,
    stats: BridgeStats,
}

impl std::fmt::Debug for LearnerBridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LearnerBridge").field("remote", &self.remote).field("stats", &self.stats).finish()
    }
}

impl LearnerBridge {
    /// Opens the proxy on the learner's services (waiting for them) and starts listening.
    pub fn start(cfg: &LearnerBridgeConfig) -> Result<Self, BridgeError> {
        let proxy = WorkerEnd::<ipc::Service>::open(&cfg.run_id, PROXY_ID, PROTOCOL_VERSION, cfg.open_timeout)?;
        let info = proxy.info();
        let session = open(Some(&cfg.listen), None)?;
        let shared = Arc::new(Mutex::new(Shared {
            template: JoinReply {
                protocol: PROTOCOL_VERSION,
                run_id: cfg.run_id.clone(),
                run: cfg.run.clone(),
                id_base: 0,
                n_params: info.n_params,
                episode_cap: info.episode_cap,
                episodes_per_iteration: cfg.episodes_per_iteration,
                zeta_dim: info.zeta_dim,
            },
            next_block: 1,
            latest: Vec::new(),
            hosts: 0,
        }));
        let s = shared.clone();
        let join = session
            .declare_queryable(JOIN_KEY)
            .callback(move |query| {
                let bytes = query.payload().map(|p| p.to_bytes().into_owned()).unwrap_or_default();
                let answer = match peek_version(&bytes) {
                    Ok(v) if v != PROTOCOL_VERSION => {
                        Err(format!("the learner speaks envpg protocol v{PROTOCOL_VERSION}, the joining host v{v}"))
                    }
                    Err(e) => Err(e.to_string()),
                    Ok(_) => match decode::<JoinRequest>("join request", &bytes) {
                        Err(e) => Err(e.to_string()),
                        Ok(req) => {
                            let mut sh = s.lock().expect("bridge state");
                            let mut reply = sh.template.clone();
                            reply.id_base = sh.next_block * ID_BLOCK;
                            sh.next_block += 1;
                            sh.hosts += 1;
                            tracing::info!(
                                "host {:?} joins with {} workers (ids from {})",
                                req.host,
                                req.workers,
                                reply.id_base
                            );
                            encode("join reply", &reply).map_err(|e| e.to_string())
                        }
                    },
                };
                let sent = match answer {
                    Ok(b) => query.reply(JOIN_KEY, b).wait(),
                    Err(e) => {
                        tracing::warn!("refusing a join request: {e}");
                        query.reply_err(e).wait()
                    }
                };
                if let Err(e) = sent {
                    tracing::warn!("cannot answer a join request: {e}");
                }
            })
            .wait()
            .map_err(err("join queryable"))?;
        let s = shared.clone();
        let latest_k = latest_key(&cfg.run_id);
        let reply_key = latest_k.clone();
        let latest = session
            .declare_queryable(latest_k)
            .callback(move |query| {
                let msgs = s.lock().expect("bridge state").latest.clone();
                for m in msgs {
                    if let Err(e) = query.reply(reply_key.clone(), m).wait() {
                        tracing::warn!("cannot answer a resync request: {e}");
                    }
                }
            })
            .wait()
            .map_err(err("latest queryable"))?;
        let (down, up) = routes(&session, down_key(&cfg.run_id), up_key(&cfg.run_id))?;
        Ok(Self {
            session,
            last_route_check: Instant::now(),
            proxy,
            down,
            up,
            _join: join,
            _latest: latest,
            shared,
            remote: BTreeSet::new(),
            info: None,
            weights: None,
            stats: BridgeStats::default(),
        })
    }

    /// Remote workers that have joined and not left yet: at the end of the run the bridge
    /// stays up until they have all left (or a grace period ends), so the news reaches them.
    pub fn remote_workers(&self) -> usize {
        self.remote.len()
    }

    /// Traffic so far.
    pub fn stats(&self) -> BridgeStats {
        let mut s = self.stats.clone();
        s.hosts = self.shared.lock().expect("bridge state").hosts;
        s
    }

    fn put(&mut self, bytes: ZBytes) -> Result<(), BridgeError> {
        self.down.put(bytes).wait().map_err(err("put"))?;
        self.stats.down += 1;
        Ok(())
    }

    fn cache_latest(&mut self) -> Result<(), BridgeError> {
        let mut latest = Vec::new();
        if let Some(i) = self.info {
            latest.push(encode("down", &Down::Info(i))?.into());
        }
        latest.extend(self.weights.clone());
        self.shared.lock().expect("bridge state").latest = latest;
        Ok(())
    }

    /// One round of relaying in both directions, waiting up to `wait` for remote messages when
    /// there is nothing else to do. Returns whether the learner has announced the end.
    pub fn pump(&mut self, wait: Duration) -> Result<bool, BridgeError> {
        // Learner → remote hosts.
        let finished = self.proxy.run_finished()?;
        let info = Info { zeta_dim: self.proxy.info().zeta_dim, finished };
        let mut moved = false;
        if self.info != Some(info) {
            self.info = Some(info);
            self.put(encode("down", &Down::Info(info))?.into())?;
            self.cache_latest()?;
            moved = true;
        }
        let mut weights = None;
        self.proxy.with_latest_weights(|h, p| weights = Some(Weights::from_parts(h, p)))?;
        if let Some(w) = weights {
            let bytes = ZBytes::from(encode("down", &Down::Weights(w))?);
            // ZBytes clones share the buffer.
            self.put(bytes.clone())?;
            self.weights = Some(bytes);
            self.cache_latest()?;
            moved = true;
        }
        for (h, ids) in self.proxy.take_tasks()? {
            if self.remote.contains(&h.worker_id) {
                self.put(encode("down", &Down::Tasks(Tasks::from_parts(&h, &ids)))?.into())?;
                moved = true;
            }
        }
        self.proxy.drain_wakeups();
        // Remote hosts → learner.
        let mut n = 0;
        loop {
            let next = if n == 0 && !moved { self.up.recv_timeout(wait) } else { self.up.try_recv() };
            let Some(sample) = next.map_err(|e| BridgeError::Zenoh { what: "receive", reason: e.to_string() })? else {
                break;
            };
            n += 1;
            let bytes = sample.payload().to_bytes();
            match decode::<Up>("up", &bytes) {
                Ok(Up::Hello(h)) => self.relay_hello(h)?,
                Ok(Up::Episode(e)) => match e.to_parts() {
                    Ok((mut header, records)) => {
                        header.run_id = run_id_bytes(self.proxy.run_id());
                        self.stats.transitions += records.len() as u64;
                        self.stats.episodes += 1;
                        self.proxy.publish_episode(header, records.into_iter())?;
                    }
                    Err(e) => {
                        tracing::warn!("dropping a malformed episode from a remote host: {e}");
                        self.stats.malformed += 1;
                    }
                },
                Err(e) => {
                    tracing::warn!("dropping a malformed message from a remote host: {e}");
                    self.stats.malformed += 1;
                }
            }
            if n >= 512 {
                break;
            }
        }
        if n > 0 {
            self.proxy.notify_learner()?;
        } else if self.last_route_check.elapsed() > ROUTE_CHECK {
            self.last_route_check = Instant::now();
            self.check_routes()?;
        }
        Ok(finished)
    }

    /// With remote workers around, our publisher must match their hosts' subscribers; after a
    /// break of the link zenoh's reconnected session does not always bring the routes back
    /// (seen with zenoh 1.10 peers), so declare ours anew. Only called with the up queue
    /// drained, so nothing queued in the old subscriber is lost.
    fn check_routes(&mut self) -> Result<(), BridgeError> {
        if self.remote.is_empty() || self.down.matching_status().wait().map_err(err("matching status"))?.matching() {
            return Ok(());
        }
        tracing::warn!("no route to the remote hosts' subscribers; declaring the bridge's routes anew");
        let run_id = self.proxy.run_id().to_owned();
        (self.down, self.up) = routes(&self.session, down_key(&run_id), up_key(&run_id))?;
        Ok(())
    }

    fn relay_hello(&mut self, h: HelloMsg) -> Result<(), BridgeError> {
        match h.kind {
            hello_kind::JOIN | hello_kind::HEARTBEAT => {
                self.remote.insert(h.worker_id);
            }
            _ => {
                self.remote.remove(&h.worker_id);
            }
        }
        self.stats.hellos += 1;
        self.proxy.forward_hello(h.to_hello())?;
        Ok(())
    }
}
