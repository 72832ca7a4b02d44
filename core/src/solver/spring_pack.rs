//! Linear springs' per-spring parameters packed to the precision they need, in the order
//! the streamed kernel reads them.
//!
//! When every spring streams its own parameters (no run shares one entry), f32 parameters
//! cost 12 bytes a spring in three streams per run, and a group of nine runs reads 27 of
//! them at once, more than the hardware prefetchers follow. Packed, a spring costs 6 bytes,
//! and a group reads *one* sequential stream: for each lane block of [`LANES`] first nodes,
//! the records of the group's runs one after the other, exactly as the kernel visits them.
//!
//! A record holds, per lane, as 16-bit values:
//! * rest length: an unsigned offset in f32 units in the last place (ulp) above the run's
//!   shortest rest length, `rest = base + d·ulp(base)`. Decoded **exactly** (every rest
//!   length of f32 type at or above `base` is a whole number of `ulp(base)` above it); a run
//!   whose rest lengths span 65,536 ulps or more (about 61 µm at 1 cm) cannot be packed.
//! * stiffness and dashpot: IEEE binary16 factors of a per-run scale, `k = k_max·f`, the
//!   scale being the run's largest value or the power of two above it. Within
//!   [`PACKED_RELATIVE_BOUND`] of the f32 value (binary16 rounding, 2^-11, and the product's
//!   f32 rounding, 2^-24); exact when the run's values are equal, or in ratios binary16
//!   holds, or have at most 11 significant bits (whole N/m below 2048: the yardstick's 50,
//!   150 and 400 N/m). A factor that would lose more (below binary16's normal range, 6.1e-5
//!   of the scale) cannot be packed.
//!
//! Packing is all or nothing: when one spring of the block cannot be packed within these
//! bounds, the kernel streams the f32 parameters instead. Only f32 is packed (an f64 run
//! keeps f64 parameters).

use super::lane_block::{LANES, f16_from_f64, f16_to_f64};
use super::spring_layout::{LinearParams, NULL_SPRING, SpringBlock, same_group};
use crate::real::Real;

/// Largest relative error of a packed stiffness or dashpot against its f32 value:
/// `2^-11 + 2^-23` (binary16 rounding, then the f32 product).
pub const PACKED_RELATIVE_BOUND: f64 = 1.0 / 2048.0 + 1.0 / 8_388_608.0;

/// [`LANES`] springs of one run, packed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(16))]
pub struct PackedRecord {
    /// Rest length offsets in units of the run's [`PackedRun::unit`].
    pub rest: [u16; LANES],
    /// Stiffness factors (binary16) of the run's [`PackedRun::k_max`].
    pub k: [u16; LANES],
    /// Dashpot factors (binary16) of the run's [`PackedRun::c_max`].
    pub c: [u16; LANES],
}

/// What a run's records are relative to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackedRun<T> {
    /// Shortest rest length of the run's springs, m.
    pub base: T,
    /// One f32 ulp of `base`, m.
    pub unit: T,
    /// Scale of the stiffness factors: the largest stiffness magnitude of the run's springs
    /// or the power of two above it (the one that decodes exactly; 1 when all are 0), N/m.
    pub k_max: T,
    /// Scale of the dashpot factors, as `k_max`, N·s/m.
    pub c_max: T,
}

/// A linear block's run parameters, packed.
#[derive(Clone, Debug, Default)]
pub struct PackedLinear<T> {
    /// Per run (as [`SpringBlock::runs`]).
    pub runs: Vec<PackedRun<T>>,
    /// Per run: index in `records` of its first record. A group's records are stored lane
    /// block by lane block, each block's runs in order, so a run's next record is
    /// group-size records further on.
    pub first_record: Vec<u32>,
    /// Every run's records in the kernel's reading order.
    pub records: Vec<PackedRecord>,
}

/// The decoded rest length, stiffness and dashpot of a record's lane `l`: the operations the
/// kernel performs, in `T`.
#[inline(always)]
pub fn decode<T: Real>(run: &PackedRun<T>, rec: &PackedRecord, l: usize) -> [T; 3] {
    [
        run.base + T::from_f64(f64::from(rec.rest[l])) * run.unit,
        run.k_max * T::from_f64(f16_to_f64(rec.k[l])),
        run.c_max * T::from_f64(f16_to_f64(rec.c[l])),
    ]
}

/// Why a block could not be packed.
#[derive(Clone, Debug, PartialEq)]
pub enum PackError {
    /// The precision is not f32.
    NotF32,
    /// A run's rest lengths span too many ulps of its shortest, or are not finite.
    RestSpread { run: usize },
    /// A stiffness or dashpot does not pack within [`PACKED_RELATIVE_BOUND`].
    Factor { run: usize },
}

fn f32_ulp(v: f32) -> f32 {
    let v = v.abs();
    if !v.is_finite() {
        return f32::NAN;
    }
    let next = f32::from_bits(v.to_bits() + 1);
    next - v
}

/// The scale of a run's binary16 factors: the largest magnitude, or the power of two at or
/// above it when that decodes every value exactly and the largest does not (values with 11
/// significant bits or fewer, such as whole N/m below 2048, are exact in binary16 times a
/// power of two); 1 when every value is 0.
fn scale_of<T: Real>(values: &[T]) -> T {
    let largest = values.iter().map(|v| v.to_f64().abs()).fold(0.0f64, f64::max);
    if largest == 0.0 || !largest.is_finite() {
        return T::ONE;
    }
    let exact = |scale: T| {
        values.iter().all(|&v| scale * T::from_f64(f16_to_f64(f16_from_f64(v.to_f64() / scale.to_f64()))) == v)
    };
    let largest = T::from_f64(largest);
    let power = T::from_f64((2.0f64).powi(largest.to_f64().log2().ceil() as i32));
    if !exact(largest) && exact(power) { power } else { largest }
}

/// Packs `block`'s runs (its loose springs keep their f32 entries).
///
/// # Errors
/// [`PackError`]: `T` is not f32, or a spring does not pack within the stated bounds.
pub fn pack_linear<T: Real>(block: &SpringBlock<LinearParams<T>>) -> Result<PackedLinear<T>, PackError> {
    if T::NAME != "f32" {
        return Err(PackError::NotF32);
    }
    let p = &block.params;
    let mut out = PackedLinear {
        runs: Vec::with_capacity(block.runs.len()),
        first_record: vec![0; block.runs.len()],
        records: Vec::new(),
    };
    // Bases of every run.
    for (r, run) in block.runs.iter().enumerate() {
        let first = run.first as usize;
        let real: Vec<usize> = (first..first + run.len as usize).filter(|&s| block.source[s] != NULL_SPRING).collect();
        let base = real.iter().map(|&s| p.rest[s].to_f64() as f32).fold(f32::INFINITY, f32::min);
        let base = if real.is_empty() { 0.0 } else { base };
        let unit = f32_ulp(base);
        if !base.is_finite() || !unit.is_finite() {
            return Err(PackError::RestSpread { run: r });
        }
        let k: Vec<T> = real.iter().map(|&s| p.k[s]).collect();
        let c: Vec<T> = real.iter().map(|&s| p.c[s]).collect();
        out.runs.push(PackedRun {
            base: T::from_f64(base.into()),
            unit: T::from_f64(unit.into()),
            k_max: scale_of(&k),
            c_max: scale_of(&c),
        });
    }
    // Records, group by group, lane block by lane block, run by run.
    let runs = &block.runs;
    let mut start = 0;
    while start < runs.len() {
        let mut end = start + 1;
        while end < runs.len() && same_group(&runs[start], &runs[end]) {
            end += 1;
        }
        let len = runs[start].len as usize;
        let group_first = out.records.len();
        for (j, r) in (start..end).enumerate() {
            out.first_record[r] = (group_first + j) as u32;
        }
        for done in (0..len).step_by(LANES) {
            for r in start..end {
                let pr = out.runs[r];
                let mut rec = PackedRecord::default();
                for l in 0..LANES.min(len - done) {
                    let s = runs[r].first as usize + done + l;
                    if block.source[s] == NULL_SPRING {
                        // k = c = 0: no force, whatever the rest length.
                        continue;
                    }
                    let (rest, k, c) = (p.rest[s], p.k[s], p.c[s]);
                    let steps = (rest.to_f64() - pr.base.to_f64()) / pr.unit.to_f64();
                    if !(0.0..=65535.0).contains(&steps) || steps.fract() != 0.0 {
                        return Err(PackError::RestSpread { run: r });
                    }
                    rec.rest[l] = steps as u16;
                    rec.k[l] = f16_from_f64(k.to_f64() / pr.k_max.to_f64());
                    rec.c[l] = f16_from_f64(c.to_f64() / pr.c_max.to_f64());
                    let [rest2, k2, c2] = decode(&pr, &rec, l);
                    let close = |got: T, want: T| {
                        (got.to_f64() - want.to_f64()).abs() <= PACKED_RELATIVE_BOUND * want.to_f64().abs()
                    };
                    if rest2.to_f64() != rest.to_f64() {
                        return Err(PackError::RestSpread { run: r });
                    }
                    if !close(k2, k) || !close(c2, c) {
                        return Err(PackError::Factor { run: r });
                    }
                }
                out.records.push(rec);
            }
        }
        start = end;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::law::SpringLaw;
    use crate::model::Model;
    use crate::solver::SimdLevel;
    use crate::solver::spring_kernels::{ForceWindow, NodeView, accumulate_part};
    use crate::solver::spring_layout::SpringLayout;
    use crate::yardstick::{LatticeSize, lattice_model};

    /// A reproducible stream of numbers in [0, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn f16_codes_round_trip_and_round_to_nearest_works() {
        for h in 0..=u16::MAX {
            let v = f16_to_f64(h);
            if v.is_nan() {
                continue;
            }
            assert_eq!(f16_from_f64(v), h, "{h:#06x} = {v}");
        }
        assert_eq!(f16_to_f64(0x3c00), 1.0);
        assert_eq!(f16_to_f64(0x7bff), 65504.0);
        assert_eq!(f16_to_f64(0x0001), (2.0f64).powi(-24));
        assert_eq!(f16_from_f64(1e6), 0x7c00);
        let mut rng = Lcg(7);
        for _ in 0..100_000 {
            // Normal range: half a binary16 step, 2^-11 relative.
            let sign = if rng.next() < 0.5 { -1.0 } else { 1.0 };
            let v = sign * (1.0 + rng.next()) * (2.0f64).powi((rng.next() * 29.0) as i32 - 14);
            let back = f16_to_f64(f16_from_f64(v));
            assert!((back - v).abs() <= v.abs() / 2048.0, "{v} -> {back}");
        }
        // Ties go to even: 1 + 2^-11 is halfway between 1 and 1 + 2^-10.
        assert_eq!(f16_from_f64(1.0 + 1.0 / 2048.0), 0x3c00);
        assert_eq!(f16_from_f64(1.0 + 3.0 / 2048.0), 0x3c02);
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
            let x: Vec<Vec<f32>> =
                (0..3).map(|c| model.nodes.position.iter().map(|p| jitter(p[c])).collect()).collect();
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
}
