//! The C ABI's edge without a `lamina` process: bad and closed handles, NULL pointers, bad
//! arguments, the open timeout with no core, and a stand-in core (a thread publishing a small
//! topology and node frames with `lamina-bridge`) that stops mid-read. Every call is made as a
//! C program makes it, through the exported functions.

use core::ffi::{CStr, c_char};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lamina_bridge::{
    Bridge, BridgeConfig, LayerRange, NodesPublisher, SurfaceTopology, TissueKind, Topology, TopologyPublisher,
};
use lamina_client::*;

/// Longest wait for anything the stand-in core does.
const WATCHDOG_MS: u32 = 30_000;

fn unique(tag: &str) -> String {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    format!("t_client_{tag}_{}_{nanos}", std::process::id())
}

fn message() -> String {
    // SAFETY: the library returns a NUL-terminated string valid until the next failing call.
    unsafe { CStr::from_ptr(lamina_last_error_message()) }.to_str().expect("UTF-8").to_owned()
}

fn open(prefix: &str, timeout_ms: u32) -> (LaminaStatus, LaminaClient) {
    let text = std::ffi::CString::new(prefix).unwrap();
    let mut client: LaminaClient = 0;
    // SAFETY: a NUL-terminated prefix and a valid out pointer.
    let status = unsafe { lamina_open(text.as_ptr(), timeout_ms, &mut client) };
    (status, client)
}

/// A 2 x 3 grid of nodes, 1 cm apart in x and z, at y = 0.05 m.
fn small_topology(tool_source: u32) -> Topology {
    let rest: Vec<[f32; 3]> = (0..6).map(|i| [0.01 * (i % 2) as f32, 0.05, 0.01 * (i / 2) as f32]).collect();
    Topology {
        name: "six nodes".into(),
        node_count: 6,
        triangles: vec![[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4]],
        layers: vec![LayerRange { name: "skin".into(), tissue: TissueKind::Skin, first_node: 0, node_count: 6 }],
        surfaces: vec![SurfaceTopology {
            name: "skin_outer".into(),
            tissue: TissueKind::Skin,
            grid: Some((2, 3)),
            indices: (0..6).collect(),
        }],
        springs: vec![[0, 1], [2, 3], [4, 5]],
        spring_layer: vec![0, 0, 0],
        node_layer: vec![0; 6],
        rest_positions: rest,
        tool: lamina_bridge::WireTool { source: tool_source, radius_m: 0.012, ..Default::default() },
        ..Topology::default()
    }
}

/// A stand-in core on its own thread: serves the topology to late joiners and publishes a
/// frame every millisecond (node `i` at its rest position plus `sequence` µm in y) until
/// stopped; stopping drops its publishers, as a killed core's go.
struct FakeCore {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<u64>>,
}

impl FakeCore {
    fn start(prefix: &str, topology: Topology) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let (flag, prefix) = (stop.clone(), prefix.to_owned());
        let thread = std::thread::spawn(move || {
            let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
            let mut topo_pub = TopologyPublisher::create(&bridge, topology.word_count()).unwrap();
            topo_pub.publish(&topology).unwrap();
            let nodes = NodesPublisher::create(&bridge, topology.node_count as usize).unwrap();
            let rest = topology.rest_positions.clone();
            let mut sequence = 0u64;
            while !flag.load(Ordering::Relaxed) {
                topo_pub.serve_late_joiners().unwrap();
                let lift = sequence as f32 * 1e-6;
                nodes
                    .publish_from_fn(sequence, 2 * sequence, 0.001 * sequence as f64, rest.len(), |i| {
                        [rest[i][0], rest[i][1] + lift, rest[i][2]]
                    })
                    .unwrap();
                sequence += 1;
                std::thread::sleep(Duration::from_millis(1));
            }
            sequence
        });
        Self { stop, thread: Some(thread) }
    }

    /// Stops the core; the number of frames it published.
    fn stop(&mut self) -> u64 {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.take().map_or(0, |t| t.join().expect("the stand-in core ran"))
    }
}

impl Drop for FakeCore {
    fn drop(&mut self) {
        self.stop();
    }
}

#[test]
fn open_with_no_core_times_out_with_a_message_works() {
    let prefix = unique("none");
    let start = Instant::now();
    let (status, client) = open(&prefix, 300);
    assert_eq!(status, LaminaStatus::Timeout);
    assert_eq!(client, 0, "the out handle is left as it was");
    assert!(start.elapsed() >= Duration::from_millis(300), "the timeout given is obeyed, not cut short");
    let text = message();
    assert!(text.contains(&format!("no Lamina core answered on prefix '{prefix}' within 300 ms")), "{text}");
    assert!(text.contains("lamina run --prefix"), "the message says what to start: {text}");
    // SAFETY: lamina_status_name returns a static string.
    let name = unsafe { CStr::from_ptr(lamina_status_name(status as i32)) };
    assert_eq!(name.to_str(), Ok("LAMINA_STATUS_TIMEOUT"));
}

#[test]
fn null_pointers_and_bad_arguments_are_refused_works() {
    let mut client: LaminaClient = 7;
    // SAFETY: NULL is allowed by the contract and refused.
    assert_eq!(unsafe { lamina_open(core::ptr::null(), 10, &mut client) }, LaminaStatus::NullPointer);
    assert_eq!(message(), "lamina_open: prefix is NULL");
    // SAFETY: as above.
    assert_eq!(unsafe { lamina_open(c"x".as_ptr(), 10, core::ptr::null_mut()) }, LaminaStatus::NullPointer);
    assert_eq!(message(), "lamina_open: out_client is NULL");
    let invalid = [0xffu8, 0xfe, 0];
    // SAFETY: a NUL-terminated string that is not UTF-8.
    assert_eq!(
        unsafe { lamina_open(invalid.as_ptr().cast::<c_char>(), 10, &mut client) },
        LaminaStatus::InvalidArgument
    );
    assert!(message().contains("prefix is not UTF-8"), "{}", message());
    // SAFETY: an empty string.
    assert_eq!(unsafe { lamina_open(c"".as_ptr(), 10, &mut client) }, LaminaStatus::InvalidArgument);
    assert!(message().contains("prefix '' is not a service prefix"), "{}", message());
    assert_eq!(client, 7, "never written on failure");
    assert_eq!(lamina_send_grasp(1, 0.0, 0.0, 0.0, 0.0, 2), LaminaStatus::InvalidArgument);
    assert!(message().contains("closed = 2 is neither 0"), "{}", message());
    // SAFETY: lamina_status_name returns a static string.
    assert_eq!(unsafe { CStr::from_ptr(lamina_status_name(99)) }.to_str(), Ok("LAMINA_STATUS_UNKNOWN"));
    assert_eq!(lamina_abi_version(), LAMINA_ABI_VERSION);
}

#[test]
fn bad_handles_are_refused_by_every_call_works() {
    let mut info = LaminaTopologyInfo::default();
    let mut frame = LaminaFrameInfo::default();
    let mut feedback = LaminaFeedback::default();
    let mut layer = LaminaLayerInfo::default();
    let mut surface = LaminaSurfaceInfo::default();
    let mut positions = [0f32; 30];
    let mut words = [0u32; 30];
    let mut count = 0usize;
    let command = LaminaToolCommand::default();
    for handle in [0, u64::MAX, 123_456_789] {
        // SAFETY: every pointer is valid; the handle is what is wrong.
        let statuses = unsafe {
            [
                lamina_topology_info(handle, &mut info),
                lamina_layer_info(handle, 0, &mut layer),
                lamina_surface_info(handle, 0, &mut surface),
                lamina_surface_indices(handle, 0, words.as_mut_ptr(), words.len(), &mut count),
                lamina_triangles(handle, words.as_mut_ptr(), words.len(), &mut count),
                lamina_rest_positions(handle, positions.as_mut_ptr(), 10, &mut count),
                lamina_next_frame(handle, 1, positions.as_mut_ptr(), 10, &mut frame),
                lamina_latest_frame(handle, 1, positions.as_mut_ptr(), 10, &mut frame),
                lamina_send_tool(handle, &command),
                lamina_send_sphere(handle, 0.0, 0.0, 0.0, 0.0),
                lamina_send_grasp(handle, 0.0, 0.0, 0.0, 0.0, 1),
                lamina_send_scalpel(handle, 0.0, 0.0, 0.0, 0.01),
                lamina_latest_feedback(handle, 1, &mut feedback),
                lamina_close(handle),
            ]
        };
        for (i, s) in statuses.iter().enumerate() {
            assert_eq!(*s, LaminaStatus::BadHandle, "call {i} with handle {handle}: {}", message());
        }
        let text = message();
        if handle == 0 {
            assert!(text.contains("handle 0 is not a client"), "{text}");
        } else {
            assert!(text.contains(&format!("handle {handle} was never opened")), "{text}");
        }
    }
    let mut buf = [0u8; 16];
    // SAFETY: a 16-byte buffer.
    let len = unsafe { lamina_last_error_copy(buf.as_mut_ptr().cast(), buf.len()) };
    assert_eq!(len, message().len());
    assert_eq!(&buf[..15], &message().as_bytes()[..15]);
    assert_eq!(buf[15], 0, "NUL-terminated when truncated");
}

#[test]
fn a_stand_in_core_is_read_and_its_end_is_told_works() {
    let prefix = unique("fake");
    let topology = small_topology(2);
    let mut core = FakeCore::start(&prefix, topology.clone());
    let (status, client) = open(&prefix, WATCHDOG_MS);
    assert_eq!(status, LaminaStatus::Ok, "{}", message());
    assert_ne!(client, 0);

    let mut info = LaminaTopologyInfo::default();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_topology_info(client, &mut info) }, LaminaStatus::Ok);
    assert_eq!((info.node_count, info.triangle_count, info.layer_count, info.surface_count), (6, 4, 1, 1));
    assert_eq!((info.spring_count, info.rest_position_count, info.tool.source), (3, 6, 2));
    // SAFETY: the library NUL-terminates the name.
    assert_eq!(unsafe { CStr::from_ptr(info.model_name.as_ptr()) }.to_str(), Ok("six nodes"));
    let mut surface = LaminaSurfaceInfo::default();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_surface_info(client, 0, &mut surface) }, LaminaStatus::Ok);
    assert_eq!((surface.grid_cols, surface.grid_rows, surface.index_count, surface.tissue), (2, 3, 6, 1));
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_surface_info(client, 1, &mut surface) }, LaminaStatus::InvalidArgument);
    assert!(message().contains("surface index 1 is past the table (1 entries)"), "{}", message());
    let mut words = [0u32; 12];
    let mut count = 0;
    // SAFETY: a 12-word buffer given as 12.
    assert_eq!(unsafe { lamina_triangles(client, words.as_mut_ptr(), 12, &mut count) }, LaminaStatus::Ok);
    assert_eq!(&words[..count], topology.triangles.as_flattened());
    // SAFETY: a buffer given as smaller than it is.
    assert_eq!(unsafe { lamina_triangles(client, words.as_mut_ptr(), 11, &mut count) }, LaminaStatus::BufferTooSmall);
    assert!(message().contains("indices holds 11, the model needs 12"), "{}", message());
    let mut rest = [0f32; 18];
    // SAFETY: 6 nodes of room.
    assert_eq!(unsafe { lamina_rest_positions(client, rest.as_mut_ptr(), 6, &mut count) }, LaminaStatus::Ok);
    assert_eq!((count, &rest[..]), (6, topology.rest_positions.as_flattened()));

    // Frames in order, each the stand-in's rest positions lifted by `sequence` µm.
    let mut positions = [0f32; 18];
    let mut frame = LaminaFrameInfo::default();
    let mut last = None;
    for _ in 0..50 {
        // SAFETY: 6 nodes of room.
        let s = unsafe { lamina_next_frame(client, WATCHDOG_MS, positions.as_mut_ptr(), 6, &mut frame) };
        assert_eq!(s, LaminaStatus::Ok, "{}", message());
        assert_eq!((frame.node_count, frame.tick), (6, 2 * frame.sequence));
        let lift = frame.sequence as f32 * 1e-6;
        assert_eq!(positions[4], topology.rest_positions[1][1] + lift, "node 1's y of frame {}", frame.sequence);
        assert!(last.is_none_or(|l| frame.sequence > l), "sequence {} after {last:?}", frame.sequence);
        last = Some(frame.sequence);
    }
    // SAFETY: a buffer of 5 nodes given as 5.
    let s = unsafe { lamina_next_frame(client, 10, positions.as_mut_ptr(), 5, &mut frame) };
    assert_eq!(s, LaminaStatus::BufferTooSmall);
    assert!(message().contains("capacity_nodes holds 5, the model needs 6"), "{}", message());

    // The handle is this thread's: another thread is told so.
    let other = std::thread::spawn(move || {
        let mut info = LaminaTopologyInfo::default();
        // SAFETY: valid out pointer.
        (unsafe { lamina_topology_info(client, &mut info) }, message())
    });
    let (s, text) = other.join().unwrap();
    assert_eq!(s, LaminaStatus::WrongThread);
    assert!(text.contains(&format!("handle {client} belongs to thread")), "{text}");

    // Commands out of the core's bounds never leave.
    assert_eq!(lamina_send_sphere(client, 0.0, f64::NAN, 0.0, 0.01), LaminaStatus::InvalidArgument);
    assert!(message().contains("position y = NaN m is not finite or beyond the bound of 1000 m per coordinate"));
    assert_eq!(lamina_send_sphere(client, 0.0, 0.0, -1000.0, 0.01), LaminaStatus::InvalidArgument);
    assert!(message().contains("position z = -1000 m"), "{}", message());
    assert_eq!(lamina_send_sphere(client, 0.0, 0.0, 0.0, 1.0), LaminaStatus::InvalidArgument);
    assert!(message().contains("radius 1 m is outside 0 <= r < 1 m"), "{}", message());
    assert_eq!(lamina_send_sphere(client, 0.0, 0.06, 0.01, 0.01), LaminaStatus::Ok, "{}", message());

    // The core stops mid-read: queued frames are still read, then the end is told.
    let published = core.stop();
    let ended = loop {
        // SAFETY: 6 nodes of room.
        let s = unsafe { lamina_next_frame(client, 200, positions.as_mut_ptr(), 6, &mut frame) };
        if s != LaminaStatus::Ok {
            break s;
        }
        assert!(frame.sequence < published);
    };
    assert_eq!(ended, LaminaStatus::CoreGone, "{}", message());
    assert!(message().contains(&format!("the core on prefix '{prefix}' is gone")), "{}", message());
    let mut feedback = LaminaFeedback::default();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_latest_feedback(client, 20, &mut feedback) }, LaminaStatus::CoreGone);

    assert_eq!(lamina_close(client), LaminaStatus::Ok);
    assert_eq!(lamina_close(client), LaminaStatus::BadHandle);
    assert!(message().contains(&format!("handle {client} is closed")), "{}", message());
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_topology_info(client, &mut info) }, LaminaStatus::BadHandle);
}

#[test]
fn a_scene_without_a_commanded_tool_refuses_tool_commands_works() {
    let prefix = unique("scripted");
    let _core = FakeCore::start(&prefix, small_topology(1));
    let (status, client) = open(&prefix, WATCHDOG_MS);
    assert_eq!(status, LaminaStatus::Ok, "{}", message());
    assert_eq!(lamina_send_sphere(client, 0.0, 0.0, 0.0, 0.0), LaminaStatus::NoTool);
    assert!(message().contains("tool source 1"), "{}", message());
    let mut feedback = LaminaFeedback::default();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { lamina_latest_feedback(client, 20, &mut feedback) }, LaminaStatus::Timeout);
    assert!(message().contains("does not follow tool commands (tool source 1)"), "{}", message());
    // SAFETY: NULL out pointers are refused.
    assert_eq!(unsafe { lamina_topology_info(client, core::ptr::null_mut()) }, LaminaStatus::NullPointer);
    // SAFETY: as above.
    let s = unsafe { lamina_next_frame(client, 10, core::ptr::null_mut(), 6, &mut LaminaFrameInfo::default()) };
    assert_eq!(s, LaminaStatus::NullPointer);
    assert_eq!(message(), "lamina_next_frame: positions is NULL");
    assert_eq!(lamina_close(client), LaminaStatus::Ok);
}

#[test]
fn scalpel_commands_reach_the_core_as_sent_works() {
    // The C struct as the header lays it out: the wire's kind after the buttons, the blade
    // length last (ABI version 2).
    assert_eq!(LAMINA_ABI_VERSION, 2);
    assert_eq!(
        (core::mem::offset_of!(LaminaToolCommand, kind), core::mem::offset_of!(LaminaToolCommand, blade_length_m)),
        (68, 72)
    );
    assert_eq!(core::mem::size_of::<LaminaToolCommand>(), 80);
    let prefix = unique("scalpel");
    let _core = FakeCore::start(&prefix, small_topology(2));
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let tool = lamina_bridge::ToolSubscriber::create(&bridge).unwrap();
    let (status, client) = open(&prefix, WATCHDOG_MS);
    assert_eq!(status, LaminaStatus::Ok, "{}", message());
    let received = || {
        let sample = tool.receive_timeout(Duration::from_millis(WATCHDOG_MS.into())).unwrap();
        *sample.expect("the command arrives").message()
    };
    assert_eq!(lamina_send_scalpel(client, 0.0, 0.044, 0.12, 0.01), LaminaStatus::Ok, "{}", message());
    let got = received();
    assert_eq!((got.kind(), got.blade_length_m), (Ok(lamina_bridge::ToolKind::Scalpel), 0.01));
    assert_eq!((got.position, got.orientation, got.buttons), ([0.0, 0.044, 0.12], [0.0, 0.0, 0.0, 1.0], 0));
    // Through lamina_send_tool: the edge turned 90 degrees about z (+y to -x).
    let h = core::f64::consts::FRAC_1_SQRT_2;
    let turned = LaminaToolCommand {
        position: [0.0, 0.05, 0.1],
        orientation: [0.0, 0.0, h, h],
        kind: LAMINA_TOOL_SCALPEL,
        blade_length_m: 0.02,
        ..LaminaToolCommand::default()
    };
    // SAFETY: a valid command.
    assert_eq!(unsafe { lamina_send_tool(client, &turned) }, LaminaStatus::Ok, "{}", message());
    let got = received();
    assert_eq!(
        (got.kind(), got.orientation, got.blade_length_m),
        (Ok(lamina_bridge::ToolKind::Scalpel), turned.orientation, 0.02)
    );
    let end = got.blade_end(got.blade_length_m);
    assert!((end[0] + 0.02).abs() < 1e-15 && (end[1] - 0.05).abs() < 1e-15, "edge end {end:?}");
    // The sphere still goes out as the sphere.
    assert_eq!(lamina_send_sphere(client, 0.0, 0.06, 0.12, 0.0), LaminaStatus::Ok, "{}", message());
    assert_eq!(received().kind(), Ok(lamina_bridge::ToolKind::Sphere));
    // What the core would refuse never leaves.
    let refused = [
        (LaminaToolCommand { kind: 2, ..turned }, "kind 2 is no tool (0: LAMINA_TOOL_SPHERE, 1: LAMINA_TOOL_SCALPEL)"),
        (LaminaToolCommand { blade_length_m: f64::NAN, ..turned }, "blade length NaN m is outside 0 <= l < 1 m"),
        (LaminaToolCommand { blade_length_m: 1.0, ..turned }, "blade length 1 m is outside 0 <= l < 1 m"),
        (LaminaToolCommand { blade_length_m: -0.01, ..turned }, "blade length -0.01 m is outside"),
        (
            LaminaToolCommand { orientation: [0.0; 4], ..turned },
            "orientation [0, 0, 0, 0] turns the scalpel's edge nowhere",
        ),
    ];
    for (command, why) in refused {
        // SAFETY: a valid pointer; the command's values are what is wrong.
        assert_eq!(unsafe { lamina_send_tool(client, &command) }, LaminaStatus::InvalidArgument, "{command:?}");
        assert!(message().starts_with("lamina_send_tool: ") && message().contains(why), "{}", message());
    }
    assert_eq!(lamina_send_scalpel(client, 0.0, 0.05, 0.1, 2.0), LaminaStatus::InvalidArgument);
    assert!(message().starts_with("lamina_send_scalpel: blade length 2 m"), "{}", message());
    assert!(tool.try_receive().unwrap().is_none(), "no refused command was sent");
    assert_eq!(lamina_close(client), LaminaStatus::Ok);
}
