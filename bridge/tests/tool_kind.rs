//! The tool command's kind and the scalpel's cutting edge: every kind's code and name round
//! trip, an unknown code comes back as itself, and the edge's far end is the tip plus the
//! blade length along the tool's local +y axis, rotated by the orientation (checked against
//! rotations whose effect on +y is known in closed form).

use lamina_bridge::{ToolCommand, ToolKind};

fn edge(orientation: [f64; 4], length: f64) -> [f64; 3] {
    ToolCommand { position: [0.1, 0.2, 0.3], orientation, ..ToolCommand::default() }.blade_end(length)
}

fn assert_close(got: [f64; 3], want: [f64; 3]) {
    for c in 0..3 {
        assert!((got[c] - want[c]).abs() < 1e-15, "{got:?} against {want:?}");
    }
}

#[test]
fn tool_kind_codes_and_names_round_trip_works() {
    assert_eq!(ToolKind::ALL.map(ToolKind::code), [0, 1]);
    for kind in ToolKind::ALL {
        assert_eq!(ToolKind::from_code(kind.code()), Ok(kind));
        assert_eq!(ToolKind::parse(kind.name()), Some(kind));
        assert_eq!(ToolKind::parse(&kind.code().to_string()), Some(kind));
        let command = ToolCommand { kind: kind.code(), ..ToolCommand::default() };
        assert_eq!(command.kind(), Ok(kind));
    }
    assert_eq!((ToolKind::Sphere.name(), ToolKind::Scalpel.name()), ("sphere", "scalpel"));
    assert_eq!(ToolCommand::default().kind(), Ok(ToolKind::Sphere), "the default command is the sphere");
}

#[test]
fn tool_kind_unknown_code_is_refused_with_it_fails() {
    for code in [2, 7, u32::MAX] {
        assert_eq!(ToolCommand { kind: code, ..ToolCommand::default() }.kind(), Err(code));
    }
    for text in ["2", "knife", "", "Scalpel", "-1", "1.0"] {
        assert_eq!(ToolKind::parse(text), None, "'{text}'");
    }
}

#[test]
fn blade_edge_follows_the_orientation_works() {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // Identity: straight up (+y) from the tip.
    assert_close(edge([0.0, 0.0, 0.0, 1.0], 0.01), [0.1, 0.21, 0.3]);
    // 90° about +z takes +y to −x; about +x takes +y to +z; 180° about +x to −y.
    assert_close(edge([0.0, 0.0, h, h], 0.01), [0.09, 0.2, 0.3]);
    assert_close(edge([h, 0.0, 0.0, h], 0.01), [0.1, 0.2, 0.31]);
    assert_close(edge([1.0, 0.0, 0.0, 0.0], 0.01), [0.1, 0.19, 0.3]);
    // About +y itself: the edge does not move.
    assert_close(edge([0.0, h, 0.0, h], 0.01), [0.1, 0.21, 0.3]);
    // A quaternion of another length is the same rotation.
    assert_close(edge([0.0, 0.0, 3.0, 3.0], 0.01), [0.09, 0.2, 0.3]);
    // No rotation at all (zero quaternion): the edge has no length.
    assert_close(edge([0.0; 4], 0.01), [0.1, 0.2, 0.3]);
}
