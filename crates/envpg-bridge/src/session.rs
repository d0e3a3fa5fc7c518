//! Opening zenoh sessions the way both sides of the bridge need them.

use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::Sample;
use zenoh::{Config, Session, Wait};

use crate::BridgeError;

fn zerr(what: &'static str) -> impl FnOnce(zenoh::Error) -> BridgeError {
    move |e| BridgeError::Zenoh { what, reason: e.to_string() }
}

/// A peer session listening on `listen` and/or connecting to `connect` (zenoh endpoints such
/// as `tcp/10.0.0.1:7447`), with multicast scouting off so only the given endpoints are
/// used. A connecting peer keeps retrying in the background, also after a link loss.
pub(crate) fn open(listen: Option<&str>, connect: Option<&str>) -> Result<Session, BridgeError> {
    let mut c = Config::default();
    let mut set = |key: &str, value: String| {
        c.insert_json5(key, &value)
            .map_err(|e| BridgeError::Zenoh { what: "configuration", reason: format!("{key}: {e}") })
    };
    set("mode", "\"peer\"".into())?;
    set("scouting/multicast/enabled", "false".into())?;
    // A link silent for 3 s is declared dead (zenoh's default is 10 s): the other side then
    // resyncs sooner, and the learner's own worker timeout stays the slower, deciding one.
    set("transport/link/tx/lease", "3000".into())?;
    if let Some(l) = listen {
        set("listen/endpoints", format!("[{}]", serde_json::to_string(l).expect("string")))?;
    }
    if let Some(e) = connect {
        set("connect/endpoints", format!("[{}]", serde_json::to_string(e).expect("string")))?;
    }
    zenoh::open(c).wait().map_err(zerr("session"))
}

/// Maps a zenoh error of operation `what`.
pub(crate) fn err(what: &'static str) -> impl FnOnce(zenoh::Error) -> BridgeError {
    zerr(what)
}

/// A subscriber whose samples queue up until read.
pub(crate) type Inbox = Subscriber<FifoChannelHandler<Sample>>;

/// Declares a bridge end's routes: a subscriber on `inbound` (first, so nothing published
/// meanwhile is missed when routes are declared anew) and a publisher on `outbound` with
/// blocking congestion control, so backpressure reaches the sender.
pub(crate) fn routes(
    session: &Session,
    outbound: String,
    inbound: String,
) -> Result<(Publisher<'static>, Inbox), BridgeError> {
    let sub = session.declare_subscriber(inbound).wait().map_err(err("subscriber"))?;
    let publisher = session
        .declare_publisher(outbound)
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(err("publisher"))?;
    Ok((publisher, sub))
}
