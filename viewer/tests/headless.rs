//! Renders Lamina's default scene headless and compares it with the committed reference image
//! `tests/reference/default.png`: the core's built-in default scene (the generator's
//! cylindrical limb) simulated by the physics library with the haptic tool pressing 8 mm into
//! the skin, drawn through the same `ViewModel` the live viewer builds from the core's model.
//! The viewer's own synthetic limb (`--synthetic`, no core needed) has its reference too,
//! `tests/reference/synthetic.png`.
//!
//! Regenerate the references with `UPDATE_REFERENCE=1 cargo test -p lamina-viewer --test headless`
//! (and look at them). Without a Vulkan or GL adapter the tests print SKIP, unless
//! `LAMINA_REQUIRE_GPU_SOFTWARE=1` (set by CI), which makes them fail.
//!
//! Tolerance: lavapipe renders the same image bit for bit on one machine, but another Mesa or
//! LLVM version (or CPU vector width) may round edges, MSAA coverage and `pow` differently by a
//! few levels on a few pixels. A mean absolute difference below 1.5 levels (of 255) per channel,
//! with at most 0.5 % of pixels off by more than 48 levels, absorbs that, while any real change
//! (a missing layer, a moved camera, a different material) moves far more than that: the cut
//! face of one tissue alone covers over 2 % of the image. The simulated positions themselves
//! are the same bits on every SIMD level (`core/tests/yardstick.rs`).

use core::time::Duration;
use std::path::{Path, PathBuf};

use glam::Vec3;
use lamina_core::hand_tool::HandTool;
use lamina_core::scene::{Scene, ToolSource};
use lamina_viewer::app::{HeadlessViewer, Hud, ViewerOptions};
use lamina_viewer::png_io::{read_png, write_png};
use lamina_viewer::source::{FrameSource, SourceEvent, SyntheticSource};
use lamina_viewer::synthetic::SyntheticLimb;
use lamina_viewer::view_model::{Frame, ToolPose, ViewModel};

const MEAN_ABS_DIFF_LIMIT: f64 = 1.5;
const BAD_PIXEL_LEVEL: u8 = 48;
const BAD_PIXEL_FRACTION_LIMIT: f64 = 0.005;

fn reference_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference").join(format!("{name}.png"))
}

/// A 320 × 240 headless viewer, or `None` (SKIP) without an adapter when allowed. The volume
/// texture is off: these references check the geometry, cut faces and tissue colours (the
/// texture has its own tests, `tests/volume_texture.rs`).
fn viewer() -> Option<HeadlessViewer> {
    match HeadlessViewer::new(ViewerOptions { texture: false, ..ViewerOptions::default() }) {
        Ok(v) => {
            eprintln!("adapter: {}", v.adapter());
            Some(v)
        }
        Err(e) => {
            if std::env::var("LAMINA_REQUIRE_GPU_SOFTWARE").as_deref() == Ok("1") {
                panic!("LAMINA_REQUIRE_GPU_SOFTWARE=1 but no GPU adapter is available: {e}");
            }
            eprintln!("SKIP headless render test: {e}");
            None
        }
    }
}

/// The built-in default scene after 0.4 s: the tool parked for 0.1 s while gravity settles
/// the limb, then lowered from the device's centre (touching the skin) 8 mm into it over
/// 0.2 s and held. Fixed overlay text (no timings, so the image does not depend on the
/// machine's speed).
fn render_default_scene() -> Option<(u32, u32, Vec<u8>)> {
    let mut viewer = viewer()?;
    let scene = Scene::builtin_default();
    let model = scene.build_model().expect("the default scene builds");
    let tool = scene.tool.expect("the default scene has a tool");
    let ToolSource::Haptics { device_origin, .. } = tool.source else { panic!("a haptics tool") };
    let (mut sim, mut hand) = HandTool::simulation::<f32>(&model, scene.solver.clone(), scene.effects.clone(), tool)
        .expect("the default scene steps");
    let frames = (0.4 * scene.rate_hz as f64) as usize;
    let mut centre = device_origin;
    for k in 0..frames {
        let t = k as f64 / scene.rate_hz as f64;
        if t >= 0.1 {
            let press = 0.008 * ((t - 0.1) / 0.2).min(1.0);
            centre = [device_origin[0], device_origin[1] - press, device_origin[2]];
            hand.move_to(&mut sim, centre, None);
        }
        sim.step();
    }
    let x = &sim.state().x;
    assert!(x.all_finite());
    let positions = (0..x.len()).map(|i| Vec3::from_array(x.get(i))).collect();
    viewer.set_model(ViewModel::from_core_model(&model));
    let frame = Frame {
        sequence: frames as u64,
        sim_time_s: sim.state().time,
        publish_time_ns: 0,
        positions,
        tool: Some(ToolPose { center: Vec3::from_array(centre.map(|c| c as f32)), radius: tool.radius as f32 }),
        stats: None,
    };
    let hud = Hud { lines: vec!["LAMINA  DEFAULT SCENE".into(), "HEADLESS REFERENCE FRAME".into()] };
    viewer.render(&frame, &hud).expect("frame reads back");
    let (w, h) = viewer.size();
    Some((w, h, viewer.pixels().to_vec()))
}

/// The viewer's synthetic limb at t = 0.5 s, fixed overlay text.
fn render_synthetic_limb() -> Option<(u32, u32, Vec<u8>)> {
    let mut viewer = viewer()?;
    let mut source = SyntheticSource::new(SyntheticLimb::default(), 60.0, 0.5);
    let SourceEvent::Model(model) = source.next_event(Duration::ZERO) else {
        panic!("synthetic source starts with its model")
    };
    viewer.set_model(model);
    let SourceEvent::Frame(frame) = source.next_event(Duration::ZERO) else { panic!("then frames") };
    let hud = Hud { lines: vec!["LAMINA  SYNTHETIC LIMB".into(), "HEADLESS REFERENCE FRAME".into()] };
    viewer.render(&frame, &hud).expect("frame reads back");
    let (w, h) = viewer.size();
    Some((w, h, viewer.pixels().to_vec()))
}

#[test]
fn headless_default_scene_matches_reference_works() {
    if let Some(image) = render_default_scene() {
        compare_with_reference("default", image);
    }
}

#[test]
fn headless_synthetic_limb_matches_reference_works() {
    if let Some(image) = render_synthetic_limb() {
        compare_with_reference("synthetic", image);
    }
}

fn compare_with_reference(name: &str, (w, h, actual): (u32, u32, Vec<u8>)) {
    let path = reference_path(name);
    if std::env::var("UPDATE_REFERENCE").as_deref() == Ok("1") {
        write_png(&path, w, h, &actual).expect("reference written");
        eprintln!("wrote {}", path.display());
        return;
    }
    let actual_path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}.actual.png"));
    write_png(&actual_path, w, h, &actual).expect("actual image written");
    let (rw, rh, reference) =
        read_png(&path).unwrap_or_else(|e| panic!("{}: {e} (create it with UPDATE_REFERENCE=1)", path.display()));
    assert_eq!((rw, rh), (w, h), "reference size differs; rendered image: {}", actual_path.display());
    let mut sum = 0u64;
    let mut bad = 0usize;
    for (a, r) in actual.chunks_exact(4).zip(reference.chunks_exact(4)) {
        let diffs: Vec<u8> = (0..3).map(|k| a[k].abs_diff(r[k])).collect();
        sum += diffs.iter().map(|&d| u64::from(d)).sum::<u64>();
        if diffs.iter().any(|&d| d > BAD_PIXEL_LEVEL) {
            bad += 1;
        }
    }
    let pixels = (w * h) as usize;
    let mean = sum as f64 / (3 * pixels) as f64;
    let bad_fraction = bad as f64 / pixels as f64;
    eprintln!(
        "mean absolute difference {mean:.3} levels, {:.3} % pixels off by > {BAD_PIXEL_LEVEL}",
        100.0 * bad_fraction
    );
    assert!(
        mean < MEAN_ABS_DIFF_LIMIT && bad_fraction < BAD_PIXEL_FRACTION_LIMIT,
        "rendered image differs from {}: mean {mean:.3} (limit {MEAN_ABS_DIFF_LIMIT}), {:.3} % bad pixels (limit {:.3} %); \
         rendered image: {}",
        path.display(),
        100.0 * bad_fraction,
        100.0 * BAD_PIXEL_FRACTION_LIMIT,
        actual_path.display()
    );
}

#[test]
fn headless_default_scene_is_deterministic_works() {
    let Some((_, _, a)) = render_default_scene() else { return };
    let Some((_, _, b)) = render_default_scene() else { return };
    assert!(a == b, "two renders of the same frame differ");
}
