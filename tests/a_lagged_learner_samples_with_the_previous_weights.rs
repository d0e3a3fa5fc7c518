//! With a policy lag (`AcConfig::lag` = 1) the batch of iteration k + 1 is sampled with the
//! weights, design and temperature the update of batch k started from; the learner keeps them
//! in its state, so a checkpoint carries them, and a state of the other kind is refused.

mod support;

use envpg_ac::learner::Batch;
use envpg_ac::rollout::run_iteration;
use envpg_core::Streams;

#[test]
fn batch_k_plus_one_is_sampled_with_the_weights_update_k_started_from() {
    let mut spec = support::tiny_spec(0.9, 4, 10);
    spec.config.lag = 1;
    spec.config.warmup = 0;
    let (env, _, mut learner) = spec.start(&support::registry()).unwrap();
    let (net, sets, streams) = (env.sampler(), learner.action_sets().clone(), Streams::new(4));
    let b = learner.behaviour();
    assert_eq!((b.actor, b.zeta, b.alpha), (learner.actor().params(), learner.zeta(), learner.alpha()));
    for k in 0..3 {
        let before = learner.state();
        let mut table = learner.behaviour_table();
        let zeta = learner.behaviour().zeta.to_vec();
        let episodes = run_iteration(net, &sets, &mut table, &zeta, learner.config(), &streams, k);
        learner.update(&Batch { k, episodes }).unwrap();
        let b = learner.behaviour();
        assert_eq!(b.actor, &before.actor[..], "iteration {k}: θ");
        assert_eq!((b.zeta, b.alpha), (&before.zeta[..], before.alpha), "iteration {k}: ζ, α");
        assert_ne!(learner.actor().params(), b.actor, "iteration {k}: the update moved θ");
        // The table the next batch is sampled from is the behaviour weights' policy.
        let lagged = learner.behaviour_table().full().to_vec();
        assert_ne!(lagged, learner.policy_table().full().to_vec(), "iteration {k}");
    }
    assert_ne!(learner.zeta(), learner.behaviour().zeta, "ζ moved after the warm-up");

    // A checkpointed lagged state restores exactly, and only into a lagged learner.
    let st = learner.state();
    assert!(st.lagged.is_some());
    // Checkpoints serialise the state borrowed: the same bytes as the copy.
    let bytes = postcard::to_stdvec(&st).unwrap();
    assert_eq!(postcard::to_stdvec(&learner.state_ref()).unwrap(), bytes);
    let (_, _, mut again) = spec.start(&support::registry()).unwrap();
    again.restore(st.clone()).unwrap();
    assert_eq!(again.state(), st);
    let mut unlagged = spec.clone();
    unlagged.config.lag = 0;
    let (_, _, mut other) = unlagged.start(&support::registry()).unwrap();
    assert_eq!(postcard::to_stdvec(&other.state_ref()).unwrap(), postcard::to_stdvec(&other.state()).unwrap());
    let e = other.restore(st).unwrap_err();
    assert!(e.contains("policy lag"), "{e}");
}
