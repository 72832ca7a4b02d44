//! A service created first by someone else: Lamina uses it when its settings are at least
//! Lamina's, and otherwise refuses it naming every setting with the value found and the value
//! Lamina needs. Also pins the wire types' sizes, which clients in other languages declare
//! by hand (python/lamina/wire.py).

use iceoryx2::prelude::ZeroCopySend;
use lamina_bridge::services::{NODES_BUFFER_SIZE, PubSubSettings};
use lamina_bridge::wire::{NodesHeader, TopologyHeader, WireLayer};
use lamina_bridge::{
    Bridge, BridgeConfig, ContactFeedback, NodesPublisher, NodesSubscriber, PortCreateError, ServiceOpenError,
    SettingMismatch, StatsSummary, ToolCommand, ToolSubscriber,
};

fn bridge(test: &str) -> Bridge {
    let prefix = format!("t{}_{test}", std::process::id());
    Bridge::open(&BridgeConfig::with_prefix(&prefix)).expect("bridge opens")
}

/// The mismatches of an `Incompatible` error, or a panic naming what came instead.
fn mismatches(error: &PortCreateError) -> (&str, &str, &[SettingMismatch]) {
    match error {
        PortCreateError::Service(ServiceOpenError::Incompatible { pattern, service, mismatches }) => {
            (pattern, service, mismatches)
        }
        other => panic!("expected an incompatible service, got {other:?}"),
    }
}

fn mismatch(setting: &'static str, found: &str, needed: &str) -> SettingMismatch {
    SettingMismatch { setting, found: found.into(), needed: needed.into() }
}

#[test]
fn nodes_created_with_default_settings_are_refused_naming_them_works() {
    let b = bridge("defaults");
    // What a client with iceoryx2's default settings creates: buffer 2, history 0.
    let _held = b
        .node()
        .service_builder(&b.names().nodes)
        .publish_subscribe::<[[f32; 3]]>()
        .user_header::<NodesHeader>()
        .create()
        .unwrap();
    let err = NodesPublisher::create(&b, 10).unwrap_err();
    let lamina_bridge::NodesPublisherCreateError::Port(err) = err else { panic!("{err:?}") };
    let (pattern, service, found) = mismatches(&err);
    assert_eq!((pattern, service), ("publish-subscribe", b.names().nodes.as_str()));
    assert_eq!(
        found,
        [
            mismatch("subscriber_max_buffer_size", "2", &format!("at least {NODES_BUFFER_SIZE}")),
            mismatch("history_size", "0", "at least 1"),
        ]
    );
    let text = err.to_string();
    assert!(
        text.contains(&format!("service '{}' exists", b.names().nodes))
            && text.contains("subscriber_max_buffer_size 2 (Lamina needs at least 16)")
            && text.contains("history_size 0 (Lamina needs at least 1)"),
        "{text}"
    );
    // Subscribers are refused the same way.
    let err = NodesSubscriber::create(&b).unwrap_err();
    assert_eq!(mismatches(&err).2.len(), 2, "{err}");
}

#[test]
fn service_created_with_larger_settings_is_used_works() {
    let b = bridge("larger");
    let larger = PubSubSettings {
        subscriber_max_buffer_size: 64,
        history_size: 4,
        subscriber_max_borrowed_samples: 8,
        max_subscribers: 32,
        max_publishers: 4,
        max_nodes: 64,
        safe_overflow: true,
    };
    let _held = b
        .node()
        .service_builder(&b.names().nodes)
        .publish_subscribe::<[[f32; 3]]>()
        .user_header::<NodesHeader>()
        .enable_safe_overflow(larger.safe_overflow)
        .history_size(larger.history_size)
        .subscriber_max_buffer_size(larger.subscriber_max_buffer_size)
        .subscriber_max_borrowed_samples(larger.subscriber_max_borrowed_samples)
        .max_subscribers(larger.max_subscribers)
        .max_publishers(larger.max_publishers)
        .max_nodes(larger.max_nodes)
        .create()
        .unwrap();
    let publisher = NodesPublisher::create(&b, 4).expect("a service with larger settings is used");
    let subscriber = NodesSubscriber::create(&b).unwrap();
    publisher.publish_from_fn(7, 7, 0.007, 4, |i| [i as f32, 0.0, 0.0]).unwrap();
    let frame = subscriber.try_receive().unwrap().expect("the frame arrives");
    assert_eq!((frame.header().sequence, frame.positions()[3]), (7, [3.0, 0.0, 0.0]));
}

#[test]
fn service_with_other_types_is_refused_naming_them_works() {
    let b = bridge("types");
    // Positions as a flat f32 slice and no header: the bytes would fit, the contract does not.
    let _held = b.node().service_builder(&b.names().nodes).publish_subscribe::<[f32]>().create().unwrap();
    let err = NodesSubscriber::create(&b).unwrap_err();
    let (_, _, found) = mismatches(&err);
    assert_eq!(
        found,
        [
            mismatch(
                "payload type",
                "slice of 'f32' (size 4, alignment 4)",
                "slice of '[f32; 3]' (size 12, alignment 4)"
            ),
            mismatch("user header type", "'()' (size 0, alignment 1)", "'LaminaNodesHeaderV1' (size 40, alignment 8)"),
            mismatch("subscriber_max_buffer_size", "2", "at least 16"),
            mismatch("history_size", "0", "at least 1"),
        ]
    );
}

#[test]
fn tool_without_safe_overflow_is_refused_naming_it_works() {
    let b = bridge("overflow");
    let _held = b
        .node()
        .service_builder(&b.names().tool)
        .publish_subscribe::<ToolCommand>()
        .enable_safe_overflow(false)
        .history_size(1)
        .subscriber_max_buffer_size(4)
        .create()
        .unwrap();
    let err = ToolSubscriber::create(&b).unwrap_err();
    let (_, service, found) = mismatches(&err);
    assert_eq!(service, b.names().tool.as_str());
    assert_eq!(found, [mismatch("enable_safe_overflow", "false", "true")]);
    assert!(err.to_string().contains("enable_safe_overflow false (Lamina needs true)"), "{err}");
}

#[test]
fn wake_event_with_too_few_listeners_is_refused_naming_it_works() {
    let b = bridge("event");
    let _held = b.node().service_builder(&b.names().nodes).event().max_listeners(2).create().unwrap();
    let err = NodesSubscriber::create(&b).unwrap_err();
    let (pattern, service, found) = mismatches(&err);
    assert_eq!((pattern, service), ("event", b.names().nodes.as_str()));
    assert_eq!(found, [mismatch("max_listeners", "2", "at least 16")]);
}

#[test]
fn wire_type_sizes_match_the_python_clients_works() {
    // python/lamina/wire.py declares every type's size in `WIRE_SIZES` and checks its
    // ctypes declarations against them at import; those sizes must be the Rust types'.
    use core::mem::size_of;
    use lamina_bridge::wire::{WireSurface, WireTool, WireVolume};
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../python/lamina/wire.py");
    let text = std::fs::read_to_string(path).expect("python/lamina/wire.py");
    let table = text.split_once("WIRE_SIZES = {").expect("WIRE_SIZES in python/lamina/wire.py").1;
    let table = table.split_once('}').expect("WIRE_SIZES closes").0;
    let python: std::collections::BTreeMap<&str, usize> = table
        .lines()
        .filter_map(|l| l.trim().trim_end_matches(',').split_once(": "))
        .map(|(name, size)| (name, size.parse().expect("a size in bytes")))
        .collect();
    let rust = [
        ("Position", size_of::<[f32; 3]>()),
        ("NodesHeader", size_of::<NodesHeader>()),
        ("WireLayer", size_of::<WireLayer>()),
        ("WireSurface", size_of::<WireSurface>()),
        ("WireTool", size_of::<WireTool>()),
        ("WireVolume", size_of::<WireVolume>()),
        ("TopologyHeader", size_of::<TopologyHeader>()),
        ("ToolCommand", size_of::<ToolCommand>()),
        ("ContactFeedback", size_of::<ContactFeedback>()),
        ("StatsSummary", size_of::<StatsSummary>()),
    ];
    assert_eq!(python.len(), rust.len(), "python/lamina/wire.py declares {python:?}");
    for (name, size) in rust {
        assert_eq!(python.get(name), Some(&size), "{name}: python/lamina/wire.py against the Rust type");
    }
}

/// `ToolCommand` as protocol version 1 declared it (88 bytes: `reserved` where `kind` is, no
/// blade length), what a client built for that version registers.
#[derive(Debug, Clone, Copy, Default, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaToolCommandV1")]
struct ToolCommandV1 {
    sequence: u64,
    time_ns: u64,
    position: [f64; 3],
    orientation: [f64; 4],
    buttons: u32,
    reserved: u32,
    tool_radius_m: f64,
}

#[test]
fn tool_created_by_a_version_1_client_is_refused_naming_both_types_works() {
    let b = bridge("tool_v1_first");
    // A version-1 client came first and created `tool` with Lamina's settings.
    let _held = b
        .node()
        .service_builder(&b.names().tool)
        .publish_subscribe::<ToolCommandV1>()
        .enable_safe_overflow(true)
        .history_size(1)
        .subscriber_max_buffer_size(4)
        .subscriber_max_borrowed_samples(2)
        .max_publishers(2)
        .max_subscribers(8)
        .max_nodes(20)
        .create()
        .unwrap();
    let err = ToolSubscriber::create(&b).unwrap_err();
    let (_, service, found) = mismatches(&err);
    assert_eq!(service, b.names().tool.as_str());
    assert_eq!(
        found,
        [mismatch(
            "payload type",
            "'LaminaToolCommandV1' (size 88, alignment 8)",
            "'LaminaToolCommandV2' (size 96, alignment 8)"
        )]
    );
}

#[test]
fn version_1_client_opening_the_tool_service_is_refused_works() {
    use iceoryx2::service::builder::publish_subscribe::{PublishSubscribeOpenError, PublishSubscribeOpenOrCreateError};
    let b = bridge("tool_v1_second");
    let _core = ToolSubscriber::create(&b).unwrap();
    // A version-1 client after the core: iceoryx2 refuses the type before any byte is read.
    let open = b.node().service_builder(&b.names().tool).publish_subscribe::<ToolCommandV1>().open();
    assert_eq!(open.err(), Some(PublishSubscribeOpenError::IncompatibleTypes));
    let open_or_create = b
        .node()
        .service_builder(&b.names().tool)
        .publish_subscribe::<ToolCommandV1>()
        .enable_safe_overflow(true)
        .history_size(1)
        .subscriber_max_buffer_size(4)
        .open_or_create();
    assert_eq!(
        open_or_create.err(),
        Some(PublishSubscribeOpenOrCreateError::PublishSubscribeOpenError(
            PublishSubscribeOpenError::IncompatibleTypes
        ))
    );
}
