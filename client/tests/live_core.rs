//! The C ABI against a live `lamina run` on the built-in default scene (1,032 nodes, its tool
//! following commands): the topology against the model built here with the physics library,
//! node frames in order, a sphere pressed deeper pushing back harder, a grasp pulling, and a
//! core killed with SIGKILL mid-read giving `LAMINA_STATUS_CORE_GONE`.

mod common;

use core::ffi::CStr;
use std::time::{Duration, Instant};

use common::{SERIAL, message, start_core, stop};
use lamina_client::*;
use lamina_core::scene::Scene;
use lamina_tests::{kill9, unique_prefix};

/// How long a core may take to start on a loaded machine, ms.
const OPEN_TIMEOUT_MS: u32 = 60_000;

fn open(prefix: &str) -> LaminaClient {
    let text = std::ffi::CString::new(prefix).unwrap();
    let mut client = 0;
    // SAFETY: a NUL-terminated prefix and a valid out pointer.
    let status = unsafe { lamina_open(text.as_ptr(), OPEN_TIMEOUT_MS, &mut client) };
    assert_eq!(status, LaminaStatus::Ok, "{}", message());
    client
}

fn next_frame(client: LaminaClient, positions: &mut [f32]) -> LaminaFrameInfo {
    let mut info = LaminaFrameInfo::default();
    // SAFETY: `positions` holds `len / 3` nodes.
    let s = unsafe { lamina_next_frame(client, 10_000, positions.as_mut_ptr(), positions.len() / 3, &mut info) };
    assert_eq!(s, LaminaStatus::Ok, "{}", message());
    info
}

/// The node to press on: the top of the model (max y, within 1 mm) nearest its middle in x
/// and z; as `examples/python/haptic_driver.py` chooses it.
fn touch_point(positions: &[f32]) -> [f64; 3] {
    let nodes: Vec<[f64; 3]> = positions.chunks_exact(3).map(|p| [p[0].into(), p[1].into(), p[2].into()]).collect();
    let top = nodes.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &nodes {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let mid = [(lo[0] + hi[0]) / 2.0, (lo[2] + hi[2]) / 2.0];
    let d = |p: &[f64; 3]| (p[0] - mid[0]).powi(2) + (p[2] - mid[1]).powi(2);
    *nodes.iter().filter(|p| p[1] >= top - 1e-3).min_by(|a, b| d(a).total_cmp(&d(b))).expect("a top node")
}

/// Holds the tool at `centre` (buttons as given) for `seconds`, commanding every 2 ms; the
/// mean feedback force of the second half and whether every such feedback was in contact.
fn hold(client: LaminaClient, centre: [f64; 3], radius: f64, closed: u32, seconds: f64) -> ([f64; 3], bool, usize) {
    let start = Instant::now();
    let (mut sum, mut kept, mut contact) = ([0.0; 3], 0usize, true);
    let mut last_sequence = None;
    while start.elapsed().as_secs_f64() < seconds {
        let s = lamina_send_grasp(client, centre[0], centre[1], centre[2], radius, closed);
        assert_eq!(s, LaminaStatus::Ok, "{}", message());
        let mut fb = LaminaFeedback::default();
        // SAFETY: valid out pointer.
        let s = unsafe { lamina_latest_feedback(client, 1_000, &mut fb) };
        assert_eq!(s, LaminaStatus::Ok, "{}", message());
        if start.elapsed().as_secs_f64() >= seconds / 2.0 && last_sequence != Some(fb.sequence) {
            (0..3).for_each(|c| sum[c] += fb.force[c]);
            kept += 1;
            contact &= fb.in_contact == 1;
        }
        last_sequence = Some(fb.sequence);
        std::thread::sleep(Duration::from_millis(2));
    }
    (sum.map(|s| s / kept.max(1) as f64), contact && kept > 0, kept)
}

#[test]
fn topology_frames_and_a_press_against_lamina_run_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("client_live");
    let core = start_core(&prefix);
    let client = open(&prefix);

    // The topology against the model built here from the same built-in scene.
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let n = model.nodes.position.len();
    let mut info = LaminaTopologyInfo::default();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_topology_info(client, &mut info) }, LaminaStatus::Ok);
    assert_eq!(info.node_count as usize, n);
    assert_eq!(info.rest_position_count as usize, n);
    assert_eq!(info.spring_count as usize, model.springs.len());
    assert_eq!(info.surface_count as usize, model.surfaces.len());
    // SAFETY: NUL-terminated by the library.
    assert_eq!(unsafe { CStr::from_ptr(info.model_name.as_ptr()) }.to_str(), Ok(model.name.as_str()));
    assert_eq!(info.tool.source, 2, "the default scene's tool follows commands");
    let tool = scene.tool.expect("the default scene has a tool");
    assert_eq!(info.tool.radius_m, tool.radius);
    for (i, s) in model.surfaces.iter().enumerate() {
        let mut got = LaminaSurfaceInfo::default();
        // SAFETY: valid out pointer.
        assert_eq!(unsafe { lamina_surface_info(client, i as u32, &mut got) }, LaminaStatus::Ok);
        // SAFETY: NUL-terminated by the library.
        assert_eq!(unsafe { CStr::from_ptr(got.name.as_ptr()) }.to_str(), Ok(s.name.as_str()));
        let grid = s.grid.as_ref().map_or((0, 0), |(c, r, _)| (*c, *r));
        assert_eq!((got.grid_cols, got.grid_rows), grid, "surface {}", s.name);
    }
    let mut layer_nodes = 0;
    for i in 0..info.layer_count {
        let mut l = LaminaLayerInfo::default();
        // SAFETY: valid out pointer.
        assert_eq!(unsafe { lamina_layer_info(client, i, &mut l) }, LaminaStatus::Ok);
        layer_nodes += l.node_count as usize;
    }
    assert_eq!(layer_nodes, n, "the layers cover every node");
    let mut rest = vec![0f32; 3 * n];
    let mut count = 0;
    // SAFETY: `rest` holds n nodes.
    assert_eq!(unsafe { lamina_rest_positions(client, rest.as_mut_ptr(), n, &mut count) }, LaminaStatus::Ok);
    assert_eq!(count, n);
    for (i, p) in model.nodes.position.iter().enumerate() {
        for c in 0..3 {
            assert!(
                (f64::from(rest[3 * i + c]) - p[c]).abs() < 1e-6,
                "node {i} axis {c}: {} vs {}",
                rest[3 * i + c],
                p[c]
            );
        }
    }

    // 1,000 frames in order: every frame carries every node, finite, near its rest position.
    let mut positions = vec![0f32; 3 * n];
    let first = next_frame(client, &mut positions);
    let (mut last, mut gaps) = (first.sequence, 0);
    for _ in 1..1000 {
        let f = next_frame(client, &mut positions);
        assert_eq!(f.node_count as usize, n);
        assert!(f.sequence > last, "sequence {} after {last}", f.sequence);
        gaps += f.sequence - last - 1;
        last = f.sequence;
    }
    assert!(positions.iter().all(|v| v.is_finite()));
    let moved = positions.iter().zip(&rest).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
    assert!(moved < 2e-3, "the parked limb stays within 2 mm of rest: {moved} m");
    // A frame is lost only when this thread was descheduled for 16 ms: 2 % at most.
    assert!(gaps <= 20, "{gaps} frames lost in 1,000");
    let mut newest = LaminaFrameInfo::default();
    // SAFETY: `positions` holds n nodes.
    let s = unsafe { lamina_latest_frame(client, 10_000, positions.as_mut_ptr(), n, &mut newest) };
    assert_eq!(s, LaminaStatus::Ok, "{}", message());
    assert!(newest.sequence > last);

    // Press: clear of the skin no force; 2, 4 and 6 mm deep, the skin pushes up harder.
    let touch = touch_point(&positions);
    let r = tool.radius;
    let at = |depth: f64| [touch[0], touch[1] + r - depth, touch[2]];
    let (free, free_contact, _) = hold(client, at(-0.003), r, 0, 0.4);
    assert_eq!((free, free_contact), ([0.0; 3], false), "3 mm above the skin");
    let mut ups = Vec::new();
    for depth in [0.002, 0.004, 0.006] {
        let (force, contact, kept) = hold(client, at(depth), r, 0, 0.5);
        eprintln!("depth {:.1} mm: force {force:?} N over {kept} feedback messages", depth * 1e3);
        assert!(contact, "in contact at {depth} m");
        assert!(force[1] > 0.0, "the skin pushes the tool up at {depth} m: {force:?}");
        ups.push(force[1]);
    }
    assert!(ups[0] < ups[1] && ups[1] < ups[2], "force rises with depth: {ups:?}");

    // Grasp at 4 mm, then lift 4 mm above the skin's rest height: the held skin pulls down.
    hold(client, at(0.004), r, 1, 0.3);
    let (pull, held, _) = hold(client, at(-0.004), r, 1, 0.5);
    assert!(held, "the grasp holds");
    assert!(pull[1] < 0.0, "the lifted skin pulls the tool down: {pull:?}");
    hold(client, at(-0.02), r, 0, 0.2);

    assert_eq!(lamina_close(client), LaminaStatus::Ok);
    stop(core);
}

#[test]
fn a_core_killed_mid_read_gives_core_gone_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("client_kill");
    let mut core = start_core(&prefix);
    let client = open(&prefix);
    let mut info = LaminaTopologyInfo::default();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_topology_info(client, &mut info) }, LaminaStatus::Ok);
    let mut positions = vec![0f32; 3 * info.node_count as usize];
    for _ in 0..100 {
        next_frame(client, &mut positions);
    }
    kill9(&mut core);
    let start = Instant::now();
    let status = loop {
        let mut f = LaminaFrameInfo::default();
        // SAFETY: `positions` holds node_count nodes.
        let s = unsafe { lamina_next_frame(client, 200, positions.as_mut_ptr(), info.node_count as usize, &mut f) };
        if s != LaminaStatus::Ok {
            break s;
        }
        assert!(start.elapsed() < Duration::from_secs(60), "frames still arrive 60 s after SIGKILL");
    };
    assert_eq!(status, LaminaStatus::CoreGone, "{}", message());
    assert!(message().contains(&format!("the core on prefix '{prefix}' is gone")), "{}", message());
    assert_eq!(lamina_send_sphere(client, 0.0, 0.2, 0.0, 0.0), LaminaStatus::Ok, "a command to nobody is sent");
    assert_eq!(lamina_close(client), LaminaStatus::Ok);
}
