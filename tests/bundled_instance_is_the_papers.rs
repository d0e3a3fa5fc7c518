//! The bundled default instance is the paper's network: 271 users, 5 UAVs, one destination,
//! κ = 1 and η = 100 unless overridden; the bundled copies of the two published problems are
//! the shared ones.

#[test]
fn bundled_instance_has_the_papers_shape() {
    let registry = envpg_envs::registry();
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/launch/instances/uav271.json");
    let env = registry.load(path, &[]).expect("bundled instance loads");
    assert_eq!((env.name, env.title.as_str()), ("uav", "uav271"));
    let s = env.sampler();
    assert_eq!((s.n_states(), s.n_actions(), s.zeta_dim()), (271 + 5 + 1, 6, 10));
    assert_eq!((env.param("kappa"), env.param("eta")), (Some(1.0), Some(100.0)));
    assert_eq!(registry.load("uav271", &[]).unwrap().instance, env.instance);
}

#[test]
fn the_shipped_published_instances_are_the_shared_copies() {
    for name in ["aac1800.json", "flpo-n10m4.json"] {
        let ours = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/launch/instances/").to_owned() + name);
        let shared =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/instances/").to_owned() + name);
        if let (Ok(a), Ok(b)) = (&ours, &shared) {
            assert_eq!(a, b, "{name} differs from ../shared/instances");
        }
        assert!(ours.is_ok(), "{name} is shipped in launch/instances");
    }
}
