//! The XML model format round-trips bit-exactly, carries the PPU export, applies material
//! defaults, and reads and writes a yardstick-sized model quickly (times printed, not asserted).

use lamina_core::io::{
    ModelWriteError, ModelWriteOptions, PPU_STRET_LEN_FACTOR, model_from_str, model_to_string, model_to_string_with,
    read_model, write_model, write_model_with,
};
use lamina_core::law::{Bilinear, PpuBilinearPair, SpringLaw};
use lamina_core::model::{Layer, Model, ModelValidateError, NodeKind, Surface, Tissue};
use lamina_core::yardstick::{LatticeSize, lattice_model};
use proptest::prelude::*;
use std::time::Instant;

/// Finite f64 of any class, with the awkward values made likely.
fn any_finite() -> impl Strategy<Value = f64> {
    use proptest::num::f64::{NEGATIVE, NORMAL, POSITIVE, SUBNORMAL, ZERO};
    prop_oneof![
        3 => POSITIVE | NEGATIVE | NORMAL | SUBNORMAL | ZERO,
        1 => prop_oneof![
            Just(1e-300), Just(1e300), Just(-1e300), Just(-0.0), Just(0.0), Just(5e-324), Just(f64::MAX),
            Just(f64::MIN), Just(f64::MIN_POSITIVE), Just(0.1), Just(1.0 / 3.0), Just(f64::from_bits(0x000F_FFFF_FFFF_FFFF))
        ],
    ]
}

/// Finite f64 ≥ 0 (including −0.0, which compares equal to 0).
fn non_negative() -> impl Strategy<Value = f64> {
    use proptest::num::f64::{NORMAL, POSITIVE, SUBNORMAL, ZERO};
    prop_oneof![
        3 => POSITIVE | NORMAL | SUBNORMAL | ZERO,
        1 => prop_oneof![Just(1e-300), Just(1e300), Just(-0.0), Just(5e-324), Just(f64::MAX), Just(0.1)],
    ]
}

/// Finite f64 > 0.
fn positive() -> impl Strategy<Value = f64> {
    use proptest::num::f64::{NORMAL, POSITIVE, SUBNORMAL};
    prop_oneof![3 => POSITIVE | NORMAL | SUBNORMAL, 1 => prop_oneof![Just(1e-300), Just(1e300), Just(5e-324)]]
}

fn any_f32() -> impl Strategy<Value = f32> {
    use proptest::num::f32::{NEGATIVE, NORMAL, POSITIVE, SUBNORMAL, ZERO};
    prop_oneof![3 => POSITIVE | NEGATIVE | NORMAL | SUBNORMAL | ZERO, 1 => prop_oneof![Just(-0.0f32), Just(1e-45f32), Just(f32::MAX)]]
}

/// Text with markup characters, whitespace that XML would normalise, other control
/// characters and non-ASCII; no NUL.
fn text() -> impl Strategy<Value = String> {
    "[a-z &<>\"'\t\n\r\u{1}\u{1f}é漢\u{1F600}]{0,10}"
}

fn law(rest: f64) -> impl Strategy<Value = SpringLaw> {
    prop_oneof![
        non_negative().prop_map(|stiffness| SpringLaw::Linear { stiffness }),
        (non_negative(), non_negative(), non_negative(), non_negative(), any::<bool>()).prop_map(
            move |(k1, k2, kc, extra, at_rest)| {
                let turn_length = if at_rest { rest } else { rest.max(extra) };
                SpringLaw::Bilinear(Bilinear { k1, k2, turn_length, k_compression: kc })
            }
        ),
    ]
}

fn model() -> impl Strategy<Value = Model> {
    let layers = proptest::collection::vec(
        (
            text(),
            prop_oneof![
                Just(Tissue::Skin),
                Just(Tissue::Fat),
                Just(Tissue::Muscle),
                Just(Tissue::Bone),
                Just(Tissue::Other)
            ],
        )
            .prop_map(|(name, tissue)| Layer { name, tissue }),
        1..4,
    );
    (layers, 0usize..25, text(), proptest::collection::vec((text(), text()), 0..4))
        .prop_flat_map(|(layers, n, name, provenance)| {
            let nl = layers.len() as u16;
            let node = (
                [any_finite(), any_finite(), any_finite()],
                positive(),
                prop_oneof![Just(NodeKind::Free), Just(NodeKind::Fixed), Just(NodeKind::Kinematic)],
                0..nl,
                [any_f32(), any_f32(), any_f32()],
                any::<bool>(),
            );
            let nodes = proptest::collection::vec(node, n);
            let springs = if n >= 2 {
                proptest::collection::vec(
                    (0..n as u32, 1..n as u32, non_negative(), non_negative(), 0..nl).prop_flat_map(
                        move |(a, d, rest, damping, layer)| {
                            let b = (a + d) % n as u32;
                            (Just((a, b, rest, damping, layer)), law(rest))
                        },
                    ),
                    0..40,
                )
                .boxed()
            } else {
                Just(Vec::new()).boxed()
            };
            let surfaces = if n >= 1 {
                proptest::collection::vec(
                    (
                        text(),
                        proptest::collection::vec([0..n as u32, 0..n as u32, 0..n as u32], 0..6),
                        proptest::option::of((0u32..4, 0u32..4).prop_flat_map(move |(c, r)| {
                            proptest::collection::vec(0..n as u32, (c * r) as usize).prop_map(move |g| (c, r, g))
                        })),
                    )
                        .prop_map(|(name, triangles, grid)| Surface { name, triangles, grid }),
                    0..3,
                )
                .boxed()
            } else {
                Just(Vec::new()).boxed()
            };
            (Just(layers), nodes, springs, surfaces, Just(name), Just(provenance))
        })
        .prop_map(|(layers, nodes, springs, surfaces, name, provenance)| {
            let mut m = Model { name, layers, surfaces, provenance, ..Model::default() };
            for (p, mass, kind, layer, t, textured) in nodes {
                let i = m.nodes.push(p, mass, kind, layer) as usize;
                if textured {
                    m.nodes.texcoord[i] = t;
                }
            }
            for ((a, b, rest, damping, layer), law) in springs {
                m.springs.push(a, b, rest, law, damping, layer);
            }
            m
        })
}

/// Bit patterns of every float, so that −0.0 ≠ 0.0 and a changed subnormal shows.
fn bits(m: &Model) -> Vec<u64> {
    let mut v: Vec<u64> = m.nodes.position.iter().flatten().map(|x| x.to_bits()).collect();
    v.extend(m.nodes.mass.iter().map(|x| x.to_bits()));
    v.extend(m.nodes.texcoord.iter().flatten().map(|x| x.to_bits() as u64));
    v.extend(m.springs.rest_length.iter().map(|x| x.to_bits()));
    v.extend(m.springs.damping.iter().map(|x| x.to_bits()));
    for law in &m.springs.law {
        match law {
            SpringLaw::Linear { stiffness } => v.push(stiffness.to_bits()),
            SpringLaw::Bilinear(b) => {
                v.extend([b.k1, b.k2, b.turn_length, b.k_compression].map(f64::to_bits));
            }
        }
    }
    v
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// `read(write(m)) == m`, bit for bit, with and without the PPU export.
    #[test]
    fn io_xml_random_model_round_trips_works(m in model(), ppu in any::<bool>()) {
        let text = model_to_string_with(&m, ModelWriteOptions { ppu_export: ppu }).expect("valid model writes");
        let back = model_from_str(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        prop_assert_eq!(&back, &m);
        prop_assert_eq!(bits(&back), bits(&m));
    }
}

#[test]
fn io_xml_file_round_trip_works() {
    let mut m = lattice_model(LatticeSize { nx: 4, ny: 3, nz: 3 });
    m.springs.law[0] = SpringLaw::Bilinear(Bilinear {
        k1: 10.0,
        k2: 300.0,
        turn_length: m.springs.rest_length[0] * 1.2,
        k_compression: 10.0,
    });
    m.surfaces.push(Surface { name: "top".into(), triangles: vec![[0, 1, 2]], grid: Some((1, 2, vec![3, 4])) });
    let path = std::env::temp_dir().join(format!("lamina_io_round_trip_{}.xml", std::process::id()));
    write_model(&m, &path).expect("write");
    let back = read_model(&path).expect("read");
    std::fs::remove_file(&path).ok();
    assert_eq!(back, m);
}

#[test]
fn io_xml_bilinear_spring_carries_ppu_export_works() {
    let mut m = lattice_model(LatticeSize { nx: 2, ny: 1, nz: 1 });
    let rest = m.springs.rest_length[0];
    let law = Bilinear { k1: 10.0, k2: 200.0, turn_length: rest * 1.25, k_compression: 10.0 };
    m.springs.law[0] = SpringLaw::Bilinear(law);
    let text = model_to_string(&m).expect("write");
    let pair = PpuBilinearPair::from_bilinear(&law, rest, 0.0, PPU_STRET_LEN_FACTOR * law.turn_length).expect("pair");
    let z = |x: f64| zmij::Buffer::new().format(x).to_string();
    let expect = format!(
        "<ppu TurnLen=\"{}\" TurnForce=\"{}\">\n        <first CompForce=\"{}\" CompLen=\"{}\" RestLen=\"{}\" StretForce=\"{}\" StretLen=\"{}\"/>",
        z(pair.turn_len),
        z(pair.turn_force),
        z(pair.first.comp_force),
        z(pair.first.comp_len),
        z(pair.first.rest_len),
        z(pair.first.stret_force),
        z(pair.first.stret_len),
    );
    assert!(text.contains(&expect), "{text}");
    // Without the PPU export there is no <ppu> element; the law reads back the same.
    let plain = model_to_string_with(&m, ModelWriteOptions { ppu_export: false }).expect("write");
    assert!(!plain.contains("<ppu"));
    assert_eq!(model_from_str(&plain).expect("read"), m);
}

#[test]
fn io_xml_spring_given_only_as_ppu_pair_reads_as_bilinear_works() {
    let law = Bilinear { k1: 8.0, k2: 120.0, turn_length: 0.0125, k_compression: 3.0 };
    let pair = PpuBilinearPair::from_bilinear(&law, 0.01, 0.0, 0.05).expect("pair");
    let s = |p: &lamina_core::law::PpuLinearSpring| {
        format!(
            "CompForce=\"{}\" CompLen=\"{}\" RestLen=\"{}\" StretForce=\"{}\" StretLen=\"{}\"",
            p.comp_force, p.comp_len, p.rest_len, p.stret_force, p.stret_len
        )
    };
    let text = format!(
        r#"<lamina-model version="1" units="SI (m, kg, s, N)">
  <layers count="1"><layer index="0" name="l" tissue="skin"/></layers>
  <nodes count="2">
    <node index="0" x="0" y="0" z="0" mass="1" kind="free" layer="0"/>
    <node index="1" x="0.01" y="0" z="0" mass="1" kind="free" layer="0"/>
  </nodes>
  <springs count="1">
    <spring index="0" a="0" b="1" layer="0" damping="0">
      <ppu TurnLen="{}" TurnForce="{}"><first {}/><second {}/></ppu>
    </spring>
  </springs>
</lamina-model>"#,
        pair.turn_len,
        pair.turn_force,
        s(&pair.first),
        s(&pair.second)
    );
    let m = model_from_str(&text).expect("read");
    assert_eq!(m.springs.rest_length[0], 0.01);
    let SpringLaw::Bilinear(back) = m.springs.law[0] else { panic!("not bilinear: {:?}", m.springs.law[0]) };
    assert_eq!(back.turn_length, law.turn_length);
    for (got, want) in [(back.k1, law.k1), (back.k2, law.k2), (back.k_compression, law.k_compression)] {
        assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");
    }
}

#[test]
fn io_xml_material_defaults_apply_to_springs_without_law_works() {
    let m = read_model(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/io/valid/small.xml")).expect("read");
    let SpringLaw::Bilinear(b) = m.springs.law[0] else { panic!("material law not applied") };
    assert_eq!((b.k1, b.k2, b.k_compression), (20.0, 400.0, 20.0));
    assert_eq!(b.turn_length, 0.01 * (1.0 + 0.1));
    assert_eq!(m.springs.damping[0], 0.05);
    // Springs with their own law keep it.
    assert_eq!(m.springs.law[1], SpringLaw::Linear { stiffness: 100.0 });
}

#[test]
fn io_xml_invalid_model_write_fails() {
    let mut m = lattice_model(LatticeSize { nx: 2, ny: 1, nz: 1 });
    m.nodes.mass[1] = 0.0;
    assert_eq!(model_to_string(&m), Err(ModelWriteError::Invalid { reason: ModelValidateError::BadNode { node: 1 } }));
    let mut m = lattice_model(LatticeSize { nx: 2, ny: 1, nz: 1 });
    m.provenance.push(("nul".into(), "a\0b".into()));
    assert!(matches!(model_to_string(&m), Err(ModelWriteError::UnrepresentableText { .. })));
    let mut m = lattice_model(LatticeSize { nx: 2, ny: 1, nz: 1 });
    m.nodes.texcoord[0][2] = f32::NAN;
    assert_eq!(model_to_string(&m), Err(ModelWriteError::NonFiniteTexcoord { node: 0 }));
}

/// Times the yardstick SMALL model (39×7×10: 2,730 nodes, 21,017 springs), linear and
/// with every spring bilinear (so every spring carries a PPU export). Prints, never asserts.
#[test]
fn io_xml_lattice_small_read_write_times_works() {
    let linear = lattice_model(LatticeSize::SMALL);
    let mut bilinear = linear.clone();
    for (law, &rest) in bilinear.springs.law.iter_mut().zip(&bilinear.springs.rest_length) {
        let k = law.max_stiffness();
        *law = SpringLaw::Bilinear(Bilinear { k1: k, k2: 20.0 * k, turn_length: rest * 1.1, k_compression: k });
    }
    let dir = std::env::temp_dir();
    for (label, m, ppu_export) in
        [("linear", &linear, true), ("bilinear+ppu", &bilinear, true), ("bilinear", &bilinear, false)]
    {
        let path = dir.join(format!("lamina_io_timing_{}_{label}.xml", std::process::id()));
        let best = |f: &mut dyn FnMut()| {
            (0..5)
                .map(|_| {
                    let t = Instant::now();
                    f();
                    t.elapsed().as_secs_f64() * 1e3
                })
                .fold(f64::INFINITY, f64::min)
        };
        let options = ModelWriteOptions { ppu_export };
        let write_ms = best(&mut || write_model_with(m, &path, options).expect("write"));
        let mut back = None;
        let read_ms = best(&mut || back = Some(read_model(&path).expect("read")));
        let text = std::fs::read_to_string(&path).expect("written");
        let parse_ms = best(&mut || back = Some(model_from_str(&text).expect("parse")));
        let size = text.len();
        std::fs::remove_file(&path).ok();
        assert_eq!(back.as_ref(), Some(m));
        println!(
            "io timing | {label:>13} | {} nodes | {} springs | {:.1} MB | write {write_ms:.1} ms | read {read_ms:.1} ms (from memory {parse_ms:.1} ms)",
            m.nodes.len(),
            m.springs.len(),
            size as f64 / 1e6
        );
    }
}

/// The yardstick LARGE model (250,000 nodes, 2,175,450 springs) writes and reads back.
/// Slow: runs only when `LAMINA_SLOW_TESTS` is set. Prints its times, never asserts them.
#[test]
fn io_xml_lattice_large_round_trip_works() {
    if std::env::var_os("LAMINA_SLOW_TESTS").is_none() {
        println!("SKIP io_xml_lattice_large_round_trip_works: set LAMINA_SLOW_TESTS to run");
        return;
    }
    let m = lattice_model(LatticeSize::LARGE);
    let path = std::env::temp_dir().join(format!("lamina_io_large_{}.xml", std::process::id()));
    let t = Instant::now();
    write_model(&m, &path).expect("write");
    let write_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let back = read_model(&path).expect("read");
    let read_s = t.elapsed().as_secs_f64();
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    std::fs::remove_file(&path).ok();
    assert_eq!(back, m);
    println!(
        "io timing | large | {} nodes | {} springs | {:.0} MB | write {write_s:.2} s | read {read_s:.2} s",
        m.nodes.len(),
        m.springs.len(),
        size as f64 / 1e6
    );
}

/// The example in `docs/model-format.md` reads, and is exactly what the writer writes.
#[test]
fn io_xml_documented_example_reads_works() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/model-format.md")).expect("docs");
    let example = doc.split("## Example").nth(1).expect("an Example section");
    let xml = example.split("```xml").nth(1).and_then(|s| s.split("```").next()).expect("an xml block");
    let m = model_from_str(xml).unwrap_or_else(|e| panic!("documented example: {e}"));
    assert_eq!((m.nodes.len(), m.springs.len(), m.surfaces.len()), (3, 2, 1));
    // It is exactly the writer's output, PPU export included.
    assert_eq!(model_to_string(&m).expect("write"), xml.trim_start());
}
