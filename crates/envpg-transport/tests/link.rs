//! The two ends of the link talk — join, weights, tasks, episodes, end of run — over the
//! process-local service and over shared memory, with the worker joining after the learner.

use std::time::{Duration, Instant};

use envpg_protocol::{
    EpisodeHeader, EpisodeId, PROTOCOL_VERSION, Step, hello_kind, run_id_bytes, step_words, write_step,
};
use envpg_transport::{LearnerEnd, LinkSizes, TransportError, WorkerEnd, ipc, local};
use iceoryx2::prelude::*;

fn sizes() -> LinkSizes {
    LinkSizes { max_workers: 2, n_params: 5, episode_cap: 4, episodes_per_iteration: 3 }
}

const IDS: [EpisodeId; 2] = [EpisodeId { kind: 0, index: 0 }, EpisodeId { kind: 1, index: 2 }];

/// Two steps (1, 2, 3, 4.5) at ζ_pert = (0.25, 0.25), as an episode message's words.
fn two_steps() -> Vec<u32> {
    let mut words = vec![0u32; 2 * step_words(2)];
    for rec in words.chunks_exact_mut(step_words(2)) {
        write_step(rec, Step { s: 1, a: 2, s2: 3, cost: 4.5 }, &[0.25, 0.25]);
    }
    words
}

/// Polls `f` until it returns `Some`, failing after a watchdog timeout.
fn until<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let start = Instant::now();
    loop {
        if let Some(t) = f() {
            return t;
        }
        assert!(start.elapsed() < Duration::from_secs(10), "watchdog: {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn worker_side<S: Service>(run_id: &str) {
    let worker = WorkerEnd::<S>::open(run_id, 0, PROTOCOL_VERSION, Duration::from_secs(5)).unwrap();
    assert_eq!(worker.info().n_params, 5);
    worker.say(hello_kind::JOIN, 0, 7).unwrap();
    let (h, w) = until("weights", || worker.latest_weights().unwrap());
    assert_eq!((h.k, h.alpha, h.zeta_dim, &h.zeta[..2]), (3, 0.5, 2, &[1.0, 2.0][..]));
    assert_eq!(w, vec![0.1, 0.2, 0.3, 0.4, 0.5]);
    let tasks = until("tasks", || Some(worker.take_tasks().unwrap()).filter(|t| !t.is_empty()));
    assert_eq!((tasks[0].0.k, tasks[0].0.incarnation), (3, 7));
    assert_eq!(tasks[0].1, IDS.to_vec());
    let header = EpisodeHeader {
        protocol: PROTOCOL_VERSION,
        worker_id: 0,
        run_id: run_id_bytes(run_id),
        k: 3,
        episode: IDS[1],
        seq: 0,
        len: 2,
        capped: 0,
        zeta_dim: 2,
        _pad: 0,
    };
    worker.publish_episode(header, &two_steps()).unwrap();
    // Nothing larger than the run's episodes fits its messages.
    let too_long = vec![0u32; 5 * step_words(2)];
    assert!(matches!(worker.publish_episode(header, &too_long), Err(TransportError::Malformed { .. })));
    worker.notify_learner().unwrap();
    until("end of run", || worker.run_finished().unwrap().then_some(()));
}

fn round_trip<S: Service>(run_id: &str) {
    let learner = LearnerEnd::<S>::create(run_id, sizes()).unwrap();
    learner.announce(2, false).unwrap();
    std::thread::scope(|scope| {
        let w = scope.spawn(|| worker_side::<S>(run_id));
        // The worker joins after the run info was published: refresh delivers it.
        let hello = until("hello", || {
            learner.refresh();
            learner.receive_hellos().unwrap().pop()
        });
        assert_eq!((hello.kind, hello.worker_id, hello.incarnation), (hello_kind::JOIN, 0, 7));
        learner.publish_weights(3, 0.5, &[1.0, 2.0], &[0.1, 0.2, 0.3, 0.4, 0.5]).unwrap();
        learner.assign(0, 7, 3, &IDS).unwrap();
        learner.notify_workers().unwrap();
        let mut got = Vec::new();
        until("episode", || {
            learner.receive_episodes(|h, r| got.push((*h, r.to_vec()))).unwrap();
            (!got.is_empty()).then_some(())
        });
        assert_eq!(got[0].0.episode, IDS[1]);
        assert_eq!(got[0].1, two_steps());
        learner.announce(2, true).unwrap();
        w.join().unwrap();
    });
}

#[test]
fn local_link_round_trip() {
    round_trip::<local::Service>("linktestlocal");
}

#[test]
fn ipc_link_round_trip() {
    round_trip::<ipc::Service>(&format!("linkipc{}", std::process::id()));
}

#[test]
fn a_worker_of_another_protocol_version_is_refused_with_both_versions() {
    let run_id = format!("linkver{}", std::process::id());
    let learner = LearnerEnd::<ipc::Service>::create(&run_id, sizes()).unwrap();
    learner.announce(2, false).unwrap();
    std::thread::scope(|scope| {
        let w = scope.spawn(|| {
            WorkerEnd::<ipc::Service>::open(&run_id, 4, PROTOCOL_VERSION + 1, Duration::from_secs(5)).map(|_| ())
        });
        let refusal = until("refusal", || {
            learner.refresh();
            learner.receive_hellos().unwrap().pop()
        });
        assert_eq!((refusal.kind, refusal.worker_id, refusal.protocol), (hello_kind::REFUSE, 4, PROTOCOL_VERSION + 1));
        match w.join().unwrap() {
            Err(e @ TransportError::Version { .. }) => {
                let msg = e.to_string();
                assert!(
                    msg.contains(&format!("version {PROTOCOL_VERSION}"))
                        && msg.contains(&format!("version {}", PROTOCOL_VERSION + 1)),
                    "{msg}"
                );
            }
            other => panic!("expected a version error, got {other:?}"),
        }
    });
}

#[test]
fn a_payload_of_the_wrong_type_cannot_join_the_episode_service() {
    let run_id = format!("linktype{}", std::process::id());
    let names = envpg_protocol::ServiceNames::new(&run_id);
    let learner = LearnerEnd::<ipc::Service>::create(&run_id, sizes()).unwrap();
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let rogue = node
        .service_builder(&ServiceName::new(&names.episodes()).unwrap())
        .publish_subscribe::<[u64]>()
        .user_header::<EpisodeHeader>()
        .open();
    let err = format!("{:?}", rogue.map(|_| ()).expect_err("a payload of another type must be refused"));
    assert!(err.contains("Incompatible"), "{err}");
    // The learner's side is unaffected.
    assert_eq!(learner.receive_episodes(|_, _| {}).unwrap(), 0);
}

#[test]
fn a_worker_joining_a_run_that_is_over_leaves_at_once() {
    // No learner at all: asked to stop waiting, the worker leaves at once instead of waiting
    // out its join timeout (an in-process run whose learner already returned): the timeout
    // would have been `NoLearner`.
    let r = WorkerEnd::<local::Service>::open_while(
        "linkover1",
        0,
        PROTOCOL_VERSION,
        Duration::from_secs(30),
        &|| false,
        iceoryx2::prelude::SignalHandlingMode::HandleTerminationRequests,
    );
    assert!(matches!(r, Err(TransportError::RunOver { .. })), "{:?}", r.err());
    // Without that, a missing learner is an error after the timeout.
    let r = WorkerEnd::<local::Service>::open("linkover2", 0, PROTOCOL_VERSION, Duration::from_millis(50));
    assert!(matches!(r, Err(TransportError::NoLearner { .. })), "{:?}", r.err());
    // A learner that announced the end of its run: a late worker learns it from the run info.
    let run_id = format!("linkover3{}", std::process::id());
    let learner = LearnerEnd::<ipc::Service>::create(&run_id, sizes()).unwrap();
    learner.announce(2, true).unwrap();
    std::thread::scope(|scope| {
        let w = scope.spawn(|| {
            WorkerEnd::<ipc::Service>::open(&run_id, 0, PROTOCOL_VERSION, Duration::from_secs(5)).map(|_| ())
        });
        // The learner's loop delivers the run info's history to new subscribers.
        while !w.is_finished() {
            learner.refresh();
            std::thread::sleep(Duration::from_millis(2));
        }
        let r = w.join().unwrap();
        assert!(matches!(r, Err(TransportError::RunOver { .. })), "{r:?}");
    });
}
