//! `lamina bench yardstick`: time per step of the yardstick scene, Lamina's solver beside
//! the specification's plain scalar loop, in one run.

use crate::yardstick_c::CStepper;
use lamina_core::real::Real;
use lamina_core::solver::{SimdLevel, Simulation};
use lamina_core::yardstick::{self, Checksum, LatticeSize, ReferenceStepper, YardstickImpl};
use serde::Serialize;
use std::time::{Duration, Instant};

/// One timed configuration.
#[derive(Clone, Debug, Serialize)]
pub struct YardstickRow {
    pub size: String,
    pub nodes: usize,
    pub springs: usize,
    pub precision: &'static str,
    pub implementation: String,
    pub threads: usize,
    pub ms_per_step: f64,
    pub ns_per_spring_step: f64,
    pub mspring_per_s: f64,
    pub steps_timed: usize,
}

/// The small size's checksum after 1000 steps, per implementation and precision.
#[derive(Clone, Debug, Serialize)]
pub struct ChecksumRow {
    pub precision: &'static str,
    pub implementation: String,
    pub threads: usize,
    pub sum_ux: f64,
    pub sum_uy: f64,
    pub sum_uz: f64,
    pub max_u: f64,
    pub rms_u: f64,
}

trait Stepper {
    fn step(&mut self);
}

impl<T: Real> Stepper for Simulation<T> {
    fn step(&mut self) {
        Simulation::step(self)
    }
}

impl Stepper for CStepper {
    fn step(&mut self) {
        CStepper::step(self)
    }
}

impl<T: Real> Stepper for ReferenceStepper<T> {
    fn step(&mut self) {
        ReferenceStepper::step(self)
    }
}

/// Median time per step over `batches` batches after warm-up, s.
fn time_steps(stepper: &mut dyn Stepper, target_batch: Duration, batches: usize) -> (f64, usize) {
    // Warm-up: at least 10 steps and 0.2 s; also sizes the batch.
    let start = Instant::now();
    let mut warm = 0usize;
    while warm < 10 || start.elapsed() < Duration::from_millis(200) {
        stepper.step();
        warm += 1;
    }
    let per_step = start.elapsed().as_secs_f64() / warm as f64;
    let n = ((target_batch.as_secs_f64() / per_step).ceil() as usize).max(3);
    let mut samples: Vec<f64> = (0..batches)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..n {
                stepper.step();
            }
            t.elapsed().as_secs_f64() / n as f64
        })
        .collect();
    samples.sort_by(|a, b| a.total_cmp(b));
    (samples[samples.len() / 2], n * batches)
}

fn build<T: Real>(size: LatticeSize, imp: YardstickImpl, threads: usize) -> Box<dyn Stepper> {
    let model = yardstick::lattice_model(size);
    match imp {
        YardstickImpl::Reference => {
            Box::new(ReferenceStepper::<T>::new(&model, yardstick::GRAVITY, yardstick::DT).expect("linear springs"))
        }
        YardstickImpl::Lamina(_) | YardstickImpl::LaminaStreamed(_) => Box::new(
            Simulation::<T>::new(&model, yardstick::impl_params(imp, threads), yardstick::lattice_effects())
                .expect("the yardstick model is valid"),
        ),
    }
}

/// Times one configuration.
pub fn time_config(
    size: LatticeSize,
    precision: &'static str,
    imp: YardstickImpl,
    threads: usize,
    batch: Duration,
) -> YardstickRow {
    let mut stepper =
        if precision == "f64" { build::<f64>(size, imp, threads) } else { build::<f32>(size, imp, threads) };
    let (secs, steps) = time_steps(stepper.as_mut(), batch, 5);
    let springs = yardstick::spring_count(size);
    YardstickRow {
        size: size.name(),
        nodes: size.nodes(),
        springs,
        precision,
        implementation: imp.to_string(),
        threads,
        ms_per_step: secs * 1e3,
        ns_per_spring_step: secs * 1e9 / springs as f64,
        mspring_per_s: springs as f64 / secs / 1e6,
        steps_timed: steps,
    }
}

/// Times the plain-C baseline (f32) on `threads` threads: `Err` says why it is not in this
/// binary.
pub fn time_c(size: LatticeSize, threads: usize, batch: Duration) -> Result<YardstickRow, String> {
    let model = yardstick::lattice_model(size);
    let mut stepper = CStepper::new(&model, threads)?;
    let (secs, steps) = time_steps(&mut stepper, batch, 5);
    let springs = yardstick::spring_count(size);
    Ok(YardstickRow {
        size: size.name(),
        nodes: size.nodes(),
        springs,
        precision: "f32",
        implementation: c_name(threads).into(),
        threads,
        ms_per_step: secs * 1e3,
        ns_per_spring_step: secs * 1e9 / springs as f64,
        mspring_per_s: springs as f64 / secs / 1e6,
        steps_timed: steps,
    })
}

/// Name of the C baseline's row on `threads` threads.
pub fn c_name(threads: usize) -> &'static str {
    if threads > 1 { "c-openmp" } else { "c" }
}

/// Checksum row of the C baseline (f32), small size after 1000 steps.
pub fn c_checksum_row(threads: usize) -> Result<ChecksumRow, String> {
    let model = yardstick::lattice_model(LatticeSize::SMALL);
    let mut c = CStepper::new(&model, threads)?;
    for _ in 0..1000 {
        c.step();
    }
    let s = yardstick::checksum(&model, |i| c.x[i].map(f64::from));
    Ok(ChecksumRow {
        precision: "f32",
        implementation: c_name(threads).into(),
        threads,
        sum_ux: s.sum_ux,
        sum_uy: s.sum_uy,
        sum_uz: s.sum_uz,
        max_u: s.max_u,
        rms_u: s.rms_u,
    })
}

fn checksum_of<T: Real>(imp: YardstickImpl, threads: usize) -> Checksum {
    let model = yardstick::lattice_model(LatticeSize::SMALL);
    match imp {
        YardstickImpl::Reference => {
            let mut r = ReferenceStepper::<T>::new(&model, yardstick::GRAVITY, yardstick::DT).expect("linear springs");
            for _ in 0..1000 {
                r.step();
            }
            yardstick::checksum(&model, |i| r.x[i].map(|c| c.to_f64()))
        }
        YardstickImpl::Lamina(_) | YardstickImpl::LaminaStreamed(_) => {
            let mut s =
                Simulation::<T>::new(&model, yardstick::impl_params(imp, threads), yardstick::lattice_effects())
                    .expect("valid");
            for _ in 0..1000 {
                s.step();
            }
            yardstick::checksum(&model, |i| s.state().x.get_f64(i))
        }
    }
}

/// Checksum row of the small size after 1000 steps.
pub fn checksum_row(precision: &'static str, imp: YardstickImpl, threads: usize) -> ChecksumRow {
    let c = if precision == "f64" { checksum_of::<f64>(imp, threads) } else { checksum_of::<f32>(imp, threads) };
    ChecksumRow {
        precision,
        implementation: imp.to_string(),
        threads,
        sum_ux: c.sum_ux,
        sum_uy: c.sum_uy,
        sum_uz: c.sum_uz,
        max_u: c.max_u,
        rms_u: c.rms_u,
    }
}

/// The implementations to time: the scalar reference, then Lamina at `levels`, then (when
/// `streamed`) Lamina at `levels` with per-spring parameter streams.
pub fn implementations(levels: &[SimdLevel], streamed: bool) -> Vec<YardstickImpl> {
    let shared = levels.iter().map(|&l| YardstickImpl::Lamina(l));
    let streamed = levels.iter().filter(|_| streamed).map(|&l| YardstickImpl::LaminaStreamed(l));
    std::iter::once(YardstickImpl::Reference).chain(shared).chain(streamed).collect()
}
