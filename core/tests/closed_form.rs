//! The solver against closed-form mechanics: a spring's oscillation, a hanging chain's
//! static sag (linear and bilinear), symplectic Euler's bounded energy error, and the
//! convergence orders of the integrators.

use lamina_core::law::{Bilinear, SpringLaw};
use lamina_core::model::{Layer, Model, NodeKind, Tissue};
use lamina_core::solver::{Effects, IntegrationParameters, IntegratorKind, Simulation, Substeps};

const G: f64 = 9.81;

/// Node 0 fixed at the origin, node 1 free at `(rest + stretch, 0, 0)`.
fn one_spring(mass: f64, k: f64, c: f64, rest: f64, stretch: f64) -> Model {
    let mut m = Model::default();
    m.layers.push(Layer { name: "test".into(), tissue: Tissue::Other });
    m.nodes.push([0.0; 3], 1.0, NodeKind::Fixed, 0);
    m.nodes.push([rest + stretch, 0.0, 0.0], mass, NodeKind::Free, 0);
    m.springs.push(0, 1, rest, SpringLaw::Linear { stiffness: k }, c, 0);
    m
}

fn params(integrator: IntegratorKind, dt: f64, substeps: u32) -> IntegrationParameters {
    IntegrationParameters {
        dt,
        integrator,
        substeps: Substeps::Fixed(substeps),
        cg_tolerance: 1e-12,
        cg_max_iterations: 500,
        ..IntegrationParameters::default()
    }
}

fn held(spring_damping: bool) -> Effects {
    Effects { bone: true, spring_damping, ..Effects::default() }
}

/// The model's node 1 starts `stretch` from rest; returns x(t) − rest for t at every step.
fn trajectory(model: &Model, p: IntegrationParameters, e: Effects, steps: usize) -> Vec<(f64, f64)> {
    let rest = model.springs.rest_length[0];
    let mut sim = Simulation::<f64>::new(model, p, e).unwrap();
    let mut out = Vec::with_capacity(steps);
    for _ in 0..steps {
        sim.step();
        out.push((sim.state().time, sim.state().x.get_f64(1)[0] - rest));
    }
    out
}

#[test]
fn single_spring_period_and_amplitude_match_closed_form_works() {
    let (m, k, a): (f64, f64, f64) = (0.1, 40.0, 0.01);
    let omega = (k / m).sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    for integrator in [IntegratorKind::SymplecticEuler, IntegratorKind::Rk4] {
        let traj = trajectory(&one_spring(m, k, 0.0, 0.05, a), params(integrator, 1e-4, 1), held(false), 20_000);
        // Upward zero crossings, interpolated.
        let mut crossings = Vec::new();
        for w in traj.windows(2) {
            let ((t0, x0), (t1, x1)) = (w[0], w[1]);
            if x0 < 0.0 && x1 >= 0.0 {
                crossings.push(t0 + (t1 - t0) * (-x0) / (x1 - x0));
            }
        }
        assert!(crossings.len() >= 5);
        let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        assert!((measured - period).abs() / period < 1e-4, "{integrator}: period {measured} vs {period}");
        let amplitude = traj.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
        // Symplectic Euler's shadow orbit is off by about omega*dt/2 = 1e-3 relative.
        assert!((amplitude - a).abs() / a < 2e-3, "{integrator}: amplitude {amplitude} vs {a}");
    }
}

/// A vertical chain of `n` masses hung from a fixed node at the origin.
fn chain(n: usize, mass: f64, rest: f64, law: SpringLaw) -> Model {
    let mut m = Model::default();
    m.layers.push(Layer { name: "chain".into(), tissue: Tissue::Other });
    m.nodes.push([0.0; 3], mass, NodeKind::Fixed, 0);
    for i in 1..=n {
        m.nodes.push([0.0, -(i as f64) * rest, 0.0], mass, NodeKind::Free, 0);
        m.springs.push((i - 1) as u32, i as u32, rest, law, 0.0, 0);
    }
    m
}

/// Static positions: spring j (1-based from the top) carries (n − j + 1)·m·g.
fn chain_static(n: usize, mass: f64, rest: f64, law: &SpringLaw) -> Vec<f64> {
    let mut y = 0.0;
    let mut out = vec![0.0];
    for j in 1..=n {
        let tension = (n - j + 1) as f64 * mass * G;
        let stretch = match law {
            SpringLaw::Linear { stiffness } => tension / stiffness,
            SpringLaw::Bilinear(b) => {
                let turn = b.turn_length - rest;
                if tension <= b.k1 * turn { tension / b.k1 } else { turn + (tension - b.k1 * turn) / b.k2 }
            }
        };
        y -= rest + stretch;
        out.push(y);
    }
    out
}

#[test]
fn hanging_chain_sag_matches_analytic_solution_works() {
    let (n, mass, rest) = (10, 0.01, 0.02);
    let laws = [
        SpringLaw::Linear { stiffness: 50.0 },
        // Turning tension k1*(Lt-L0) = 20*0.01 = 0.2 N: the top five springs (0.49..0.98 N... above it) are in phase 2.
        SpringLaw::Bilinear(Bilinear { k1: 20.0, k2: 400.0, turn_length: rest + 0.01, k_compression: 20.0 }),
    ];
    for law in laws {
        let model = chain(n, mass, rest, law);
        let expect = chain_static(n, mass, rest, &law);
        let effects =
            Effects { gravity: Some([0.0, -G, 0.0]), viscous_damping: Some(20.0), bone: true, ..Effects::default() };
        let mut sim = Simulation::<f64>::new(&model, params(IntegratorKind::ImplicitEuler, 0.01, 1), effects).unwrap();
        for _ in 0..3000 {
            sim.step();
        }
        for i in 0..=n {
            let y = sim.state().x.get_f64(i)[1];
            assert!((y - expect[i]).abs() < 1e-9, "{} node {i}: {y} vs {}", law.kind_name(), expect[i]);
        }
    }
}

fn energy(model: &Model, sim: &Simulation<f64>, gravity: f64) -> f64 {
    let s = sim.state();
    let mut e = 0.0;
    for i in 0..model.nodes.len() {
        let (v, x) = (s.v.get_f64(i), s.x.get_f64(i));
        e += 0.5 * model.nodes.mass[i] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if model.nodes.kind[i] == NodeKind::Free {
            e += model.nodes.mass[i] * gravity * x[1];
        }
    }
    for j in 0..model.springs.len() {
        let (a, b) = (s.x.get_f64(model.springs.a[j] as usize), s.x.get_f64(model.springs.b[j] as usize));
        let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        let SpringLaw::Linear { stiffness } = model.springs.law[j] else { unreachable!() };
        e += 0.5 * stiffness * (l - model.springs.rest_length[j]).powi(2);
    }
    e
}

#[test]
fn symplectic_euler_energy_error_stays_bounded_works() {
    // A swinging three-mass chain: nonlinear, gravity, no damping; 10^5 steps.
    let mut model = chain(3, 0.05, 0.1, SpringLaw::Linear { stiffness: 200.0 });
    for i in 1..=3 {
        model.nodes.position[i] = [0.1 * i as f64, -0.02 * i as f64, 0.0];
    }
    let effects = Effects { gravity: Some([0.0, -G, 0.0]), bone: true, ..Effects::default() };
    let mut sim = Simulation::<f64>::new(&model, params(IntegratorKind::SymplecticEuler, 1e-4, 1), effects).unwrap();
    let e0 = energy(&model, &sim, G);
    let mut first = 0.0;
    let mut last = 0.0;
    let mut worst: f64 = 0.0;
    let steps = 100_000;
    let window = 10_000;
    // Energy scale: the initial potential energy relative to the hanging rest state.
    let scale = e0.abs().max(1e-3);
    for k in 0..steps {
        sim.step();
        let e = energy(&model, &sim, G);
        worst = worst.max((e - e0).abs());
        if k < window {
            first += e / window as f64;
        }
        if k >= steps - window {
            last += e / window as f64;
        }
    }
    // Symplectic Euler conserves a shadow energy that differs from the true one by O(h·ω):
    // the error oscillates within that band and does not grow.
    let band = 2.0 * 1e-4 * sim.stability().omega_max;
    assert!(worst / scale < band, "energy error {worst} vs scale {scale}, band {band}");
    assert!((last - first).abs() / scale < 5e-4, "secular drift {} (first {first}, last {last})", last - first);
}

/// Observed order from errors at steps dt, dt/2, dt/4.
fn observed_order(errors: &[f64]) -> f64 {
    ((errors[0] / errors[1]).log2() + (errors[1] / errors[2]).log2()) / 2.0
}

#[test]
fn integrators_converge_at_their_theoretical_order_works() {
    // Damped oscillator m x'' = −k x − c x', x(0) = A, v(0) = 0: closed form at t = 0.5 s.
    let (m, k, c, a, t_end): (f64, f64, f64, f64, f64) = (0.1, 40.0, 0.4, 0.01, 0.5);
    let omega = (k / m).sqrt();
    let gamma = c / (2.0 * m);
    let wd = (omega * omega - gamma * gamma).sqrt();
    let exact = a * (-gamma * t_end).exp() * ((wd * t_end).cos() + gamma / wd * (wd * t_end).sin());
    for (integrator, dt0) in [
        (IntegratorKind::SymplecticEuler, 2e-3f64),
        (IntegratorKind::VelocityVerlet, 2e-3),
        (IntegratorKind::ImplicitEuler, 2e-3),
        (IntegratorKind::Rk4, 2e-2),
    ] {
        let errors: Vec<f64> = [1u32, 2, 4]
            .iter()
            .map(|&sub| {
                let steps = (t_end / dt0).round() as usize;
                let traj = trajectory(&one_spring(m, k, c, 0.05, a), params(integrator, dt0, sub), held(true), steps);
                (traj.last().unwrap().1 - exact).abs()
            })
            .collect();
        let order = observed_order(&errors);
        let want = integrator.order() as f64;
        assert!((order - want).abs() < 0.3 * want, "{integrator}: errors {errors:?}, order {order}, want {want}");
        assert!(errors[2] < errors[0], "{integrator} converges");
    }
}
