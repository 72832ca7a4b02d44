//! The deformable volume texture, rendered headless (lavapipe on a machine without a GPU).
//!
//! 1. The texture follows the tissue. A NIfTI-1 volume of sharp random blobs (written by this
//!    test, RGB24, millimetre spacing, its origin in the header) is drawn on the viewer's flat
//!    synthetic limb at rest, then with every node moved by a known translation along the limb
//!    (10 mm). The textured pattern inside the skin, with the smooth shading removed (each
//!    image divided by the same view drawn without texture), must reappear shifted by the
//!    translation's projection on the screen: the normalised cross-correlation peaks within
//!    1.5 px of the projected shift. Drawn instead with texture coordinates taken from the
//!    CURRENT positions (a deliberately wrong mapping, the texture fixed in space), the
//!    pattern does not move: the peak is within 1.5 px of no shift.
//! 2. The cut face shows the anatomy: with the procedural volume, pixels along a ray in the
//!    cut plane from above the skin to the bone's centre pass skin, fat, muscle and bone in
//!    that order (each judged by its hue).
//!
//! Without a Vulkan or GL adapter the tests print SKIP, unless `LAMINA_REQUIRE_GPU_SOFTWARE=1`.

use std::path::{Path, PathBuf};

use glam::{Vec3, Vec4Swizzles};
use lamina_viewer::app::{HeadlessViewer, Hud, ViewerOptions};
use lamina_viewer::mesh_build::{MeshOptions, SpringDisplay};
use lamina_viewer::synthetic::SyntheticLimb;
use lamina_viewer::view_model::{Frame, ViewModel, VolumeSpec};
use lamina_viewer::volume::{VoxelFormat, read_nifti};

const W: u32 = 480;
const H: u32 = 360;

fn viewer(texture: bool, cut: bool) -> Option<HeadlessViewer> {
    let options = ViewerOptions {
        width: W,
        height: H,
        samples: 4,
        mesh: MeshOptions { springs: SpringDisplay::Off, ..MeshOptions::default() },
        cut,
        overlay: false,
        focus: None,
        texture,
    };
    match HeadlessViewer::new(options) {
        Ok(v) => Some(v),
        Err(e) => {
            if std::env::var("LAMINA_REQUIRE_GPU_SOFTWARE").as_deref() == Ok("1") {
                panic!("LAMINA_REQUIRE_GPU_SOFTWARE=1 but no GPU adapter is available: {e}");
            }
            eprintln!("SKIP volume texture test: {e}");
            None
        }
    }
}

fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_volume_texture_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

/// Writes a single-file NIfTI-1 volume (`.nii`): RGB24 voxels (x fastest), spacing in mm,
/// the first voxel's centre at `origin_mm` (sform).
fn write_nifti_rgb(path: &Path, dims: [u16; 3], spacing_mm: f32, origin_mm: Vec3, rgb: &[[u8; 3]]) {
    let data: Vec<u8> = rgb.iter().flatten().copied().collect();
    write_nifti(path, dims, (128, 24), spacing_mm, origin_mm, &data);
}

/// Writes a single-file NIfTI-1 volume of `datatype = (code, bits)` voxels given as bytes.
fn write_nifti(path: &Path, dims: [u16; 3], datatype: (i16, i16), spacing_mm: f32, origin_mm: Vec3, data: &[u8]) {
    let mut h = vec![0u8; 352];
    let put_i16 = |h: &mut Vec<u8>, at: usize, v: i16| h[at..at + 2].copy_from_slice(&v.to_le_bytes());
    let put_f32 = |h: &mut Vec<u8>, at: usize, v: f32| h[at..at + 4].copy_from_slice(&v.to_le_bytes());
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (k, d) in [3i16, dims[0] as i16, dims[1] as i16, dims[2] as i16, 1, 1, 1, 1].into_iter().enumerate() {
        put_i16(&mut h, 40 + 2 * k, d);
    }
    put_i16(&mut h, 70, datatype.0);
    put_i16(&mut h, 72, datatype.1);
    for (k, p) in [1.0, spacing_mm, spacing_mm, spacing_mm, 1.0, 1.0, 1.0, 1.0].into_iter().enumerate() {
        put_f32(&mut h, 76 + 4 * k, p);
    }
    put_f32(&mut h, 108, 352.0); // vox_offset
    h[123] = 2; // xyzt_units: millimetres
    put_i16(&mut h, 254, 1); // sform_code
    for (row, o) in [origin_mm.x, origin_mm.y, origin_mm.z].into_iter().enumerate() {
        let mut srow = [0.0f32; 4];
        srow[row] = spacing_mm;
        srow[3] = o;
        for (k, v) in srow.into_iter().enumerate() {
            put_f32(&mut h, 280 + 16 * row + 4 * k, v);
        }
    }
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend_from_slice(data);
    std::fs::write(path, h).expect("write the NIfTI file");
}

/// A 3D pattern of sharp random blobs, about 5 mm across, in two colours.
fn blob_volume(dims: [u16; 3], spacing_mm: f32, seed: u64) -> Vec<[u8; 3]> {
    // A coarse random lattice, trilinearly interpolated and thresholded at its median.
    let cell_mm = 5.0;
    let n = |d: u16| ((d as f32 * spacing_mm / cell_mm).ceil() as usize) + 2;
    let (cx, cy, cz) = (n(dims[0]), n(dims[1]), n(dims[2]));
    let mut state = seed;
    let lattice: Vec<f32> = (0..cx * cy * cz)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect();
    let at = |x: usize, y: usize, z: usize| lattice[x + cx * (y + cy * z)];
    let mut out = Vec::with_capacity(dims.iter().map(|&d| d as usize).product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = Vec3::new(x as f32, y as f32, z as f32) * spacing_mm / cell_mm;
                let (f, t) = (p.floor(), p - p.floor());
                let (i, j, k) = (f.x as usize, f.y as usize, f.z as usize);
                let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
                let v = lerp(
                    lerp(lerp(at(i, j, k), at(i + 1, j, k), t.x), lerp(at(i, j + 1, k), at(i + 1, j + 1, k), t.x), t.y),
                    lerp(
                        lerp(at(i, j, k + 1), at(i + 1, j, k + 1), t.x),
                        lerp(at(i, j + 1, k + 1), at(i + 1, j + 1, k + 1), t.x),
                        t.y,
                    ),
                    t.z,
                );
                out.push(if v > 0.5 { [235, 225, 210] } else { [60, 40, 90] });
            }
        }
    }
    out
}

fn render(viewer: &mut HeadlessViewer, frame: &Frame) -> Vec<f32> {
    viewer.render(frame, &Hud::default()).expect("frame rendered");
    viewer.pixels().chunks_exact(4).map(|p| 0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32).collect()
}

/// Normalised cross-correlation of `a` in `region` against `b` shifted by `(dx, dy)`.
fn ncc(a: &[f32], b: &[f32], region: &[(i32, i32)], dx: i32, dy: i32) -> f32 {
    let pairs: Vec<(f32, f32)> = region
        .iter()
        .filter_map(|&(x, y)| {
            let (bx, by) = (x + dx, y + dy);
            ((0..W as i32).contains(&bx) && (0..H as i32).contains(&by))
                .then(|| (a[(y * W as i32 + x) as usize], b[(by * W as i32 + bx) as usize]))
        })
        .collect();
    let n = pairs.len() as f32;
    let (ma, mb) = pairs.iter().fold((0.0, 0.0), |(sa, sb), &(x, y)| (sa + x / n, sb + y / n));
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for &(x, y) in &pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt().max(1e-9)
}

/// The shift `(dx, dy)` within ±`reach` px that best matches `a`'s `region` in `b`.
fn best_shift(a: &[f32], b: &[f32], region: &[(i32, i32)], reach: i32) -> ((i32, i32), f32) {
    let mut best = ((0, 0), f32::NEG_INFINITY);
    for dy in -reach..=reach {
        for dx in -reach..=reach {
            let c = ncc(a, b, region, dx, dy);
            if c > best.1 {
                best = ((dx, dy), c);
            }
        }
    }
    best
}

fn translated(frame: &Frame, d: Vec3) -> Frame {
    Frame { positions: frame.positions.iter().map(|&p| p + d).collect(), tool: None, ..frame.clone() }
}

fn project(viewer: &HeadlessViewer, p: Vec3) -> (f32, f32) {
    let (camera, _) = viewer.composer().view().expect("the first frame fixes the view");
    let clip = camera.view_proj(W as f32 / H as f32) * p.extend(1.0);
    let ndc = clip.xy() / clip.w;
    ((ndc.x * 0.5 + 0.5) * W as f32, (0.5 - ndc.y * 0.5) * H as f32)
}

#[test]
fn texture_follows_the_tissue_not_space_works() {
    let limb = SyntheticLimb { indent_depth: 0.0, ..SyntheticLimb::default() };
    let rest_frame = Frame { tool: None, ..limb.frame(0, 0.0) };
    let shift = Vec3::new(0.010, 0.0, 0.0);
    let moved = translated(&rest_frame, shift);

    // The volume: 1 mm voxels over the limb's rest box and a margin for the shift.
    let (lo, hi) =
        rest_frame.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &p| (l.min(p), h.max(p)));
    let (lo, hi) = (lo - Vec3::splat(0.02), hi + Vec3::splat(0.02));
    let dims = ((hi - lo) * 1000.0).ceil().as_uvec3().to_array().map(|d| d as u16);
    let dir = scratch_dir("follow");
    let path = dir.join("blobs.nii");
    write_nifti_rgb(&path, dims, 1.0, lo * 1000.0, &blob_volume(dims, 1.0, 7));
    let spec = VolumeSpec { path: path.clone(), origin_m: None, window: None };
    // The reader places it from the header: first voxel centre at `lo`, 1 mm voxels.
    let image = read_nifti(&spec).expect("the test volume reads");
    assert_eq!(image.format, VoxelFormat::Rgba);
    assert_eq!(image.size, dims.map(u32::from));
    assert!((image.box_min - (lo - Vec3::splat(0.0005))).abs().max_element() < 1e-6, "{}", image.box_min);

    let mut model = limb.view_model();
    model.rest_positions = rest_frame.positions.clone();
    model.volume = Some(spec.clone());
    let wrong_model = ViewModel { rest_positions: moved.positions.clone(), ..model.clone() };

    // Each image over the same view without texture: the shading divides out.
    let draw = |model: &ViewModel, frame: &Frame| -> Option<Vec<f32>> {
        let mut textured = viewer(true, false)?;
        let mut flat = viewer(false, false)?;
        textured.set_model(model.clone());
        flat.set_model(model.clone());
        // The first frame (at rest) fixes the camera in both.
        render(&mut textured, &rest_frame);
        render(&mut flat, &rest_frame);
        let (t, f) = (render(&mut textured, frame), render(&mut flat, frame));
        Some(t.iter().zip(&f).map(|(t, f)| if *f > 8.0 { t / f } else { 0.0 }).collect())
    };
    let Some(at_rest) = draw(&model, &rest_frame) else { return };
    let Some(following) = draw(&model, &moved) else { return };
    let Some(fixed_in_space) = draw(&wrong_model, &moved) else { return };

    // The expected screen shift of the mid-limb skin top, and a region on the skin in both.
    let mut probe = viewer(false, false).expect("adapter");
    probe.set_model(model.clone());
    render(&mut probe, &rest_frame);
    let top = rest_frame.positions[limb.node(0, 0, limb.rows / 2) as usize];
    let (x0, y0) = project(&probe, top);
    let (x1, y1) = project(&probe, top + shift);
    let expected = (x1 - x0, y1 - y0);
    assert!(expected.0.hypot(expected.1) > 8.0, "the shift must be visible: {expected:?} px");
    // The region: the skin between the top and the front of the limb, 4 rows either side of
    // the middle, sampled in its cells and projected (visible from the default view).
    let mut region: Vec<(i32, i32)> = Vec::new();
    let node = |c: usize, r: usize| rest_frame.positions[limb.node(0, c, r) as usize];
    for r in limb.rows / 2 - 4..limb.rows / 2 + 4 {
        for c in 0..3 {
            for (i, j) in (0..24).flat_map(|i| (0..24).map(move |j| (i, j))) {
                let (u, v) = (i as f32 / 24.0, j as f32 / 24.0);
                let p = node(c, r).lerp(node(c + 1, r), u).lerp(node(c, r + 1).lerp(node(c + 1, r + 1), u), v);
                let (x, y) = project(&probe, p);
                region.push((x.round() as i32, y.round() as i32));
            }
        }
    }
    region.sort_unstable();
    region.dedup();
    assert!(region.len() > 2000, "the region on the skin has {} px", region.len());

    let (peak, score) = best_shift(&at_rest, &following, &region, 20);
    eprintln!("texture follows: expected shift {expected:?} px, peak at {peak:?} (NCC {score:.3})");
    let off = |p: (i32, i32), e: (f32, f32)| (p.0 as f32 - e.0).hypot(p.1 as f32 - e.1);
    assert!(off(peak, expected) <= 1.5, "the pattern moved by {peak:?} px, the surface by {expected:?} px");
    assert!(score > 0.6, "the moved pattern matches (NCC {score:.3})");

    let (wrong_peak, wrong_score) = best_shift(&at_rest, &fixed_in_space, &region, 20);
    eprintln!("texture from current positions: peak at {wrong_peak:?} (NCC {wrong_score:.3})");
    assert!(off(wrong_peak, (0.0, 0.0)) <= 1.5, "a texture fixed in space does not move: {wrong_peak:?}");
    assert!(off(wrong_peak, expected) > 5.0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The tissue a pixel's colour shows (sRGB bytes), by hue: muscle red, fat yellow, bone
/// ivory (blue close to green), skin pink-beige; `None` for the dark background.
fn tissue_of(p: [u8; 4]) -> Option<&'static str> {
    let [r, g, b] = [p[0] as f32, p[1] as f32, p[2] as f32];
    if r < 40.0 || b > r {
        return None; // the dark blue-grey background
    }
    Some(if g < 0.55 * r {
        "muscle"
    } else if b < 0.62 * g {
        "fat"
    } else if b > 0.8 * g && g > 0.85 * r {
        "bone"
    } else {
        "skin"
    })
}

#[test]
fn cut_face_shows_skin_to_bone_in_order_works() {
    let limb = SyntheticLimb { indent_depth: 0.0, ..SyntheticLimb::default() };
    let frame = Frame { tool: None, ..limb.frame(0, 0.0) };
    let Some(mut viewer) = viewer(true, true) else { return };
    viewer.set_model(limb.view_model());
    viewer.render(&frame, &Hud::default()).expect("frame rendered");
    let bake_ms = viewer.composer().volume_bake_ns() as f64 * 1e-6;
    let size = viewer.composer().drawn_volume().expect("a procedural volume").size;
    eprintln!("procedural volume {size:?} baked in {bake_ms:.0} ms");
    let (_, cut) = viewer.composer().view().expect("view fixed");
    let plane = cut.expect("the default view cuts");
    // The ray lies in the cut plane, from 3 mm above the skin's top down to the bone's axis
    // (the synthetic limb's rows run along x; the plane is normal to x).
    let row_at = |k: usize| {
        let ring: Vec<Vec3> = (0..limb.columns).map(|c| frame.positions[limb.node(k, c, 0) as usize]).collect();
        ring
    };
    let x = plane.offset / plane.normal.x;
    let skin_top = row_at(0)[0];
    let bone_axis = row_at(3).iter().copied().sum::<Vec3>() / limb.columns as f32;
    let start = Vec3::new(x, skin_top.y + 0.003, skin_top.z);
    let end = Vec3::new(x, bone_axis.y, bone_axis.z);
    let pixels = viewer.pixels();
    let mut order: Vec<&str> = Vec::new();
    let mut runs: Vec<(&str, usize)> = Vec::new();
    for k in 0..=400 {
        let p = start.lerp(end, k as f32 / 400.0);
        let (px, py) = project(&viewer, p);
        let i = ((py.round() as u32).min(H - 1) * W + (px.round() as u32).min(W - 1)) as usize * 4;
        let Some(t) = tissue_of(pixels[i..i + 4].try_into().unwrap()) else { continue };
        match runs.last_mut() {
            Some((last, n)) if *last == t => *n += 1,
            _ => runs.push((t, 1)),
        }
    }
    // Runs of at least 4 samples (a few pixels): speckle and blended edges are ignored.
    for &(t, n) in &runs {
        if n >= 4 && order.last() != Some(&t) {
            order.push(t);
        }
    }
    eprintln!("along the ray: {runs:?}");
    let first = |t: &str| order.iter().position(|o| *o == t).unwrap_or_else(|| panic!("no {t} on the ray: {order:?}"));
    assert!(
        first("skin") < first("fat") && first("fat") < first("muscle") && first("muscle") < first("bone"),
        "skin, fat, muscle, bone expected in that order from the outside in: {order:?}"
    );
}

#[test]
fn grey_volume_reads_through_its_window_works() {
    // float32 2 × 2 × 1, 0.5 mm voxels: 0, 10, 20, 40 through the window [10, 30].
    let dir = scratch_dir("grey");
    let path = dir.join("grey.nii");
    let values = [0.0f32, 10.0, 20.0, 40.0];
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    write_nifti(&path, [2, 2, 1], (16, 32), 0.5, Vec3::new(1.0, 2.0, 3.0), &bytes);
    let spec = VolumeSpec { path: path.clone(), origin_m: None, window: Some([10.0, 30.0]) };
    let v = read_nifti(&spec).expect("reads");
    assert_eq!((v.format, v.size), (VoxelFormat::Grey, [2, 2, 1]));
    assert_eq!(v.data, [0, 0, 128, 255]);
    // First voxel centre at the header's origin (1, 2, 3) mm; the box starts half a voxel before.
    assert!((v.box_min - Vec3::new(0.00075, 0.00175, 0.00275)).abs().max_element() < 1e-7, "{}", v.box_min);
    assert!((v.box_size - Vec3::new(0.001, 0.001, 0.0005)).abs().max_element() < 1e-7);
    // Without a window: the data's range; an origin from the scene replaces the header's.
    let spec = VolumeSpec { path: path.clone(), origin_m: Some([0.0, 0.0, 0.0]), window: None };
    let v = read_nifti(&spec).expect("reads");
    assert_eq!(v.data, [0, 64, 128, 255]);
    assert!((v.box_min + Vec3::splat(0.00025)).abs().max_element() < 1e-7);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_volume_files_fail() {
    let dir = scratch_dir("bad");
    let err = |path: &Path| read_nifti(&VolumeSpec { path: path.to_path_buf(), ..VolumeSpec::default() }).unwrap_err();
    // Missing.
    let missing = dir.join("missing.nii");
    let e = err(&missing).to_string();
    assert!(e.contains("missing.nii") && e.contains("cannot read"), "{e}");
    // Not NIfTI.
    let junk = dir.join("junk.nii");
    std::fs::write(&junk, vec![7u8; 400]).unwrap();
    let e = err(&junk).to_string();
    assert!(e.contains("junk.nii") && e.contains("not a usable NIfTI-1 volume"), "{e}");
    // A NaN voxel.
    let nan = dir.join("nan.nii");
    let bytes: Vec<u8> = [1.0f32, f32::NAN, 2.0, f32::INFINITY].iter().flat_map(|v| v.to_le_bytes()).collect();
    write_nifti(&nan, [2, 2, 1], (16, 32), 1.0, Vec3::ZERO, &bytes);
    let e = err(&nan).to_string();
    assert!(e.contains("nan.nii") && e.contains("2 voxels are NaN or infinite") && e.contains("voxel 1"), "{e}");
    // 2048 × 2048 × 512 bytes: 2 GiB of texture; refused from the header, before reading.
    let huge = dir.join("huge.nii");
    write_nifti(&huge, [2048, 2048, 512], (2, 8), 1.0, Vec3::ZERO, &[]);
    let e = err(&huge).to_string();
    assert!(e.contains("huge.nii") && e.contains("2048x2048x512") && e.contains("1 GiB"), "{e}");
    // Zero spacing.
    let flat = dir.join("flat.nii");
    write_nifti(&flat, [1, 1, 1], (2, 8), 0.0, Vec3::ZERO, &[1]);
    let e = err(&flat).to_string();
    assert!(e.contains("flat.nii") && e.contains("spacing"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn committed_phantom_reads_and_is_placed_by_its_header_works() {
    // tests/data/phantom16.nii: 16³ uint8, 6 mm voxels centred on the origin, a layered limb
    // along x (bone 250 inside 15 mm, muscle 140, fat 90, skin 200 to 50 mm, then 0).
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/phantom16.nii");
    let v = read_nifti(&VolumeSpec { path, origin_m: None, window: None }).expect("the phantom reads");
    assert_eq!((v.format, v.size), (VoxelFormat::Grey, [16, 16, 16]));
    assert!((v.box_min + Vec3::splat(0.048)).abs().max_element() < 1e-6, "{}", v.box_min);
    assert!((v.box_size - Vec3::splat(0.096)).abs().max_element() < 1e-6);
    let grey = |p: Vec3| v.voxel_at(v.texcoord(p))[0];
    assert_eq!(grey(Vec3::new(0.0, 0.003, 0.003)), 255, "bone: the maximum");
    assert_eq!(grey(Vec3::new(0.0, 0.027, 0.003)), (140.0f32 * 255.0 / 250.0).round() as u8, "muscle");
    assert_eq!(grey(Vec3::new(0.0, 0.045, 0.003)), (90.0f32 * 255.0 / 250.0).round() as u8, "fat");
    assert_eq!(grey(Vec3::new(0.0, 0.045, 0.045)), 0, "outside the limb");
}
