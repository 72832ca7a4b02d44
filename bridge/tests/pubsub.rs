//! In-process publish/subscribe behaviour of every service. Each test uses its own service
//! prefix (test name + process id), so tests and concurrent runs never share a service.

use core::time::Duration;

use lamina_bridge::{
    Bridge, BridgeConfig, BridgeOpenError, ContactFeedback, FeedbackPublisher, FeedbackSubscriber, LayerRange,
    NodeChanges, NodesPublishError, NodesPublisher, NodesSubscriber, StatsPublisher, StatsSubscriber, StatsSummary,
    TissueKind, ToolCommand, ToolKind, ToolPublisher, ToolSubscriber, Topology, TopologyPublisher, TopologySubscriber,
};

/// Watchdog for waits that must succeed; it bounds a hang, it is not a timing requirement.
const WATCHDOG: Duration = Duration::from_secs(30);

fn bridge(test: &str) -> Bridge {
    let prefix = format!("t{}_{test}", std::process::id());
    Bridge::open(&BridgeConfig::with_prefix(&prefix)).expect("bridge opens")
}

fn position(seq: u64, i: usize) -> [f32; 3] {
    [i as f32, seq as f32, -(i as f32) * 0.5]
}

#[test]
fn nodes_round_trip_works() {
    let b = bridge("nodes_round_trip");
    let publisher = NodesPublisher::create(&b, 2769).unwrap();
    let subscriber = NodesSubscriber::create(&b).unwrap();

    let delivered = publisher.publish_from_fn(7, 70, 0.07, 2769, |i| position(7, i)).unwrap();
    assert_eq!(delivered, 1);
    publisher
        .publish(8, 80, 0.08, 100, |p| {
            for (i, x) in p.iter_mut().enumerate() {
                *x = position(8, i);
            }
        })
        .unwrap();

    let first = subscriber.try_receive().unwrap().expect("first frame queued");
    let h = first.header();
    assert_eq!((h.sequence, h.tick, h.sim_time_s, h.node_count), (7, 70, 0.07, 2769));
    assert!(h.publish_time_ns > 0);
    assert_eq!(first.positions().len(), 2769);
    assert!(first.positions().iter().enumerate().all(|(i, p)| *p == position(7, i)));

    let second = subscriber.try_receive().unwrap().expect("second frame queued");
    assert_eq!(second.header().sequence, 8);
    assert!(second.header().publish_time_ns >= h.publish_time_ns);
    assert!(second.positions().iter().enumerate().all(|(i, p)| *p == position(8, i)));
    assert!(subscriber.try_receive().unwrap().is_none());
}

#[test]
fn nodes_with_a_non_finite_coordinate_are_withheld_works() {
    let b = bridge("nodes_non_finite");
    let publisher = NodesPublisher::create(&b, 100).unwrap();
    let subscriber = NodesSubscriber::create(&b).unwrap();
    // NaN and infinities anywhere in a frame withhold it; the publisher goes on after.
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let sent = publisher
            .publish_finite_from_fn(1, 1, 0.001, 100, |i| if i == 57 { [0.0, bad, 0.0] } else { position(1, i) })
            .unwrap();
        assert_eq!(sent, None, "{bad}");
    }
    assert_eq!(publisher.publish_finite_from_fn(2, 2, 0.002, 100, |i| position(2, i)).unwrap(), Some(1));
    let frame = subscriber.try_receive().unwrap().expect("the finite frame");
    assert_eq!(frame.header().sequence, 2);
    assert!(frame.positions().iter().enumerate().all(|(i, p)| *p == position(2, i)));
    assert!(subscriber.try_receive().unwrap().is_none(), "no withheld frame reached the subscriber");
}

#[test]
fn nodes_from_coordinate_arrays_arrive_as_records_and_non_finite_ones_are_withheld_works() {
    let b = bridge("nodes_xyz");
    // 2,769 nodes: whole vector blocks of 16 and 8 and a tail.
    let n = 2769;
    let publisher = NodesPublisher::create(&b, n).unwrap();
    let subscriber = NodesSubscriber::create(&b).unwrap();
    let axis = |seq: u64, c: usize| -> Vec<f32> { (0..n).map(|i| position(seq, i)[c]).collect() };
    let (x, y, z) = (axis(3, 0), axis(3, 1), axis(3, 2));
    assert_eq!(publisher.publish_finite_xyz(3, 30, 0.03, &x, &y, &z).unwrap(), Some(1));
    let mut bad_z = axis(4, 2);
    bad_z[n - 1] = f32::NAN;
    assert_eq!(publisher.publish_finite_xyz(4, 40, 0.04, &axis(4, 0), &axis(4, 1), &bad_z).unwrap(), None);
    let err = publisher.publish_finite_xyz(5, 50, 0.05, &x, &y[..n - 1], &z).unwrap_err();
    assert_eq!(err, NodesPublishError::CoordinateLengths { x: n, y: n - 1, z: n });

    let frame = subscriber.try_receive().unwrap().expect("the finite frame");
    assert_eq!((frame.header().sequence, frame.header().tick, frame.header().node_count), (3, 30, n as u32));
    assert_eq!(frame.positions().len(), n);
    assert!(frame.positions().iter().enumerate().all(|(i, p)| *p == position(3, i)));
    assert!(subscriber.try_receive().unwrap().is_none(), "no withheld or refused frame reached the subscriber");
}

/// Frames published with the nodes that changed: whichever chunk iceoryx2 lends, and whatever
/// it carried before (a frame of another epoch, a frame written whole by another method, a
/// withheld one), the subscriber receives the positions as the arrays hold them.
#[test]
fn nodes_with_changed_lists_arrive_whole_works() {
    let b = bridge("nodes_changed");
    let n = 1000;
    let publisher = NodesPublisher::create(&b, n).unwrap();
    let subscriber = NodesSubscriber::create(&b).unwrap();
    let changed: Vec<u32> = (0..n as u32).filter(|i| i % 7 == 3).collect();
    let (mut x, mut y, mut z) = (vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]);
    let mut epoch = 0;
    let mut received = 0;
    for seq in 0..80u64 {
        let value = |i: usize| [seq as f32 + i as f32 * 1e-3, -(i as f32), seq as f32 * 0.5];
        // Every 10th frame a new epoch in which every node moves; the others move only the
        // changed nodes.
        let moving: Vec<usize> =
            if seq % 10 == 0 { (0..n).collect() } else { changed.iter().map(|&i| i as usize).collect() };
        epoch += u64::from(seq % 10 == 0);
        for i in moving {
            [x[i], y[i], z[i]] = value(i);
        }
        if seq % 10 == 5 {
            // Another frame written whole into a chunk, received and dropped.
            let sent = publisher.publish_from_fn(1000 + seq, 0, 0.0, n, |i| [i as f32; 3]).unwrap();
            assert_eq!(sent, 1);
            drop(subscriber.try_receive().unwrap().expect("the frame written whole"));
        }
        if seq % 10 == 7 {
            // A changed node not finite: withheld; the frame after it is whole again.
            let mut bad = z.clone();
            bad[changed[5] as usize] = f32::NAN;
            assert_eq!(
                publisher.publish_finite_xyz_changed(
                    seq,
                    seq,
                    0.0,
                    [&x, &y, &bad],
                    NodeChanges { epoch, nodes: &changed }
                ),
                Ok(None)
            );
        }
        assert_eq!(
            publisher.publish_finite_xyz_changed(seq, seq, 0.0, [&x, &y, &z], NodeChanges { epoch, nodes: &changed }),
            Ok(Some(1))
        );
        let frame = subscriber.try_receive().unwrap().expect("the frame");
        assert_eq!(frame.header().sequence, seq);
        for (i, p) in frame.positions().iter().enumerate() {
            assert_eq!(*p, [x[i], y[i], z[i]], "frame {seq}, node {i}");
        }
        received += 1;
    }
    assert_eq!(received, 80);
    let err = publisher
        .publish_finite_xyz_changed(0, 0, 0.0, [&x, &y, &z], NodeChanges { epoch, nodes: &[3, n as u32] })
        .unwrap_err();
    assert_eq!(err, NodesPublishError::ChangedNodeOutOfRange { index: n as u32, node_count: n });
    assert!(subscriber.try_receive().unwrap().is_none(), "no refused frame reached the subscriber");
}

#[test]
fn nodes_receive_timeout_works() {
    let b = bridge("nodes_receive_timeout");
    let subscriber = NodesSubscriber::create(&b).unwrap();
    // Nothing published: the wait ends empty instead of hanging.
    assert!(subscriber.receive_timeout(Duration::from_millis(20)).unwrap().is_none());

    // A publisher on another thread (own node) publishes once the subscriber is waiting, and
    // stays alive until the frame was read (a dropped publisher takes its samples with it).
    let prefix = b.prefix().to_owned();
    let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
    let publisher_thread = std::thread::spawn(move || {
        let b = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
        let publisher = NodesPublisher::create(&b, 10).unwrap();
        std::thread::sleep(Duration::from_millis(50));
        let delivered = publisher.publish_from_fn(42, 1, 0.001, 10, |i| position(42, i)).unwrap();
        let _ = done_rx.recv_timeout(WATCHDOG);
        delivered
    });
    let frame = subscriber.receive_timeout(WATCHDOG).unwrap().expect("woken by the publish");
    assert_eq!(frame.header().sequence, 42);
    assert_eq!(frame.positions()[9], position(42, 9));
    done_tx.send(()).unwrap();
    assert_eq!(publisher_thread.join().unwrap(), 1);
}

#[test]
fn nodes_too_many_fails() {
    let b = bridge("nodes_too_many");
    let publisher = NodesPublisher::create(&b, 100).unwrap();
    let too_many = NodesPublishError::TooManyNodes { requested: 101, max: 100 };
    assert_eq!(publisher.publish_from_fn(0, 0, 0.0, 101, |_| [0.0; 3]), Err(too_many));
    assert_eq!(publisher.publish(0, 0, 0.0, 101, |_| {}), Err(too_many));
    assert!(publisher.publish_from_fn(0, 0, 0.0, usize::MAX, |_| [0.0; 3]).is_err());
    // The limit itself is fine, and the failed calls left the publisher usable.
    assert!(publisher.publish_from_fn(0, 0, 0.0, 100, |_| [0.0; 3]).is_ok());
}

#[test]
fn nodes_stalled_subscriber_works() {
    let b = bridge("nodes_stalled_subscriber");
    let publisher = NodesPublisher::create(&b, 2769).unwrap();
    let stalled = NodesSubscriber::create(&b).unwrap();
    let mut ok = 0u64;
    for seq in 0..10_000u64 {
        if publisher.publish_from_fn(seq, seq, 0.0, 2769, |i| position(seq, i)).is_ok() {
            ok += 1;
        }
    }
    assert_eq!(ok, 10_000);
    // Safe overflow kept the newest frames for the subscriber that never read.
    let newest = stalled.latest().unwrap().expect("buffer holds frames");
    assert_eq!(newest.header().sequence, 9_999);
}

#[test]
fn topology_late_joiner_works() {
    let b = bridge("topology_late_joiner");
    let topo = Topology {
        node_count: 4,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        layers: vec![
            LayerRange { name: "skin".into(), tissue: TissueKind::Skin, first_node: 0, node_count: 2 },
            LayerRange { name: "muscle".into(), tissue: TissueKind::Muscle, first_node: 2, node_count: 2 },
        ],
        tex_coords: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        springs: vec![[0, 1], [2, 3], [1, 2]],
        spring_layer: vec![0, 1, 1],
        rest_positions: vec![[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.01, 0.01, 0.0], [0.0, 0.01, 0.0]],
        ..Topology::default()
    };
    let mut publisher = TopologyPublisher::create(&b, topo.word_count()).unwrap();
    assert_eq!(publisher.publish(&topo).unwrap(), 0, "nobody subscribed yet");

    let late = TopologySubscriber::create(&b).unwrap();
    publisher.serve_late_joiners().unwrap();
    let sample = late.receive_timeout(WATCHDOG).unwrap().expect("history delivered");
    assert_eq!(sample.header().revision, 0);
    assert_eq!(sample.decode().unwrap(), topo);

    let bigger = Topology { triangles: vec![[0, 1, 2]; 3], ..topo.clone() };
    assert!(publisher.publish(&bigger).is_err(), "larger than the publisher's fixed size");
}

#[test]
fn feedback_late_joiner_works() {
    let b = bridge("feedback_late_joiner");
    let publisher = FeedbackPublisher::create(&b).unwrap();
    for seq in 0..3u64 {
        let fb = ContactFeedback {
            sequence: seq,
            tick: seq * 10,
            in_contact: 1,
            force: [0.0, 0.0, seq as f64],
            ..ContactFeedback::default()
        };
        publisher.publish(&fb).unwrap();
    }
    let late = FeedbackSubscriber::create(&b).unwrap();
    publisher.update_connections().unwrap();
    let got = late.latest().unwrap().expect("last value delivered");
    assert_eq!(got.message().sequence, 2);
    assert_eq!(got.message().force, [0.0, 0.0, 2.0]);
    assert!(got.message().is_in_contact());
}

#[test]
fn tool_late_joiner_works() {
    let b = bridge("tool_late_joiner");
    let publisher = ToolPublisher::create(&b).unwrap();
    for seq in 0..5u64 {
        let tool = ToolCommand {
            sequence: seq,
            position: [0.01 * seq as f64, 0.0, 0.0],
            buttons: 1,
            kind: ToolKind::Scalpel.code(),
            tool_radius_m: 0.002,
            blade_length_m: 0.015,
            ..ToolCommand::default()
        };
        publisher.publish(&tool).unwrap();
    }
    let late = ToolSubscriber::create(&b).unwrap();
    publisher.update_connections().unwrap();
    let got = late.receive_timeout(WATCHDOG).unwrap().expect("last value delivered");
    assert_eq!(got.message().sequence, 4);
    assert_eq!(got.message().orientation, [0.0, 0.0, 0.0, 1.0]);
    assert_eq!(got.message().tool_radius_m, 0.002);
    assert_eq!((got.message().kind(), got.message().blade_length_m), (Ok(ToolKind::Scalpel), 0.015));
}

#[test]
fn stats_round_trip_works() {
    let b = bridge("stats_round_trip");
    let subscriber = StatsSubscriber::create(&b).unwrap();
    let publisher = StatsPublisher::create(&b).unwrap();
    let mut stats = StatsSummary { sequence: 1, ticks: 1000, misses: 2, worst_tick: 17, ..Default::default() };
    stats.compute.p999_ns = 123_456;
    publisher.publish(&stats).unwrap();
    let got = subscriber.receive_timeout(WATCHDOG).unwrap().expect("published");
    assert_eq!(*got.message(), stats);
}

#[test]
fn bridge_invalid_prefix_fails() {
    assert_eq!(Bridge::open(&BridgeConfig::with_prefix("")).err(), Some(BridgeOpenError::InvalidPrefix));
    let cfg = BridgeConfig { file_prefix: Some("bad/name".into()), ..BridgeConfig::with_prefix("ok") };
    assert_eq!(Bridge::open(&cfg).err(), Some(BridgeOpenError::InvalidFilePrefix));
}
