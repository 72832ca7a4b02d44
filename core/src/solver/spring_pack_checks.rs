//! Packed parameters against the layouts and kernels that use them: every packed value
//! decodes within its stated bound, a block that cannot pack is refused, and the packed
//! kernel computes bit for bit what the f32 kernel computes from the decoded parameters.

use super::lane_block::LANES;
use super::simd::SimdLevel;
use super::spring_kernels::{ForceWindow, NodeView, accumulate_part};
use super::spring_layout::{NULL_SPRING, SpringLayout, pack_linear, same_group};
use super::spring_pack::{PACKED_RELATIVE_BOUND, PackError, decode};
use crate::law::SpringLaw;
use crate::model::Model;
use crate::yardstick::{LatticeSize, lattice_model};

/// A reproducible stream of numbers in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The yardstick lattice with every spring its own rest length (up to 1,000 f32 ulps
/// above the lattice's), stiffness (100-400 N/m) and dashpot (0.01-0.03 N·s/m).
fn varied_lattice(size: LatticeSize, seed: u64) -> Model {
    let mut m = lattice_model(size);
    let mut rng = Lcg(seed);
    let s = &mut m.springs;
    for i in 0..s.len() {
        let rest = s.rest_length[i] as f32;
        let ulp = f32::from_bits(rest.to_bits() + 1) - rest;
        s.rest_length[i] = f64::from(rest + ulp * (rng.next() * 1000.0).floor() as f32);
        s.law[i] = SpringLaw::Linear { stiffness: 100.0 + 300.0 * rng.next() };
        s.damping[i] = 0.01 + 0.02 * rng.next();
    }
    m
}

#[test]
fn packed_parameters_decode_within_stated_bounds_works() {
    let model = varied_lattice(LatticeSize { nx: 21, ny: 5, nz: 6 }, 3);
    let layout = SpringLayout::<f32>::with_sharing(&model.springs, 2, false);
    let block = &layout.linear;
    let packed = layout.packed.as_ref().expect("every spring packs");
    let mut checked = 0;
    for (r, run) in block.runs.iter().enumerate() {
        let m = block.runs.iter().filter(|o| same_group(o, run)).count();
        let j = block.runs[..r].iter().rev().take_while(|o| same_group(o, run)).count();
        for i in 0..run.len as usize {
            let s = run.first as usize + i;
            if block.source[s] == NULL_SPRING {
                continue;
            }
            let rec = &packed.records[packed.first_record[r] as usize + (i / LANES) * m];
            assert_eq!(packed.first_record[r] as usize - j, packed.first_record[r - j] as usize);
            let [rest, k, c] = decode(&packed.runs[r], rec, i % LANES);
            let src = block.source[s] as usize;
            // Rest length: exact.
            assert_eq!(rest, model.springs.rest_length[src] as f32);
            let SpringLaw::Linear { stiffness } = model.springs.law[src] else { unreachable!() };
            let (k0, c0) = (stiffness as f32, model.springs.damping[src] as f32);
            assert!(f64::from((k - k0).abs()) <= PACKED_RELATIVE_BOUND * f64::from(k0), "{k} vs {k0}");
            assert!(f64::from((c - c0).abs()) <= PACKED_RELATIVE_BOUND * f64::from(c0), "{c} vs {c0}");
            checked += 1;
        }
    }
    assert_eq!(checked + block.loose_a.len(), model.springs.len());
    // The yardstick's own parameters pack exactly (50, 150 and 400 N/m have 11
    // significant bits or fewer; a run's dashpots are equal, as are its rest lengths).
    let yard = lattice_model(LatticeSize::SMALL);
    let layout = SpringLayout::<f32>::with_sharing(&yard.springs, 1, false);
    let packed = layout.packed.as_ref().expect("the yardstick packs");
    for (r, run) in layout.linear.runs.iter().enumerate() {
        let m = layout.linear.runs.iter().filter(|o| same_group(o, run)).count();
        for i in 0..run.len as usize {
            let s = run.first as usize + i;
            if layout.linear.source[s] == NULL_SPRING {
                continue;
            }
            let rec = &packed.records[packed.first_record[r] as usize + (i / LANES) * m];
            let p = &layout.linear.params;
            assert_eq!(decode(&packed.runs[r], rec, i % LANES), [p.rest[s], p.k[s], p.c[s]]);
        }
    }
    // f64 and shared layouts are not packed.
    assert!(SpringLayout::<f64>::with_sharing(&yard.springs, 1, false).packed.is_none());
    assert!(SpringLayout::<f32>::with_sharing(&yard.springs, 1, true).packed.is_none());
}

#[test]
fn rest_lengths_too_far_apart_are_not_packed_works() {
    let mut model = lattice_model(LatticeSize { nx: 21, ny: 4, nz: 4 });
    for i in (0..model.springs.len()).step_by(7) {
        model.springs.rest_length[i] *= 1.01;
    }
    assert!(SpringLayout::<f32>::with_sharing(&model.springs, 1, false).packed.is_none());
    let layout = SpringLayout::<f32>::with_sharing(&model.springs, 1, false);
    assert!(matches!(pack_linear(&layout.linear), Err(PackError::RestSpread { .. })));
}

/// The packed kernel computes, bit for bit, what the f32 kernel computes from the
/// decoded parameters, at every level, full lane blocks and partial ones.
#[test]
fn packed_kernel_matches_decoded_parameters_bit_for_bit_works() {
    let model = varied_lattice(LatticeSize { nx: 21, ny: 5, nz: 6 }, 11);
    let n = model.nodes.len();
    for threads in [1, 2] {
        let packed = SpringLayout::<f32>::with_sharing(&model.springs, threads, false);
        let p = packed.packed.as_ref().expect("packs");
        let mut decoded = packed.clone();
        decoded.packed = None;
        for (r, run) in packed.linear.runs.iter().enumerate() {
            let m = packed.linear.runs.iter().filter(|o| same_group(o, run)).count();
            for i in 0..run.len as usize {
                let rec = &p.records[p.first_record[r] as usize + (i / LANES) * m];
                let [rest, k, c] = decode(&p.runs[r], rec, i % LANES);
                let s = run.first as usize + i;
                decoded.linear.params.rest[s] = rest;
                decoded.linear.params.k[s] = k;
                decoded.linear.params.c[s] = c;
            }
        }
        let mut rng = Lcg(5);
        let mut jitter = |p: f64| (p + 1e-4 * (rng.next() - 0.5)) as f32;
        let x: Vec<Vec<f32>> = (0..3).map(|c| model.nodes.position.iter().map(|p| jitter(p[c])).collect()).collect();
        let v: Vec<Vec<f32>> = (0..3).map(|_| (0..n).map(|_| jitter(0.0) * 100.0).collect()).collect();
        let nodes = NodeView { x: [&x[0], &x[1], &x[2]], v: [&v[0], &v[1], &v[2]] };
        for level in SimdLevel::available() {
            for t in 0..threads {
                let forces = |layout: &SpringLayout<f32>| {
                    let (lo, hi) = layout.window(t);
                    let mut f = vec![vec![0.0f32; (hi - lo) as usize]; 3];
                    let [fx, fy, fz] = &mut f[..] else { unreachable!() };
                    let mut out = ForceWindow { f: [fx, fy, fz], lo: lo as usize };
                    accumulate_part(level, layout, t, true, &nodes, &mut out);
                    f.concat().iter().map(|x| x.to_bits()).collect::<Vec<_>>()
                };
                let got = forces(&packed);
                assert_eq!(got, forces(&decoded), "{level}, part {t} of {threads}");
                assert!(got.iter().any(|&b| b != 0));
            }
        }
    }
}
