//! The yardstick scene stepped by Lamina's solver agrees with the specification's plain
//! scalar loop, at every instruction-set level and thread count.

use lamina_core::solver::{SimdLevel, Simulation};
use lamina_core::yardstick::{self, LatticeSize, ReferenceStepper};

fn lamina_checksum<T: lamina_core::real::Real>(
    size: LatticeSize,
    steps: usize,
    threads: usize,
    level: SimdLevel,
) -> yardstick::Checksum {
    let model = yardstick::lattice_model(size);
    let mut sim =
        Simulation::<T>::new(&model, yardstick::lattice_params(threads, level), yardstick::lattice_effects()).unwrap();
    for _ in 0..steps {
        sim.step();
    }
    yardstick::checksum(&model, |i| sim.state().x.get_f64(i))
}

#[test]
fn yardstick_lamina_matches_reference_loop_works() {
    let size = LatticeSize::SMALL;
    let model = yardstick::lattice_model(size);
    let mut reference = ReferenceStepper::<f64>::new(&model, yardstick::run_gravity(), 1e-4).unwrap();
    for _ in 0..1000 {
        reference.step();
    }
    let want = yardstick::checksum(&model, |i| reference.x[i]);
    assert!(want.sum_uy < 0.0, "the block sags under gravity");
    for level in SimdLevel::available() {
        for threads in [1, 2] {
            let got = lamina_checksum::<f64>(size, 1000, threads, level);
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
            assert!(rel(got.sum_uy, want.sum_uy) < 1e-9, "{level} x{threads}: {got:?} vs {want:?}");
            assert!(rel(got.max_u, want.max_u) < 1e-9);
            assert!(rel(got.rms_u, want.rms_u) < 1e-9);
            let got32 = lamina_checksum::<f32>(size, 1000, threads, level);
            assert!(rel(got32.sum_uy, want.sum_uy) < 1e-3, "f32 {level} x{threads}: {got32:?} vs {want:?}");
            assert!(rel(got32.max_u, want.max_u) < 1e-3);
        }
    }
    // Mirror symmetry in x and z: the sums vanish up to round-off.
    assert!(want.sum_ux.abs() < 1e-9 * want.sum_uy.abs() * 1e3);
    assert!(want.sum_uz.abs() < 1e-9 * want.sum_uy.abs() * 1e3);
}

/// With every spring streaming its own parameters (packed: rest lengths as exact ulp offsets,
/// stiffness and dashpot as binary16 factors of the run's largest), the small size after
/// 1000 steps agrees with the f32 scalar loop to f32 round-off (the yardstick's parameters
/// pack exactly, so only the summation order differs: 1e-5 relative) and is bit for bit the
/// shared-parameter run.
#[test]
fn yardstick_streamed_parameters_checksum_works() {
    let size = LatticeSize::SMALL;
    let model = yardstick::lattice_model(size);
    let mut reference = ReferenceStepper::<f32>::new(&model, yardstick::run_gravity(), 1e-4).unwrap();
    for _ in 0..1000 {
        reference.step();
    }
    let want = yardstick::checksum(&model, |i| reference.x[i].map(f64::from));
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    for level in SimdLevel::available() {
        for threads in [1, 2] {
            let run = |imp| {
                let mut sim =
                    Simulation::<f32>::new(&model, yardstick::impl_params(imp, threads), yardstick::lattice_effects())
                        .unwrap();
                for _ in 0..1000 {
                    sim.step();
                }
                yardstick::checksum(&model, |i| sim.state().x.get_f64(i))
            };
            let got = run(yardstick::YardstickImpl::LaminaStreamed(level));
            assert_eq!(got, run(yardstick::YardstickImpl::Lamina(level)), "{level} x{threads}");
            assert!(rel(got.sum_uy, want.sum_uy) < 1e-5, "{level} x{threads}: {got:?} vs {want:?}");
            assert!(rel(got.max_u, want.max_u) < 1e-5, "{level} x{threads}: {got:?} vs {want:?}");
            assert!(rel(got.rms_u, want.rms_u) < 1e-5, "{level} x{threads}: {got:?} vs {want:?}");
        }
    }
}

#[test]
fn yardstick_simd_levels_are_bit_identical_works() {
    let size = LatticeSize { nx: 17, ny: 5, nz: 6 };
    let levels = SimdLevel::available();
    let base = lamina_checksum::<f32>(size, 200, 1, levels[0]);
    for &level in &levels[1..] {
        assert_eq!(lamina_checksum::<f32>(size, 200, 1, level), base, "{level}");
    }
}

/// Runs of identical springs read one shared parameter entry (with a mask for the null
/// springs that bridge row ends) instead of a per-spring stream; the forces, and so every
/// position, are bit for bit those of the streamed layout.
#[test]
fn shared_run_parameters_match_streamed_parameters_bit_for_bit_works() {
    use lamina_core::scene::Scene;
    let lattice = yardstick::lattice_model(LatticeSize { nx: 23, ny: 6, nz: 7 });
    let scene = Scene::builtin_default();
    let limb = scene.build_model().unwrap();
    for (model, effects) in [(&lattice, yardstick::lattice_effects()), (&limb, scene.effects.clone())] {
        let run = |share: bool, threads: usize| {
            let params = lamina_core::solver::IntegrationParameters {
                share_run_parameters: share,
                ..yardstick::lattice_params(threads, SimdLevel::detect())
            };
            let mut sim = Simulation::<f32>::new(model, params, effects.clone()).unwrap();
            for _ in 0..300 {
                sim.step();
            }
            (0..model.nodes.len()).map(|i| sim.state().x.get_f64(i).map(f64::to_bits)).collect::<Vec<_>>()
        };
        for threads in [1, 2] {
            let streamed = run(false, threads);
            assert_eq!(run(true, threads), streamed, "{threads} thread(s)");
            // And the state moved: the comparison is not between two untouched copies.
            let start: Vec<_> = model.nodes.position.iter().map(|p| p.map(|c| (c as f32 as f64).to_bits())).collect();
            assert_ne!(streamed, start);
        }
    }
}

/// The default scene's bilinear springs (lane blocks, partial blocks, shared parameters)
/// give the same bits at every instruction-set level.
#[test]
fn simd_levels_are_bit_identical_on_bilinear_springs_works() {
    use lamina_core::scene::Scene;
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let run = |level: SimdLevel| {
        let params = lamina_core::solver::IntegrationParameters { simd: level, ..scene.solver.clone() };
        let mut sim = Simulation::<f32>::new(&model, params, scene.effects.clone()).unwrap();
        for _ in 0..100 {
            sim.step();
        }
        (0..model.nodes.len()).map(|i| sim.state().x.get_f64(i).map(f64::to_bits)).collect::<Vec<_>>()
    };
    let levels = SimdLevel::available();
    let base = run(levels[0]);
    for &level in &levels[1..] {
        assert!(run(level) == base, "{level} differs from {}", levels[0]);
    }
    let start: Vec<_> = model.nodes.position.iter().map(|p| p.map(|c| (c as f32 as f64).to_bits())).collect();
    assert_ne!(base, start, "the scene moved");
}
