//! Sizes and geometry the generator, the layered block and the yardstick refuse before they
//! allocate: regression tests for inputs that panicked or exhausted memory. This process caps
//! its memory budget at 2 GiB (`lamina_input::memory::set_process_limit`) so that what is
//! refused does not depend on the machine.

use lamina_core::generator::{
    AnatomyGenerateError, AnatomySpec, CylinderLimb, GeneratorError, GridSize, MAX_REPAIR_FRACTION, Materials,
    generate, generate_anatomy,
};
use lamina_core::model::ModelSizeError;
use lamina_core::scene::BlockSpec;
use lamina_core::yardstick::LatticeSize;
use lamina_input::MemoryCheckError;
use lamina_mesh::synthetic::cylinder;
use lamina_mesh::{Units, save_stl_binary};
use std::path::{Path, PathBuf};

const BUDGET: u64 = 2 << 30;

fn limit() {
    lamina_input::memory::set_process_limit(BUDGET);
}

/// The memory refusal inside `e`, with its two sizes.
fn memory_refusal(e: &ModelSizeError) -> (u64, u64) {
    match e {
        ModelSizeError::Memory(MemoryCheckError::TooLarge { needed_bytes, available_bytes, .. }) => {
            (*needed_bytes, *available_bytes)
        }
        other => panic!("expected a memory refusal, got {other}"),
    }
}

#[test]
fn cylinder_length_1e_300_is_refused_works() {
    // `lamina generate --cylinder 12x3 --length 1e-300` reached `unreachable!`.
    for length in [1e-300, 1e-170, 0.0, -1.0, f64::NAN, 1e300] {
        let spec = CylinderLimb { length, ..CylinderLimb::new(12, 3) };
        let e = generate(&spec, &Materials::default()).unwrap_err();
        assert_eq!(e, GeneratorError::BadCylinder, "length {length}");
        assert!(e.to_string().contains("between 1e-6 and 1e3 m"), "{e}");
    }
    // The bounds themselves are accepted.
    let spec = CylinderLimb { length: 1e-6, ..CylinderLimb::new(12, 3) };
    assert!(spec.is_valid() && spec.centreline().is_some());
}

#[test]
fn cylinder_4096x4096_limb_is_refused_for_memory_works() {
    // Inside the grid's index range, but W(7H+1) = 117 million nodes and W(55H-13) = 922.7
    // million springs: generation aborted when memory ran out.
    limit();
    let e = generate(&CylinderLimb::new(4096, 4096), &Materials::default()).unwrap_err();
    let GeneratorError::Size(size) = &e else { panic!("expected a size refusal, got {e}") };
    let (needed, available) = memory_refusal(size);
    assert!(needed > 60_000_000_000 && available <= BUDGET, "{e}");
    let text = e.to_string();
    assert!(text.contains("117444608 nodes, 922693632 springs") && text.contains("available"), "{text}");
    // A grid whose node count overflows the indices is refused as a bad grid.
    assert!(!GridSize::new(u32::MAX, u32::MAX).is_valid());
}

#[test]
fn block_nx_nz_2_pow_32_is_refused_works() {
    // nx * nz * rows overflowed in the size check, which then passed.
    limit();
    // Refused for memory first: the estimate overflows too (more than 16 EiB).
    let spec = BlockSpec { nx: 1 << 32, nz: 1 << 32, ..BlockSpec::default() };
    let e = spec.check_size().unwrap_err();
    let (needed, available) = memory_refusal(&e);
    assert!(needed == u64::MAX && available <= BUDGET, "{e}");
    let text = e.to_string();
    assert!(text.contains("(more than 2^64 nodes, more than 2^64 springs) needs more than 16 EiB"), "{text}");
    assert!(spec.checked_model().is_err(), "refused before building");
    let spec = BlockSpec { muscle_rows: usize::MAX, ..BlockSpec::default() };
    assert_eq!(memory_refusal(&spec.check_size().unwrap_err()).0, u64::MAX);
}

#[test]
fn block_5e7_nodes_is_refused_for_memory_works() {
    // The largest block the scene loader allowed (5e7 nodes) exhausted memory.
    limit();
    let spec = BlockSpec { nx: 2_887, nz: 2_887, ..BlockSpec::default() };
    let (needed, available) = memory_refusal(&spec.check_size().unwrap_err());
    assert!(needed > 10 * BUDGET && available <= BUDGET);
    // The default block passes.
    assert!(BlockSpec::default().check_size().is_ok());
}

#[test]
fn yardstick_unbounded_size_is_refused_works() {
    limit();
    let e = LatticeSize::parse("100000x100000x100000").unwrap().checked_model().unwrap_err();
    let (needed, available) = memory_refusal(&e);
    assert!(needed > 1_000_000_000_000_000 && available <= BUDGET, "{e}");
    assert!(e.to_string().contains("(1000000000000000 nodes, "), "{e}");
    let e = LatticeSize::parse("2000x25x2000").unwrap().check().unwrap_err();
    assert!(e.to_string().starts_with("yardstick lattice 2000x25x2000 (100000000 nodes,"), "{e}");
    assert!(LatticeSize::LARGE.check().is_ok());
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_generator_bounds_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Nested synthetic cylinders (radii mm: skin 50, fat/muscle 40, bone 15) as STL files.
fn cylinders(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let write = |name: &str, r: f64| {
        let p = dir.join(name);
        save_stl_binary(&p, &cylinder(r, -0.05, 0.35, 96, 12), Units::Millimetre).unwrap();
        p
    };
    (write("skin.stl", 0.050), write("fat_muscle.stl", 0.040), write("bone.stl", 0.015))
}

fn anatomy(skin: PathBuf, fat_muscle: PathBuf, bone: PathBuf, min_layer: f64) -> AnatomySpec {
    AnatomySpec {
        skin,
        fat_muscle,
        bone,
        z_range: (0.0, 0.3),
        grid: GridSize::new(24, 4),
        skin_fat: None,
        skin_thickness: 0.002,
        min_layer,
        materials: Materials::default(),
    }
}

#[test]
fn anatomy_skin_is_femur_is_refused_works() {
    // The femur given as the skin: every sample was "repaired" and a model written.
    let dir = scratch("femur");
    let (skin, fat_muscle, bone) = cylinders(&dir);
    assert!(generate_anatomy(&anatomy(skin, fat_muscle.clone(), bone.clone(), 1e-3), None).is_ok());
    let e = generate_anatomy(&anatomy(bone.clone(), fat_muscle, bone, 1e-3), None).unwrap_err();
    let AnatomyGenerateError::TooManyRepairs { repaired, samples, .. } = e else { panic!("{e}") };
    assert!(repaired as f64 > MAX_REPAIR_FRACTION * samples as f64 && samples == 2 * 24 * 4);
    assert!(e.to_string().contains("do not nest"), "{e}");
}

#[test]
fn anatomy_min_layer_1e9_mm_is_refused_works() {
    let dir = scratch("minlayer");
    let (skin, fat_muscle, bone) = cylinders(&dir);
    let e = generate_anatomy(&anatomy(skin, fat_muscle, bone, 1e6), None).unwrap_err();
    let AnatomyGenerateError::TooManyRepairs { repaired, samples, .. } = &e else { panic!("{e}") };
    assert_eq!(repaired, samples, "{e}");
}
