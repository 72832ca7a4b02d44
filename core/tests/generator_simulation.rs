//! A generated limb simulates: it sags under gravity and stays bounded.

use lamina_core::generator::{CylinderLimb, Materials, generate};
use lamina_core::solver::{Effects, IntegrationParameters, Simulation};

#[test]
fn generator_limb_sags_under_gravity_works() {
    // The default materials are set for the paper's 39 × 10 limb (its Table 1); on coarser
    // grids the same per-spring stiffness makes a softer limb (the paper's Table 2).
    let model = generate(&CylinderLimb::default(), &Materials::default()).unwrap();
    let effects = Effects {
        gravity: Some([0.0, -9.81, 0.0]),
        spring_damping: true,
        bone: true,
        viscous_damping: Some(5.0),
        ..Default::default()
    };
    let mut sim = Simulation::<f64>::new(&model, IntegrationParameters::default(), effects).unwrap();
    println!("sub-steps per frame: {}", sim.substeps());
    for _ in 0..500 {
        sim.step();
    }
    let state = sim.state();
    let n = model.nodes.len();
    let (mut sum_dy, mut max_d) = (0.0, 0.0f64);
    for i in 0..n {
        let p = state.x.get_f64(i);
        assert!(p.iter().all(|c| c.is_finite()), "node {i} not finite");
        let r = model.nodes.position[i];
        let d = [p[0] - r[0], p[1] - r[1], p[2] - r[2]];
        sum_dy += d[1];
        max_d = max_d.max((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
    }
    let mean_dy = sum_dy / n as f64;
    println!("after 0.5 s: mean y displacement {:.3} mm, max displacement {:.3} mm", mean_dy * 1e3, max_d * 1e3);
    assert!(mean_dy < 0.0, "the limb should sag: mean dy {mean_dy}");
    assert!(max_d < 0.01, "max displacement {max_d} m");
}
