//! [`LearnerBridge`]: the learner host's end of the bridge.
//!
//! It opens the run's iceoryx2 services like a worker would (a proxy that never joins
//! itself), and relays: run info, weights and the tasks of remote workers go down to zenoh;
//! remote hellos and episodes come up and are published to the learner as if local. It
//! answers join requests (handing each host a distinct worker-id base) and "latest" requests
//! of hosts resyncing after a link loss.

use std::collections::{BTreeMap, BTreeSet};
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
    Down, EpisodeMsg, HelloMsg, Info, JOIN_KEY, JoinReply, JoinRequest, Tasks, Up, Weights, decode, down_key, encode,
    latest_key, peek_version, up_key,
};

/// Worker id of the proxy itself (it never joins, so the learner never assigns it work).
const PROXY_ID: u32 = u32::MAX - 1;

/// How often the bridge checks, when idle, that its routes to remote hosts still exist.
const ROUTE_CHECK: Duration = Duration::from_secs(1);

/// Copies of one handed episode the bridge relays: the worker's own, and a few more, so that
/// a copy forged by another host (which the learner refuses on its contents) cannot shut the
/// real one out, while a flood stays bounded by the iteration's size.
const COPIES_PER_EPISODE: u8 = 4;

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
    /// Messages from remote hosts claiming a worker id no joined host was given — a local
    /// worker's, say (dropped before they reach the learner).
    pub foreign_ids: u64,
    /// Episodes from remote hosts that were not handed to the worker they claim (or not in
    /// the current iteration, or already relayed once): dropped.
    pub unasked: u64,
    /// Join requests refused (another protocol version, a malformed request, no worker or
    /// more than one id block of them, the id space exhausted).
    pub joins_refused: u64,
}

#[derive(Debug)]
struct Shared {
    template: JoinReply,
    next_block: u32,
    latest: Vec<ZBytes>,
    hosts: u32,
    joins_refused: u64,
}

impl Shared {
    /// The id base of the next joining host of `workers` workers, or why it is refused.
    fn hand_out_block(&mut self, workers: u32) -> Result<u32, String> {
        if workers == 0 || workers > ID_BLOCK {
            return Err(format!("a host runs 1 to {ID_BLOCK} workers; this one asked for {workers}"));
        }
        let base = self
            .next_block
            .checked_mul(ID_BLOCK)
            .filter(|b| b.checked_add(ID_BLOCK).is_some_and(|end| end < PROXY_ID))
            .ok_or_else(|| "this run has handed out every worker id it has; no more hosts can join".to_string())?;
        self.next_block += 1;
        self.hosts += 1;
        Ok(base)
    }

    /// Whether `worker_id` lies in a block handed to a joined host.
    fn is_remote_id(&self, worker_id: u32) -> bool {
        worker_id >= ID_BLOCK && worker_id / ID_BLOCK < self.next_block
    }
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
    /// (k, worker, kind, index) of every episode of the current iteration handed to a remote
    /// worker, with how many more copies of it may pass: the only episodes the bridge lets
    /// through.
    handed: BTreeMap<(u64, u32, u32, u32), u8>,
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
            joins_refused: 0,
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
                            sh.hand_out_block(req.workers).and_then(|base| {
                                let reply = JoinReply { id_base: base, ..sh.template.clone() };
                                tracing::info!(
                                    "host {:?} joins with {} workers (ids from {base})",
                                    req.host,
                                    req.workers
                                );
                                encode("join reply", &reply).map_err(|e| e.to_string())
                            })
                        }
                    },
                };
                let sent = match answer {
                    Ok(b) => query.reply(JOIN_KEY, b).wait(),
                    Err(e) => {
                        dropped(
                            &mut s.lock().expect("bridge state").joins_refused,
                            format_args!("a join request ({e})"),
                        );
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
            handed: BTreeMap::new(),
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
        let shared = self.shared.lock().expect("bridge state");
        s.hosts = shared.hosts;
        s.joins_refused = shared.joins_refused;
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
                // Episodes of earlier iterations are stale: the learner would refuse them.
                self.handed = self.handed.split_off(&(h.k, 0, 0, 0));
                self.handed.extend(ids.iter().map(|e| ((h.k, h.worker_id, e.kind, e.index), COPIES_PER_EPISODE)));
                self.put(encode("down", &Down::Tasks(Tasks::from_parts(&h, &ids)))?.into())?;
                moved = true;
            }
        }
        self.proxy.drain_wakeups();
        // Remote hosts → learner.
        let mut n = 0;
        // At most 512 messages a round, so a flood from the hosts cannot starve the way down.
        while n < 512 {
            let next = if n == 0 && !moved { self.up.recv_timeout(wait) } else { self.up.try_recv() };
            let Some(sample) = next.map_err(|e| BridgeError::Zenoh { what: "receive", reason: e.to_string() })? else {
                break;
            };
            n += 1;
            let bytes = sample.payload().to_bytes();
            let msg = decode::<Up>("up", &bytes);
            let claimed = match &msg {
                Ok(Up::Hello(h)) => Some(h.worker_id),
                Ok(Up::Episode(e)) => Some(e.worker_id),
                Err(_) => None,
            };
            // A remote host speaks only for the ids it was given: never for a local worker
            // (whose tasks and liveness it could otherwise disturb) nor the proxy.
            if claimed.is_some_and(|id| !self.shared.lock().expect("bridge state").is_remote_id(id)) {
                let id = claimed.unwrap_or_default();
                dropped(&mut self.stats.foreign_ids, format_args!("a message claiming worker {id}, not a remote id"));
                continue;
            }
            match msg {
                Ok(Up::Hello(h)) => self.relay_hello(h)?,
                Ok(Up::Episode(e)) => self.relay_episode(&e)?,
                Err(e) => dropped(&mut self.stats.malformed, format_args!("a malformed message: {e}")),
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

    /// Relays episode `e` to the learner if it is well-formed and was asked for.
    fn relay_episode(&mut self, e: &EpisodeMsg) -> Result<(), BridgeError> {
        let parts = e.to_parts().and_then(|p| {
            let cap = self.proxy.info().episode_cap;
            if p.0.len > cap {
                Err(BridgeError::Codec { what: "episode", reason: format!("{} steps, over the cap of {cap}", p.0.len) })
            } else {
                Ok(p)
            }
        });
        match parts {
            Err(err) => dropped(&mut self.stats.malformed, format_args!("a malformed episode: {err}")),
            // Not handed to that worker, stale, or duplicated past its budget: what the learner
            // would refuse anyway, dropped here so a flood never crowds real episodes out of the
            // learner's queue.
            Ok(_) if !self.take_copy(e) => dropped(
                &mut self.stats.unasked,
                format_args!("episode {:?} of iteration {}, not asked of worker {}", e.episode, e.k, e.worker_id),
            ),
            Ok((mut header, words)) => {
                header.run_id = run_id_bytes(self.proxy.run_id());
                self.stats.transitions += u64::from(header.len);
                self.stats.episodes += 1;
                self.proxy.publish_episode(header, &words)?;
            }
        }
        Ok(())
    }

    /// Whether episode `e` was handed to the worker it claims in the current iteration, with
    /// copies left to pass (using one).
    fn take_copy(&mut self, e: &EpisodeMsg) -> bool {
        match self.handed.get_mut(&(e.k, e.worker_id, e.episode.0, e.episode.1)) {
            Some(left) if *left > 0 => {
                *left -= 1;
                true
            }
            _ => false,
        }
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

/// Counts a message dropped from a remote host; the first of each kind is a warning, the rest
/// are counted (the result's details carry the counts) and logged at debug level.
fn dropped(count: &mut u64, what: std::fmt::Arguments<'_>) {
    if *count == 0 {
        tracing::warn!("dropping {what} from a remote host (further ones are counted in the result's details)");
    } else {
        tracing::debug!("dropping {what} from a remote host");
    }
    *count += 1;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shared() -> Shared {
        let template = JoinReply {
            protocol: PROTOCOL_VERSION,
            run_id: "r".into(),
            run: "{}".into(),
            id_base: 0,
            n_params: 1,
            episode_cap: 1,
            episodes_per_iteration: 1,
            zeta_dim: 1,
        };
        Shared { template, next_block: 1, latest: Vec::new(), hosts: 0, joins_refused: 0 }
    }

    #[test]
    fn each_host_gets_its_own_block_and_speaks_only_for_handed_blocks() {
        let mut s = shared();
        assert!(!s.is_remote_id(1000), "no host joined yet");
        assert_eq!(s.hand_out_block(3), Ok(1000));
        assert_eq!(s.hand_out_block(ID_BLOCK), Ok(2000));
        assert_eq!(s.hosts, 2);
        for (id, remote) in [(0, false), (999, false), (1000, true), (2999, true), (3000, false), (PROXY_ID, false)] {
            assert_eq!(s.is_remote_id(id), remote, "id {id}");
        }
    }

    #[test]
    fn joins_of_no_workers_too_many_or_past_the_id_space_are_refused() {
        let mut s = shared();
        assert!(s.hand_out_block(0).unwrap_err().contains("asked for 0"));
        assert!(s.hand_out_block(ID_BLOCK + 1).is_err());
        s.next_block = u32::MAX / ID_BLOCK - 1;
        assert_eq!(s.hand_out_block(1), Ok((u32::MAX / ID_BLOCK - 1) * ID_BLOCK), "the last whole block");
        assert!(s.hand_out_block(1).unwrap_err().contains("every worker id"));
        assert_eq!(s.hosts, 1, "refused joins are not hosts");
    }
}
