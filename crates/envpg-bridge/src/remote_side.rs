//! [`RemoteBridge`]: a worker host's end of the bridge.
//!
//! It joins the learner host over zenoh, then creates a mirror of the run's iceoryx2
//! services under a local run id — as the learner would — so worker processes on this host
//! join it unchanged. It relays run info, weights and tasks down into the mirror, and the
//! workers' hellos and episodes up, translating worker ids between the host's local ids
//! (0, 1, …) and the global ids the learner knows (`id_base + local`).

use std::time::{Duration, Instant};

use envpg_transport::{LearnerEnd, LinkSizes, ipc};
use zenoh::Wait;
use zenoh::pubsub::Publisher;
use zenoh::query::ConsolidationMode;

use crate::BridgeError;
use crate::session::{Inbox, err, open, routes};
use crate::wire::{
    Down, EpisodeMsg, HelloMsg, JOIN_KEY, JoinReply, JoinRequest, Up, decode, down_key, encode, latest_key,
    peek_version, up_key,
};

/// How a worker host joins.
#[derive(Debug, Clone)]
pub struct RemoteConfig {
    /// The learner host's zenoh endpoint, e.g. `tcp/10.0.0.1:7447`.
    pub connect: String,
    /// This host's name, for the learner's logs.
    pub host: String,
    /// Worker processes on this host.
    pub workers: u32,
    /// How long to keep asking before giving up.
    pub join_timeout: Duration,
    /// The protocol version this host announces (normally `PROTOCOL_VERSION`).
    pub protocol: u32,
}

/// What the learner host told us.
pub type Joined = JoinReply;

/// A worker host's end of the bridge.
pub struct RemoteBridge {
    cfg: RemoteConfig,
    reply: JoinReply,
    down: Inbox,
    up: Publisher<'static>,
    session: zenoh::Session,
    mirror: Option<LearnerEnd<ipc::Service>>,
    weights_k: Option<u64>,
    finished: bool,
    received: u64,
    episodes_sent: u64,
    last_down: Instant,
    link_lost: bool,
}

/// After this long without a message from the learner host, ask it for the latest run info
/// and weights: it recovers messages lost with a broken link (the end of the run among
/// them), and a live learner's answer tells this host the link is alive.
const RESYNC_WHEN_SILENT: Duration = Duration::from_secs(1);

impl std::fmt::Debug for RemoteBridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemoteBridge").field("reply", &self.reply).field("finished", &self.finished).finish()
    }
}

impl RemoteBridge {
    /// Connects and joins the run, asking until `join_timeout`.
    pub fn join(cfg: &RemoteConfig) -> Result<Self, BridgeError> {
        let session = open(None, Some(&cfg.connect))?;
        let request = encode(
            "join request",
            &JoinRequest { protocol: cfg.protocol, host: cfg.host.clone(), workers: cfg.workers },
        )?;
        let start = Instant::now();
        let reply = loop {
            let replies = session
                .get(JOIN_KEY)
                .payload(request.clone())
                .timeout(Duration::from_secs(1))
                .wait()
                .map_err(err("join request"))?;
            // The first answer decides (one learner listens at an endpoint).
            if let Ok(r) = replies.recv() {
                match r.result() {
                    Ok(sample) => {
                        let bytes = sample.payload().to_bytes();
                        let v = peek_version(&bytes)?;
                        if v != cfg.protocol {
                            return Err(BridgeError::Version { learner: v, remote: cfg.protocol });
                        }
                        break decode::<JoinReply>("join reply", &bytes)?;
                    }
                    Err(e) => {
                        return Err(BridgeError::Refused(
                            String::from_utf8_lossy(&e.payload().to_bytes()).into_owned(),
                        ));
                    }
                }
            }
            if start.elapsed() > cfg.join_timeout {
                return Err(BridgeError::NoLearner {
                    endpoint: cfg.connect.clone(),
                    seconds: start.elapsed().as_secs_f64(),
                });
            }
            std::thread::sleep(Duration::from_millis(200));
        };
        let (up, down) = routes(&session, up_key(&reply.run_id), down_key(&reply.run_id))?;
        Ok(Self {
            cfg: cfg.clone(),
            reply,
            down,
            up,
            session,
            mirror: None,
            weights_k: None,
            finished: false,
            received: 0,
            episodes_sent: 0,
            last_down: Instant::now(),
            link_lost: false,
        })
    }

    /// The learner host's answer (run description, id base, sizes).
    pub fn joined(&self) -> &Joined {
        &self.reply
    }

    /// Creates the local mirror of the run's services under `local_run_id` and fetches the
    /// current run info and weights.
    pub fn start(&mut self, local_run_id: &str) -> Result<(), BridgeError> {
        let r = &self.reply;
        let sizes = LinkSizes {
            max_workers: self.cfg.workers as usize,
            n_params: r.n_params as usize,
            episode_cap: r.episode_cap as usize,
            episodes_per_iteration: r.episodes_per_iteration as usize,
        };
        let mirror = LearnerEnd::<ipc::Service>::create(local_run_id, sizes)?;
        mirror.announce(r.zeta_dim as usize, false)?;
        self.mirror = Some(mirror);
        self.resync()?;
        Ok(())
    }

    /// The mirror's node (termination requests).
    pub fn node(&self) -> Option<&iceoryx2::prelude::Node<ipc::Service>> {
        self.mirror.as_ref().map(|m| m.node())
    }

    /// Episodes of this host's workers sent to the learner host so far.
    pub fn episodes_sent(&self) -> u64 {
        self.episodes_sent
    }

    /// Messages received from the learner host so far (a liveness signal).
    pub fn received(&self) -> u64 {
        self.received
    }

    /// Whether the learner has announced the end of the run.
    pub fn finished(&self) -> bool {
        self.finished
    }

    /// Sends `bytes` to the learner host as they are, bypassing the mirror: what a broken or
    /// hostile host could send. For diagnostics and for testing what a learner host refuses;
    /// a worker host never needs it.
    pub fn send_raw(&self, bytes: Vec<u8>) -> Result<(), BridgeError> {
        self.up.put(bytes).wait().map_err(err("put"))
    }

    /// The next message from the learner host, waiting up to `wait`, taken off the bridge
    /// rather than relayed (a joined host that never calls [`start`](Self::start) watches the
    /// run this way). Malformed messages are skipped.
    pub fn recv_raw(&self, wait: Duration) -> Result<Option<Down>, BridgeError> {
        let deadline = Instant::now() + wait;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let next = self
                .down
                .recv_timeout(left)
                .map_err(|e| BridgeError::Zenoh { what: "receive", reason: e.to_string() })?;
            match next.map(|sample| decode::<Down>("down", &sample.payload().to_bytes())) {
                None => return Ok(None),
                Some(Ok(m)) => return Ok(Some(m)),
                Some(Err(_)) if left.is_zero() => return Ok(None),
                Some(Err(_)) => {}
            }
        }
    }

    fn resync(&mut self) -> Result<(), BridgeError> {
        let replies = self
            .session
            .get(latest_key(&self.reply.run_id))
            // Info and weights share a key: keep both replies.
            .consolidation(ConsolidationMode::None)
            .timeout(Duration::from_secs(2))
            .wait()
            .map_err(err("resync request"))?;
        let mut msgs = Vec::new();
        while let Ok(r) = replies.recv() {
            if let Ok(sample) = r.result() {
                self.received += 1;
                match decode::<Down>("down", &sample.payload().to_bytes()) {
                    Ok(m) => msgs.push(m),
                    Err(e) => tracing::warn!("dropping a malformed resync answer: {e}"),
                }
            }
        }
        self.last_down = Instant::now();
        tracing::debug!("resync: {} message(s) from the learner host", msgs.len());
        if msgs.is_empty() {
            if !self.link_lost {
                tracing::warn!("the learner host does not answer; waiting for the link to come back");
            }
            self.link_lost = true;
        } else if self.link_lost || !self.up_matches()? {
            // The learner host answers, but after a break of the link (noticed, or missed while
            // a put was blocked) zenoh's reconnected session does not always bring back the
            // routes of declarations made before it (seen with zenoh 1.10 peers): the learner's
            // subscriber no longer matches our publisher. Declare ours anew.
            self.link_lost = false;
            self.redeclare()?;
        }
        for m in msgs {
            self.apply(m, false)?;
        }
        Ok(())
    }

    fn up_matches(&self) -> Result<bool, BridgeError> {
        Ok(self.up.matching_status().wait().map_err(err("matching status"))?.matching())
    }

    fn redeclare(&mut self) -> Result<(), BridgeError> {
        // A warning like the loss it ends, so a user sees both.
        tracing::warn!("link to the learner host restored; declaring the bridge's routes anew");
        (self.up, self.down) = routes(&self.session, up_key(&self.reply.run_id), down_key(&self.reply.run_id))?;
        Ok(())
    }

    fn apply(&mut self, msg: Down, may_resync: bool) -> Result<(), BridgeError> {
        match msg {
            Down::Info(i) => {
                self.finished = i.finished;
                self.mirror().announce(i.zeta_dim as usize, i.finished)?;
            }
            Down::Weights(w) => {
                if self.weights_k.is_none_or(|k| w.k > k) {
                    self.mirror().publish_weights(w.k, w.alpha, &w.zeta, &w.params)?;
                    self.weights_k = Some(w.k);
                }
            }
            Down::Tasks(t) => {
                let base = self.reply.id_base;
                if t.worker_id < base || t.worker_id >= base + self.cfg.workers {
                    return Ok(());
                }
                // Weights lost with a broken link would leave the workers waiting: fetch them.
                if may_resync && self.weights_k.is_none_or(|k| k < t.k) {
                    self.resync()?;
                }
                self.mirror().assign(t.worker_id - base, t.incarnation, t.k, &t.ids())?;
            }
        }
        Ok(())
    }

    fn mirror(&self) -> &LearnerEnd<ipc::Service> {
        self.mirror.as_ref().expect("start() creates the mirror")
    }

    /// One round of relaying in both directions, waiting up to `wait` for the learner's
    /// messages when there is nothing else to do.
    pub fn pump(&mut self, wait: Duration) -> Result<(), BridgeError> {
        let base = self.reply.id_base;
        let workers = self.cfg.workers;
        // Local workers → learner.
        let mut up = Vec::new();
        let mut episodes = 0;
        {
            let m = self.mirror();
            m.refresh();
            for h in m.receive_hellos()? {
                if h.worker_id < workers {
                    up.push(encode("up", &Up::Hello(HelloMsg::from_hello(&h, base + h.worker_id)))?);
                }
            }
            let mut bad = None;
            m.receive_episodes(|h, words| {
                if h.worker_id < workers {
                    match encode("up", &Up::Episode(EpisodeMsg::from_parts(h, words, base + h.worker_id))) {
                        Ok(b) => {
                            up.push(b);
                            episodes += 1;
                        }
                        Err(e) => bad = Some(e),
                    }
                }
            })?;
            if let Some(e) = bad {
                return Err(e);
            }
            m.drain_wakeups();
        }
        let moved = !up.is_empty();
        for b in up {
            self.up.put(b).wait().map_err(err("put"))?;
        }
        self.episodes_sent += episodes;
        // Learner → local workers.
        let mut n = 0;
        loop {
            let next = if n == 0 && !moved { self.down.recv_timeout(wait) } else { self.down.try_recv() };
            let Some(sample) = next.map_err(|e| BridgeError::Zenoh { what: "receive", reason: e.to_string() })? else {
                break;
            };
            n += 1;
            self.received += 1;
            match decode::<Down>("down", &sample.payload().to_bytes()) {
                Ok(msg) => self.apply(msg, true)?,
                Err(e) => tracing::warn!("dropping a malformed message from the learner host: {e}"),
            }
            if n >= 512 {
                break;
            }
        }
        if n > 0 {
            self.last_down = Instant::now();
        } else if self.last_down.elapsed() > RESYNC_WHEN_SILENT {
            self.resync()?;
            n = 1;
        }
        if n > 0 {
            self.mirror().notify_workers()?;
        }
        Ok(())
    }
}
