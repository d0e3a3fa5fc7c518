//! The learner checks every batch: wrong iteration, missing or reordered episodes and invalid
//! transitions are refused with a clear error, and nothing changes; an update that diverges is an
//! error too, not a design of NaNs handed to the workers.

mod support;

use envpg_ac::learner::{Batch, LearnerError};
use envpg_ac::rollout::run_iteration;
use envpg_core::Streams;

#[test]
fn malformed_batches_are_refused_without_side_effects() {
    let spec = support::tiny_spec(1.0, 1, 10);
    let (env, _, mut learner) = spec.start(&support::registry()).unwrap();
    let net = env.sampler();
    let sets = learner.action_sets().clone();
    let streams = Streams::new(1);
    let mut table = learner.policy_table();
    let zeta = learner.zeta().to_vec();
    let episodes = run_iteration(net, &sets, &mut table, &zeta, &spec.config, &streams, 0);
    let before = learner.state();

    let e = learner.update(&Batch { k: 3, episodes: episodes.clone() }).unwrap_err();
    assert_eq!(e, LearnerError::WrongIteration { expected: 0, got: 3 });

    let mut missing = episodes.clone();
    missing.remove(2);
    assert!(matches!(learner.update(&Batch { k: 0, episodes: missing }), Err(LearnerError::Episodes(_))));

    let mut swapped = episodes.clone();
    swapped.swap(0, 1);
    assert!(matches!(learner.update(&Batch { k: 0, episodes: swapped }), Err(LearnerError::Episodes(_))));

    let mut bad = episodes.clone();
    bad[0].a[0] = 99;
    let e = learner.update(&Batch { k: 0, episodes: bad }).unwrap_err();
    assert!(e.to_string().contains("not a valid transition"), "{e}");

    let mut nan = episodes.clone();
    nan[1].cost[0] = f32::NAN;
    assert!(matches!(learner.update(&Batch { k: 0, episodes: nan }), Err(LearnerError::Transition { .. })));

    assert_eq!(learner.state(), before, "refused batches must not change the learner");
    learner.update(&Batch { k: 0, episodes }).unwrap();
    assert_eq!(learner.k(), 1);
}

#[test]
fn a_diverged_update_is_an_error_naming_what_diverged_and_leaves_zeta_alone() {
    let spec = support::tiny_spec(1.0, 1, 10);
    let (env, _, mut learner) = spec.start(&support::registry()).unwrap();
    let net = env.sampler();
    let sets = learner.action_sets().clone();
    let mut table = learner.policy_table();
    let zeta = learner.zeta().to_vec();
    let episodes = run_iteration(net, &sets, &mut table, &zeta, &spec.config, &Streams::new(1), 0);
    // A critic whose weights have blown up (as with `critic_init=default` at κ = 0.85).
    let mut st = learner.state();
    st.critic.iter_mut().for_each(|w| *w = f32::NAN);
    learner.restore(st).unwrap();
    let e = learner.update(&Batch { k: 0, episodes }).unwrap_err();
    assert_eq!(e, LearnerError::Diverged { k: 0, what: "the critic's TD loss" });
    assert!(e.to_string().contains("diverged at iteration 0"), "{e}");
    assert_eq!(learner.zeta(), zeta.as_slice());
}
