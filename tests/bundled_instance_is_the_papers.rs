//! The bundled default instance is the paper's network: 271 users, 5 UAVs, one destination.

use envpg_core::Instance;

#[test]
fn bundled_instance_has_the_papers_shape() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/launch/instances/uav271.json");
    let inst = Instance::load(path).expect("bundled instance loads");
    assert_eq!(inst.name, "uav271");
    assert_eq!(inst.n_users(), 271);
    assert_eq!(inst.n_uav, 5);
    assert_eq!(inst.zeta_dim(), 10);
}
