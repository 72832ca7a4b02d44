//! Wire round trips of the static model: random valid topologies survive encode/decode
//! exactly; invalid ones are refused in both directions without panicking.

use lamina_bridge::wire::{LAYER_NAME_LEN, MAX_LAYERS, MAX_SURFACES, tissue_code};
use lamina_bridge::{
    LayerRange, SurfaceTopology, TissueKind, Topology, TopologyDecodeError, TopologyEncodeError, VolumeTopology,
};

/// xorshift64*: a tiny deterministic generator, enough for a few property cases.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: u64) -> u64 {
        if n == 0 { 0 } else { self.next() % n }
    }
}

const TISSUES: [TissueKind; 5] =
    [TissueKind::Other, TissueKind::Skin, TissueKind::Fat, TissueKind::Muscle, TissueKind::Bone];

fn random_topology(rng: &mut Rng) -> Topology {
    let node_count = 1 + rng.below(500) as u32;
    let node = |rng: &mut Rng| rng.below(u64::from(node_count)) as u32;
    let triangles = (0..rng.below(300)).map(|_| core::array::from_fn(|_| node(rng))).collect();
    let names = ["skin", "fat", "muscle", "bone", "fascia", "peau-épiderme", ""];
    let layers: Vec<LayerRange> = (0..rng.below(MAX_LAYERS as u64 + 1))
        .map(|k| {
            let first = node(rng);
            let count = rng.below(u64::from(node_count - first) + 1) as u32;
            let tissue = TISSUES[rng.below(5) as usize];
            LayerRange {
                name: format!("{}{k}", names[k as usize % names.len()]),
                tissue,
                first_node: first,
                node_count: count,
            }
        })
        .collect();
    let per_node = |rng: &mut Rng| rng.below(2) == 1;
    let tex_coords = if per_node(rng) {
        (0..node_count)
            .map(|_| [rng.below(1 << 20) as f32 / 1e6 - 0.3, f32::from_bits(rng.next() as u32 & 0x3fff_ffff)])
            .collect()
    } else {
        Vec::new()
    };
    let surfaces = (0..rng.below(MAX_SURFACES as u64 + 1))
        .map(|k| {
            let grid = (rng.below(2) == 1).then(|| (2 + rng.below(20) as u32, 2 + rng.below(20) as u32));
            let len = grid.map_or(3 * rng.below(50) as u32, |(c, r)| c * r);
            SurfaceTopology {
                name: format!("surface_{k}"),
                tissue: TISSUES[rng.below(5) as usize],
                grid,
                indices: (0..len).map(|_| node(rng)).collect(),
            }
        })
        .collect();
    let layer_count = layers.len() as u64;
    let springs: Vec<[u32; 2]> =
        if layer_count == 0 { Vec::new() } else { (0..rng.below(400)).map(|_| [node(rng), node(rng)]).collect() };
    let spring_layer = springs.iter().map(|_| rng.below(layer_count) as u32).collect();
    let node_layer = if layer_count > 0 && per_node(rng) {
        (0..node_count).map(|_| rng.below(layer_count) as u32).collect()
    } else {
        Vec::new()
    };
    let rest_positions = if per_node(rng) {
        (0..node_count).map(|_| core::array::from_fn(|_| rng.below(1 << 24) as f32 * 1e-6 - 8.0)).collect()
    } else {
        Vec::new()
    };
    let mut tool = lamina_bridge::WireTool { source: rng.below(3) as u32, radius_m: 0.005, ..Default::default() };
    tool.device_origin_m = core::array::from_fn(|_| rng.below(1000) as f64 * 1e-3);
    tool.device_rotation = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]];
    let volume = (rng.below(2) == 1).then(|| VolumeTopology {
        path: "/data/ct/leg.nrrd".into(),
        origin_m: (rng.below(2) == 1).then_some([0.1, -0.2, 0.3]),
        window: (rng.below(2) == 1).then_some([-100.0, 1500.0]),
    });
    Topology {
        name: names[rng.below(names.len() as u64) as usize].into(),
        node_count,
        triangles,
        layers,
        tex_coords,
        surfaces,
        springs,
        spring_layer,
        node_layer,
        rest_positions,
        tool,
        volume,
    }
}

#[test]
fn topology_random_round_trip_works() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for _ in 0..200 {
        let topo = random_topology(&mut rng);
        let (header, words) = topo.encode().expect("valid topology encodes");
        assert_eq!(words.len(), topo.word_count());
        assert_eq!(header.word_count(), words.len());
        let back = Topology::decode(&header, &words).expect("own encoding decodes");
        assert_eq!(back, topo);
        // The streamed words (what the publisher writes into shared memory) are the encoding.
        assert!((0..words.len()).all(|i| topo.word(i) == words[i]));
        // Bit-exact, not just equal.
        let bits = |t: &Topology| t.tex_coords.iter().flatten().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&topo));
    }
}

#[test]
fn topology_empty_round_trip_works() {
    let topo = Topology::default();
    let (header, words) = topo.encode().unwrap();
    assert!(words.is_empty());
    assert_eq!(Topology::decode(&header, &words).unwrap(), topo);
}

#[test]
fn topology_invalid_encode_fails() {
    let base = Topology { node_count: 3, triangles: vec![[0, 1, 2]], ..Topology::default() };
    let with = |f: &dyn Fn(&mut Topology)| {
        let mut t = base.clone();
        f(&mut t);
        t.encode().err()
    };
    assert_eq!(with(&|t| t.triangles[0][2] = 3), Some(TopologyEncodeError::TriangleIndexOutOfRange));
    assert_eq!(with(&|t| t.tex_coords = vec![[0.0; 2]; 2]), Some(TopologyEncodeError::TexCoordCountMismatch));
    let layer = |name: &str, first, count| LayerRange {
        name: name.into(),
        tissue: TissueKind::Skin,
        first_node: first,
        node_count: count,
    };
    assert_eq!(with(&|t| t.layers = vec![layer("a", 2, 2)]), Some(TopologyEncodeError::LayerOutOfRange));
    assert_eq!(with(&|t| t.layers = vec![layer("a", u32::MAX, 2)]), Some(TopologyEncodeError::LayerOutOfRange));
    let long = "x".repeat(LAYER_NAME_LEN + 1);
    assert_eq!(with(&|t| t.layers = vec![layer(&long, 0, 1)]), Some(TopologyEncodeError::InvalidLayerName));
    assert_eq!(with(&|t| t.layers = vec![layer("a\0b", 0, 1)]), Some(TopologyEncodeError::InvalidLayerName));
    assert_eq!(with(&|t| t.layers = vec![layer("a", 0, 1); MAX_LAYERS + 1]), Some(TopologyEncodeError::TooManyLayers));
    // Exactly the maximum name length is fine.
    assert_eq!(with(&|t| t.layers = vec![layer(&"y".repeat(LAYER_NAME_LEN), 0, 1)]), None);
    let grid = |cols, rows, len| SurfaceTopology {
        name: "skin_outer".into(),
        tissue: TissueKind::Skin,
        grid: Some((cols, rows)),
        indices: vec![0; len],
    };
    assert_eq!(with(&|t| t.surfaces = vec![grid(2, 2, 5)]), Some(TopologyEncodeError::SurfaceShapeMismatch));
    assert_eq!(with(&|t| t.surfaces = vec![grid(1, 4, 4)]), Some(TopologyEncodeError::SurfaceShapeMismatch));
    assert_eq!(
        with(&|t| t.surfaces = vec![grid(2, 2, 4); MAX_SURFACES + 1]),
        Some(TopologyEncodeError::TooManySurfaces)
    );
    let mut bad_index = grid(2, 2, 4);
    bad_index.indices[3] = 3;
    assert_eq!(with(&|t| t.surfaces = vec![bad_index.clone()]), Some(TopologyEncodeError::NodeIndexOutOfRange));
    assert_eq!(with(&|t| t.springs = vec![[0, 1]]), Some(TopologyEncodeError::TexCoordCountMismatch));
    let one_layer = |t: &mut Topology| t.layers = vec![layer("skin", 0, 3)];
    assert_eq!(
        with(&|t| {
            one_layer(t);
            t.springs = vec![[0, 1]];
            t.spring_layer = vec![1];
        }),
        Some(TopologyEncodeError::LayerIndexOutOfRange)
    );
    assert_eq!(
        with(&|t| {
            one_layer(t);
            t.springs = vec![[0, 5]];
            t.spring_layer = vec![0];
        }),
        Some(TopologyEncodeError::NodeIndexOutOfRange)
    );
    assert_eq!(with(&|t| t.rest_positions = vec![[0.0, f32::NAN, 0.0]; 3]), Some(TopologyEncodeError::NonFinite));
    assert_eq!(with(&|t| t.tool.radius_m = f64::INFINITY), Some(TopologyEncodeError::NonFinite));
    assert_eq!(with(&|t| t.name = "\0".into()), Some(TopologyEncodeError::InvalidName));
    let volume = |path: String| Some(VolumeTopology { path, ..VolumeTopology::default() });
    assert_eq!(with(&|t| t.volume = volume("v".repeat(300))), Some(TopologyEncodeError::VolumePath { bytes: 300 }));
    assert_eq!(
        with(&|t| t.volume = Some(VolumeTopology { window: Some([0.0, f64::NAN]), ..VolumeTopology::default() })),
        Some(TopologyEncodeError::NonFinite)
    );
}

#[test]
fn topology_invalid_decode_fails() {
    let topo = Topology {
        node_count: 3,
        triangles: vec![[0, 1, 2]],
        layers: vec![LayerRange { name: "skin".into(), tissue: TissueKind::Skin, first_node: 0, node_count: 3 }],
        tex_coords: vec![[0.5; 2]; 3],
        surfaces: vec![SurfaceTopology {
            name: "skin_outer".into(),
            tissue: TissueKind::Skin,
            grid: None,
            indices: vec![0, 1, 2],
        }],
        springs: vec![[0, 1], [1, 2]],
        spring_layer: vec![0, 0],
        node_layer: vec![0; 3],
        rest_positions: vec![[0.0; 3]; 3],
        ..Topology::default()
    };
    let (header, words) = topo.encode().unwrap();
    assert_eq!(Topology::decode(&header, &words[1..]), Err(TopologyDecodeError::PayloadLengthMismatch));
    let mut bad = words.clone();
    bad[0] = 99;
    assert_eq!(Topology::decode(&header, &bad), Err(TopologyDecodeError::TriangleIndexOutOfRange));
    let mut h = header;
    h.layer_count = u32::MAX;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::TooManyLayers));
    let mut h = header;
    h.layers[0].name[0] = 0xff;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::InvalidLayerName));
    let mut h = header;
    h.layers[0].node_count = 4;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::LayerOutOfRange));
    let mut h = header;
    h.tex_coord_count = 2;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::TexCoordCountMismatch));
    let mut h = header;
    h.triangle_count = u32::MAX;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::PayloadLengthMismatch));
    let mut h = header;
    h.surfaces[0].index_count = u32::MAX;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::PayloadLengthMismatch));
    let mut h = header;
    h.surface_count = u32::MAX;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::TooManyLayers));
    let mut h = header;
    h.layers[0].tissue = 77;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::UnknownTissue));
    let mut h = header;
    h.surfaces[0].tissue = tissue_code::BONE + 1;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::UnknownTissue));
    let mut h = header;
    (h.surfaces[0].grid_cols, h.surfaces[0].grid_rows) = (2, 2);
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::SurfaceShapeMismatch));
    let mut h = header;
    h.tool.force_scale = f64::NAN;
    assert_eq!(Topology::decode(&h, &words), Err(TopologyDecodeError::NonFinite));
    // Sections in order: 3 triangle, 6 uv, 3 surface, 4 spring, 2 spring-layer, 3 node-layer
    // and 9 rest-position words.
    let mut bad = words.clone();
    bad[12] = 3;
    assert_eq!(Topology::decode(&header, &bad), Err(TopologyDecodeError::TriangleIndexOutOfRange), "spring index");
    let mut bad = words.clone();
    bad[16] = 1;
    assert_eq!(Topology::decode(&header, &bad), Err(TopologyDecodeError::LayerIndexOutOfRange), "spring layer");
    let mut bad = words.clone();
    bad[21] = f32::INFINITY.to_bits();
    assert_eq!(Topology::decode(&header, &bad), Err(TopologyDecodeError::NonFinite), "rest position");
}

/// A volume path longer than the wire's 256 bytes is refused by name and length, at load
/// (`VolumeTopology::check_path`) and at encoding; 256 bytes fit and come back whole.
#[test]
fn robustness_volume_path_beyond_the_wire_fail() {
    let long = format!("/{}", "d/".repeat(150));
    let e = VolumeTopology::check_path(&long).unwrap_err();
    assert_eq!(e.bytes, 301);
    let text = e.to_string();
    assert!(text.starts_with("visual.volume \"/d/d/") && text.contains(": 301 bytes;"), "{text}");
    assert!(text.contains("at most 256 bytes"), "{text}");
    assert!(VolumeTopology::check_path("a\0b").is_err(), "a NUL is refused");
    let fits = format!("/{}", "v".repeat(255));
    assert_eq!(VolumeTopology::check_path(&fits), Ok(()));
    let topo = |path: &str| Topology {
        node_count: 1,
        volume: Some(VolumeTopology { path: path.into(), ..VolumeTopology::default() }),
        ..Topology::default()
    };
    let e = topo(&long).header().unwrap_err();
    assert_eq!(e, TopologyEncodeError::VolumePath { bytes: 301 });
    assert!(e.to_string().contains("volume path (visual.volume) is 301 bytes; the wire carries at most 256"), "{e}");
    let (header, words) = topo(&fits).encode().expect("256 bytes fit");
    let back = Topology::decode(&header, &words).expect("decodes");
    assert_eq!(back.volume.map(|v| v.path), Some(fits));
}
