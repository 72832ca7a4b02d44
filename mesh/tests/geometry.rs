//! Ray casting and centrelines against closed-form answers.

use std::f64::consts::PI;

use lamina_mesh::{
    AxisChoice, CentrelineComputeError, CentrelineOptions, RayCaster, TriMesh, centreline, cross_section, synthetic,
};

#[test]
fn raycast_sphere_analytic_distance_works() {
    let (c, r) = ([0.1, -0.05, 0.2], 0.08);
    let sphere = synthetic::sphere(c, r, 5);
    let caster = RayCaster::new(&sphere);
    // Inscribed facets lie at most r (1 − cos 0.02) ≈ 2e-4 r inside the sphere.
    let tol = 5e-4 * r;
    for k in 0..50 {
        let (th, ph) = (k as f64 * 2.399_963, (2.0 * (k as f64 + 0.5) / 50.0 - 1.0).acos());
        let d = [ph.sin() * th.cos(), ph.sin() * th.sin(), ph.cos()];
        let dist = 0.3;
        let origin = [c[0] + dist * d[0], c[1] + dist * d[1], c[2] + dist * d[2]];
        let dir = [-d[0] * 3.0, -d[1] * 3.0, -d[2] * 3.0]; // not unit: normalised inside
        let hit = caster.cast(origin, dir, f64::INFINITY).unwrap();
        assert!((hit.t - (dist - r)).abs() < tol, "t {} vs {}", hit.t, dist - r);
        assert!(hit.normal.iter().zip(&d).map(|(a, b)| a * b).sum::<f64>() > 0.99, "outward normal");
        let pr = ((hit.point[0] - c[0]).powi(2) + (hit.point[1] - c[1]).powi(2) + (hit.point[2] - c[2]).powi(2)).sqrt();
        assert!((pr - r).abs() < tol);
        let all = caster.cast_all(origin, dir, f64::INFINITY);
        assert!(all.len() >= 2 && all.windows(2).all(|w| w[0].t <= w[1].t));
        assert!((all[0].t - hit.t).abs() < 1e-12);
        assert!((all.last().unwrap().t - (dist + r)).abs() < tol);
    }
}

#[test]
fn raycast_from_inside_and_misses_works() {
    let sphere = synthetic::sphere([0.0; 3], 1.0, 4);
    let caster = RayCaster::new(&sphere);
    let hit = caster.cast([0.0; 3], [0.1, 0.2, 1.0], 10.0).unwrap();
    assert!((hit.t - 1.0).abs() < 2e-3 && hit.normal[2] > 0.95);
    assert_eq!(caster.cast_all([0.0; 3], [0.1, 0.2, 1.0], 10.0).len(), 1);
    // Straight up passes through the pole vertex: one hit per triangle around it, same t.
    let pole = caster.cast_all([0.0; 3], [0.0, 0.0, 1.0], 10.0);
    assert_eq!(pole.len(), 6); // the pole is a subdivision vertex of valence 6
    assert!(pole.iter().all(|h| (h.t - 1.0).abs() < 1e-12));
    assert!(caster.cast([0.0, 0.0, 3.0], [0.0, 0.0, 1.0], 10.0).is_none(), "pointing away");
    assert!(caster.cast([0.0, 0.0, 3.0], [0.0, 0.0, -1.0], 1.5).is_none(), "max_t too short");
    assert!(caster.cast([0.0, 0.0, 3.0], [0.0; 3], 10.0).is_none(), "zero direction");
    assert!(caster.cast([f64::NAN, 0.0, 3.0], [0.0, 0.0, -1.0], 10.0).is_none());
    assert!(caster.cast_all([0.0, 0.0, 3.0], [0.0, 0.0, -1.0], 1.5).is_empty());
    assert!(RayCaster::new(&TriMesh::default()).cast([0.0; 3], [1.0, 0.0, 0.0], 1.0).is_none());
}

#[test]
fn raycast_cylinder_toward_axis_works() {
    // The generator's use: rays from outside toward the axis hit at the polygon's inradius or beyond.
    let n = 180;
    let r = 0.05;
    let cyl = synthetic::cylinder(r, 0.0, 0.5, n, 10);
    let caster = RayCaster::new(&cyl);
    for k in 0..36 {
        let a = 2.0 * PI * k as f64 / 36.0 + 0.01;
        let o = [0.2 * a.cos(), 0.2 * a.sin(), 0.25];
        let hit = caster.cast(o, [-a.cos(), -a.sin(), 0.0], 0.2).unwrap();
        let inradius = r * (PI / n as f64).cos();
        assert!(hit.t >= 0.2 - r - 1e-12 && hit.t <= 0.2 - inradius + 1e-12, "{}", hit.t);
    }
}

fn polygon_area(r: f64, n: usize) -> f64 {
    n as f64 / 2.0 * r * r * (2.0 * PI / n as f64).sin()
}

#[test]
fn centreline_cylinder_works() {
    let (n, r) = (256, 0.05);
    let mut cyl = synthetic::cylinder(r, 0.0, 0.5, n, 12);
    cyl.translate([0.1, -0.2, 0.3]);
    let line = centreline(&cyl, &CentrelineOptions::default()).unwrap();
    assert_eq!(line.axis, [0.0, 0.0, 1.0]);
    assert_eq!((line.sections.len(), line.missed.len()), (32, 0));
    assert!((line.sections[0].height - (0.3 + 0.5 / 64.0)).abs() < 1e-12);
    for s in &line.sections {
        assert!((s.centroid[0] - 0.1).abs() < 1e-12 && (s.centroid[1] + 0.2).abs() < 1e-12, "{s:?}");
        assert!((s.centroid[2] - s.height).abs() < 1e-12);
        assert!((s.area - polygon_area(r, n)).abs() < 1e-12);
        assert!((s.area - PI * r * r).abs() < 2e-4 * PI * r * r);
        assert!((s.mean_radius - r).abs() < 1e-4 * r);
        assert!((s.equivalent_radius - r).abs() < 1e-4 * r);
        assert!((s.perimeter - 2.0 * PI * r).abs() < 1e-4);
        assert_eq!((s.loops, s.open_chains), (1, 0));
    }
    assert_eq!(line.points().len(), 32);
}

#[test]
fn centreline_cone_works() {
    let n = 256;
    let (r0, r1, h) = (0.08, 0.02, 0.6);
    let cone = synthetic::cone(r0, r1, 0.0, h, n, 30);
    let opts = CentrelineOptions { stations: 7, range: Some((0.05, 0.55)), ..Default::default() };
    let line = centreline(&cone, &opts).unwrap();
    assert_eq!(line.sections.len(), 7);
    for s in &line.sections {
        let r = r0 + (r1 - r0) * s.height / h;
        assert!(s.centroid[0].abs() < 1e-12 && s.centroid[1].abs() < 1e-12);
        assert!((s.area - polygon_area(r, n)).abs() < 1e-12, "{} vs {}", s.area, polygon_area(r, n));
        assert!((s.area / (PI * r * r) - 1.0).abs() < 2e-4);
        assert!((s.mean_radius / r - 1.0).abs() < 1e-4);
    }
    // Station exactly through a ring of vertices (z = 0.1 is ring 5 of 30): still one loop.
    let s = cross_section(&cone, [0.0, 0.0, 1.0], 0.1).unwrap();
    assert_eq!((s.loops, s.open_chains), (1, 0));
    assert!((s.area - polygon_area(r0 + (r1 - r0) / 6.0, n)).abs() < 1e-12);
}

#[test]
fn centreline_axis_choices_works() {
    // A cylinder lying along x, shifted: longest box axis and principal axis both find x.
    let (v, t) = synthetic::cylinder(0.03, -0.2, 0.2, 64, 40).into_parts();
    let v = v.into_iter().map(|[x, y, z]| [z, x + 0.5, y]).collect();
    let lying = TriMesh::new(v, t).unwrap();
    let a = centreline(&lying, &CentrelineOptions::default()).unwrap().axis;
    assert_eq!(a, [1.0, 0.0, 0.0]);
    let p = centreline(&lying, &CentrelineOptions { axis: AxisChoice::Principal, ..Default::default() }).unwrap();
    assert!((p.axis[0] - 1.0).abs() < 1e-9, "{:?}", p.axis);
    for s in &p.sections {
        assert!((s.centroid[1] - 0.5).abs() < 1e-9 && s.centroid[2].abs() < 1e-9);
    }
    // A given, reversed axis: heights are measured along −x; loops still found.
    let opts = CentrelineOptions { axis: AxisChoice::Given([-2.0, 0.0, 0.0]), stations: 3, range: Some((-0.1, 0.1)) };
    let g = centreline(&lying, &opts).unwrap();
    assert_eq!(g.axis, [-1.0, 0.0, 0.0]);
    assert!((g.sections[0].centroid[0] - 0.1).abs() < 1e-12);
    assert!((g.nearest(0.09).unwrap().height - 0.1).abs() < 1e-12);
}

#[test]
fn centreline_sphere_section_and_misses_works() {
    let sphere = synthetic::sphere([0.0; 3], 0.1, 5);
    let s = cross_section(&sphere, [0.0, 0.0, 1.0], 0.0).unwrap();
    assert!((s.area / (PI * 0.01) - 1.0).abs() < 1e-3);
    let opts = CentrelineOptions { stations: 3, range: Some((0.0, 0.3)), ..Default::default() };
    let line = centreline(&sphere, &opts).unwrap();
    assert_eq!((line.sections.len(), line.missed.clone()), (1, vec![0.15, 0.3]));
    // The plane touching the pole vertex cuts no area: no section.
    assert!(cross_section(&sphere, [0.0, 0.0, 1.0], 0.1).is_none());
}

#[test]
fn centreline_bad_input_fails() {
    let cyl = synthetic::cylinder(0.05, 0.0, 0.5, 32, 4);
    let o = CentrelineOptions::default();
    assert_eq!(centreline(&TriMesh::default(), &o), Err(CentrelineComputeError::EmptyMesh));
    assert_eq!(centreline(&cyl, &CentrelineOptions { stations: 0, ..o }), Err(CentrelineComputeError::NoStations));
    let bad_axis = CentrelineOptions { axis: AxisChoice::Given([0.0; 3]), ..o };
    assert_eq!(centreline(&cyl, &bad_axis), Err(CentrelineComputeError::InvalidAxis));
    let nan = CentrelineOptions { range: Some((f64::NAN, 1.0)), ..o };
    assert_eq!(centreline(&cyl, &nan), Err(CentrelineComputeError::InvalidRange));
    let outside = CentrelineOptions { range: Some((1.0, 2.0)), ..o };
    assert_eq!(centreline(&cyl, &outside), Err(CentrelineComputeError::NoCrossSection));
    assert!(cross_section(&cyl, [0.0; 3], 0.1).is_none());
}
