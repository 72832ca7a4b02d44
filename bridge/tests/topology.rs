//! Wire round trips of the static model: random valid topologies survive encode/decode
//! exactly; invalid ones are refused in both directions without panicking.

use lamina_bridge::wire::{LAYER_NAME_LEN, MAX_LAYERS};
use lamina_bridge::{LayerRange, Topology, TopologyDecodeError, TopologyEncodeError};

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

fn random_topology(rng: &mut Rng) -> Topology {
    let node_count = 1 + rng.below(500) as u32;
    let triangles =
        (0..rng.below(300)).map(|_| core::array::from_fn(|_| rng.below(u64::from(node_count)) as u32)).collect();
    let names = ["skin", "fat", "muscle", "bone", "fascia", "peau-épiderme", ""];
    let layers = (0..rng.below(MAX_LAYERS as u64 + 1))
        .map(|k| {
            let first = rng.below(u64::from(node_count)) as u32;
            let count = rng.below(u64::from(node_count - first) + 1) as u32;
            LayerRange { name: format!("{}{k}", names[k as usize % names.len()]), first_node: first, node_count: count }
        })
        .collect();
    let tex_coords = if rng.below(2) == 0 {
        Vec::new()
    } else {
        (0..node_count)
            .map(|_| [rng.below(1 << 20) as f32 / 1e6 - 0.3, f32::from_bits(rng.next() as u32 & 0x3fff_ffff)])
            .collect()
    };
    Topology { node_count, triangles, layers, tex_coords }
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
    let layer = |name: &str, first, count| LayerRange { name: name.into(), first_node: first, node_count: count };
    assert_eq!(with(&|t| t.layers = vec![layer("a", 2, 2)]), Some(TopologyEncodeError::LayerOutOfRange));
    assert_eq!(with(&|t| t.layers = vec![layer("a", u32::MAX, 2)]), Some(TopologyEncodeError::LayerOutOfRange));
    let long = "x".repeat(LAYER_NAME_LEN + 1);
    assert_eq!(with(&|t| t.layers = vec![layer(&long, 0, 1)]), Some(TopologyEncodeError::InvalidLayerName));
    assert_eq!(with(&|t| t.layers = vec![layer("a\0b", 0, 1)]), Some(TopologyEncodeError::InvalidLayerName));
    assert_eq!(with(&|t| t.layers = vec![layer("a", 0, 1); MAX_LAYERS + 1]), Some(TopologyEncodeError::TooManyLayers));
    // Exactly the maximum name length is fine.
    assert_eq!(with(&|t| t.layers = vec![layer(&"y".repeat(LAYER_NAME_LEN), 0, 1)]), None);
}

#[test]
fn topology_invalid_decode_fails() {
    let topo = Topology {
        node_count: 3,
        triangles: vec![[0, 1, 2]],
        layers: vec![LayerRange { name: "skin".into(), first_node: 0, node_count: 3 }],
        tex_coords: vec![[0.5; 2]; 3],
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
}
