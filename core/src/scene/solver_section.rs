//! The scene's `[solver]` table: integrator, sub-steps, threads, SIMD level and the
//! integrators' tolerances.

use super::section::{FieldError, finite3, non_negative};
use crate::solver::{
    FactorStorage, IntegrationParameters, IntegratorKind, LateBuild, MAX_BUILD_EXCHANGES, MAX_FACTORED_ITERATIONS,
    MAX_MULTIRATE_RATIO, MAX_SUBSTEPS, MAX_THREADS, MultirateSettings, SimdLevel, Substeps,
};
use serde::Deserialize;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSolver {
    integrator: Option<String>,
    substeps: Option<toml::Value>,
    threads: Option<usize>,
    simd: Option<String>,
    stability_safety: Option<f64>,
    max_substeps: Option<u32>,
    cg_tolerance: Option<f64>,
    cg_max_iterations: Option<u32>,
    rayleigh_alpha: Option<f64>,
    rayleigh_beta: Option<f64>,
    factored_iterations: Option<u32>,
    factored_preconditioner: Option<bool>,
    factor_storage: Option<String>,
    multirate: Option<RawMultirate>,
}

/// `[solver.multirate]`: the region stepped every tick and how much slower the rest steps.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMultirate {
    centre: Option<[f64; 3]>,
    radius: Option<f64>,
    ratio: Option<u32>,
    follow_tool: Option<bool>,
    build_exchanges: Option<u32>,
    late_build: Option<String>,
}

/// The `[solver]` table over the defaults, with `dt = 1 / rate_hz`. A `[solver.multirate]`
/// table without `centre` is centred on `tool_centre` (the tool's start or device origin).
pub(super) fn solver_parameters(
    raw: RawSolver,
    rate_hz: u32,
    tool_centre: Option<[f64; 3]>,
) -> Result<IntegrationParameters, FieldError> {
    let mut solver = IntegrationParameters { dt: 1.0 / rate_hz as f64, ..IntegrationParameters::default() };
    if let Some(name) = raw.integrator {
        solver.integrator = IntegratorKind::parse(&name).ok_or_else(|| {
            FieldError::new(
                "solver.integrator",
                "symplectic_euler, velocity_verlet, rk4, implicit_euler or implicit_factored",
            )
        })?;
    }
    match raw.substeps {
        None => {}
        Some(toml::Value::String(v)) if v == "auto" => solver.substeps = Substeps::Auto,
        Some(toml::Value::Integer(n)) if (1..=i64::from(MAX_SUBSTEPS)).contains(&n) => {
            solver.substeps = Substeps::Fixed(n as u32)
        }
        Some(_) => {
            return Err(FieldError::new("solver.substeps", format!("\"auto\" or an integer from 1 to {MAX_SUBSTEPS}")));
        }
    }
    if let Some(t) = raw.threads {
        if !(1..=MAX_THREADS).contains(&t) {
            return Err(FieldError::new("solver.threads", format!("between 1 and {MAX_THREADS}")));
        }
        solver.threads = t;
    }
    if let Some(level) = raw.simd {
        solver.simd =
            SimdLevel::parse(&level).ok_or_else(|| FieldError::new("solver.simd", "auto, baseline, avx2 or avx512"))?;
    }
    let fields = [
        (raw.stability_safety, "solver.stability_safety", &mut solver.stability_safety),
        (raw.cg_tolerance, "solver.cg_tolerance", &mut solver.cg_tolerance),
        (raw.rayleigh_alpha, "solver.rayleigh_alpha", &mut solver.rayleigh_alpha),
        (raw.rayleigh_beta, "solver.rayleigh_beta", &mut solver.rayleigh_beta),
    ];
    for (value, field, into) in fields {
        if let Some(v) = non_negative(value, field)? {
            *into = v;
        }
    }
    if let Some(m) = raw.max_substeps {
        if m == 0 {
            return Err(FieldError::new("solver.max_substeps", "at least 1"));
        }
        solver.max_substeps = m;
    }
    if let Some(n) = raw.factored_iterations {
        if !(1..=MAX_FACTORED_ITERATIONS).contains(&n) {
            return Err(FieldError::new(
                "solver.factored_iterations",
                format!("between 1 and {MAX_FACTORED_ITERATIONS}"),
            ));
        }
        solver.factored_iterations = n;
    }
    if let Some(on) = raw.factored_preconditioner {
        solver.factored_preconditioner = on;
    }
    if let Some(storage) = raw.factor_storage {
        solver.factor_storage = FactorStorage::parse(&storage)
            .ok_or_else(|| FieldError::new("solver.factor_storage", "\"full\" or \"f16\""))?;
    }
    if let Some(m) = raw.cg_max_iterations {
        if m == 0 {
            return Err(FieldError::new("solver.cg_max_iterations", "at least 1"));
        }
        solver.cg_max_iterations = m;
    }
    if let Some(m) = raw.multirate {
        solver.multirate = Some(multirate_settings(m, tool_centre)?);
    }
    Ok(solver)
}

fn multirate_settings(raw: RawMultirate, tool_centre: Option<[f64; 3]>) -> Result<MultirateSettings, FieldError> {
    let centre = match (raw.centre, tool_centre) {
        (Some(c), _) if finite3(&c) => c,
        (Some(_), _) => return Err(FieldError::new("solver.multirate.centre", "three finite coordinates, m")),
        (None, Some(c)) => c,
        (None, None) => {
            return Err(FieldError::new(
                "solver.multirate.centre",
                "needed: the scene has no tool to centre the region on ([x, y, z] in m)",
            ));
        }
    };
    let mut out = MultirateSettings { centre, ..MultirateSettings::default() };
    if let Some(r) = raw.radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(FieldError::new("solver.multirate.radius", "a positive number of metres"));
        }
        out.radius = r;
    }
    if let Some(k) = raw.ratio {
        if !(2..=MAX_MULTIRATE_RATIO).contains(&k) {
            return Err(FieldError::new("solver.multirate.ratio", format!("from 2 to {MAX_MULTIRATE_RATIO}")));
        }
        out.ratio = k;
    }
    if let Some(f) = raw.follow_tool {
        out.follow_tool = f;
    }
    if let Some(k) = raw.build_exchanges {
        if !(2..=MAX_BUILD_EXCHANGES).contains(&k) {
            return Err(FieldError::new(
                "solver.multirate.build_exchanges",
                format!("from 2 to {MAX_BUILD_EXCHANGES}"),
            ));
        }
        out.build_exchanges = Some(k);
    }
    match raw.late_build.as_deref() {
        None => {}
        Some("defer") => out.late_build = LateBuild::Defer,
        Some("wait") => out.late_build = LateBuild::Wait,
        Some(_) => return Err(FieldError::new("solver.multirate.late_build", "\"defer\" or \"wait\"")),
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(body: &str) -> Result<IntegrationParameters, FieldError> {
        solver_parameters(toml::from_str(body).expect("well-formed"), 500, None)
    }

    #[test]
    fn solver_section_defaults_and_values_works() {
        let d = IntegrationParameters::default();
        let p = parse("").unwrap();
        assert_eq!(p.dt, 1.0 / 500.0);
        assert_eq!((p.integrator, p.substeps, p.threads), (d.integrator, d.substeps, d.threads));
        let p = parse("integrator = \"rk4\"\nsubsteps = 4\nthreads = 2\ncg_tolerance = 1e-6\n").unwrap();
        assert_eq!((p.integrator, p.substeps, p.threads), (IntegratorKind::Rk4, Substeps::Fixed(4), 2));
        assert_eq!(p.cg_tolerance, 1e-6);
        assert_eq!(parse("substeps = \"auto\"\n").unwrap().substeps, Substeps::Auto);
        assert_eq!(p.factor_storage, FactorStorage::Full);
        assert_eq!(parse("factor_storage = \"f16\"\n").unwrap().factor_storage, FactorStorage::Half);
        assert_eq!(p.multirate, None);
        let body = "[multirate]\ncentre = [0.0, 0.1, 0.0]\nradius = 0.02\nratio = 4\nfollow_tool = false\nbuild_exchanges = 12\nlate_build = \"wait\"\n";
        let m = parse(body).unwrap().multirate.expect("multirate on");
        assert_eq!((m.centre, m.radius, m.ratio, m.follow_tool), ([0.0, 0.1, 0.0], 0.02, 4, false));
        assert_eq!((m.build_exchanges, m.late_build), (Some(12), LateBuild::Wait));
        // Without a centre, the tool's.
        let t = solver_parameters(toml::from_str("[multirate]\n").unwrap(), 1000, Some([1.0, 2.0, 3.0])).unwrap();
        assert_eq!(t.multirate, Some(MultirateSettings { centre: [1.0, 2.0, 3.0], ..MultirateSettings::default() }));
    }

    #[test]
    fn solver_section_bad_values_name_the_field_fails() {
        let cases = [
            ("integrator = \"leapfrog\"\n", "solver.integrator"),
            ("substeps = 0\n", "solver.substeps"),
            ("substeps = \"many\"\n", "solver.substeps"),
            // Above the solver's cap: refused here, at its line, not when the simulation is built.
            ("substeps = 10001\n", "solver.substeps"),
            ("threads = 0\n", "solver.threads"),
            ("simd = \"sse9\"\n", "solver.simd"),
            ("stability_safety = -0.5\n", "solver.stability_safety"),
            ("cg_tolerance = nan\n", "solver.cg_tolerance"),
            ("factored_iterations = 0\n", "solver.factored_iterations"),
            ("factor_storage = \"f8\"\n", "solver.factor_storage"),
            ("rayleigh_beta = inf\n", "solver.rayleigh_beta"),
            ("max_substeps = 0\n", "solver.max_substeps"),
            ("cg_max_iterations = 0\n", "solver.cg_max_iterations"),
            ("[multirate]\nradius = 0.02\n", "solver.multirate.centre"),
            ("[multirate]\ncentre = [0.0, nan, 0.0]\n", "solver.multirate.centre"),
            ("[multirate]\ncentre = [0.0, 0.0, 0.0]\nradius = -0.02\n", "solver.multirate.radius"),
            ("[multirate]\ncentre = [0.0, 0.0, 0.0]\nratio = 1\n", "solver.multirate.ratio"),
            ("[multirate]\ncentre = [0.0, 0.0, 0.0]\nbuild_exchanges = 1\n", "solver.multirate.build_exchanges"),
            ("[multirate]\ncentre = [0.0, 0.0, 0.0]\nlate_build = \"never\"\n", "solver.multirate.late_build"),
        ];
        for (body, field) in cases {
            assert_eq!(parse(body).expect_err(body).field, field, "{body}");
        }
    }
}
