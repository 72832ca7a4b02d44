//! Volume files a user may hand the viewer (`--volume`, a scene's `[visual]` table) that are
//! not what they claim: each is refused with the file, the field, the value and the bound,
//! before anything that could block or exhaust memory happens.
//!
//! NIfTI-1 headers are written here byte by byte from the format's specification
//! (<https://nifti.nimh.nih.gov/pub/dist/src/niftilib/nifti1.h>), NRRD headers from teem's
//! (<https://teem.sourceforge.net/nrrd/format.html>).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use lamina_viewer::view_model::VolumeSpec;
use lamina_viewer::volume::{VolumeError, VoxelFormat};
use lamina_viewer::volume_file::{read_volume, read_volume_header};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_robust_volume_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

fn spec(path: &Path) -> VolumeSpec {
    VolumeSpec { path: path.to_path_buf(), ..VolumeSpec::default() }
}

/// A single-file NIfTI-1 header (352 bytes with its extender) of uint8 voxels: `dims`,
/// spacings `pixdim` in millimetres, voxels at `vox_offset`, extender byte `extender`.
fn nifti_header(dims: [u16; 3], pixdim: [f32; 3], vox_offset: f32, extender: u8) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (k, d) in [3u16, dims[0], dims[1], dims[2], 1, 1, 1, 1].into_iter().enumerate() {
        h[40 + 2 * k..42 + 2 * k].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes()); // datatype uint8
    h[72..74].copy_from_slice(&8i16.to_le_bytes()); // bitpix
    for (k, p) in [1.0, pixdim[0], pixdim[1], pixdim[2], 1.0, 1.0, 1.0, 1.0].into_iter().enumerate() {
        h[76 + 4 * k..80 + 4 * k].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&vox_offset.to_le_bytes());
    h[123] = 2; // xyzt_units: millimetres
    h[344..348].copy_from_slice(b"n+1\0");
    h[348] = extender;
    h
}

/// Runs `f` on a thread; fails (instead of hanging the suite) when it has not returned
/// within a minute: a read that blocks on a FIFO never would.
fn within_a_minute<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(60)).expect("the read returned (it blocked on the FIFO before)")
}

fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo").arg(path).status().expect("mkfifo runs");
    assert!(status.success(), "mkfifo {}", path.display());
}

#[test]
fn robustness_volume_fifo_is_not_a_regular_file_fail() {
    let dir = scratch("fifo");
    let fifo_nii = dir.join("pipe.nii");
    let fifo_nrrd = dir.join("pipe.nrrd");
    let fifo_raw = dir.join("pipe.raw");
    for p in [&fifo_nii, &fifo_nrrd, &fifo_raw] {
        mkfifo(p);
    }
    let nhdr = dir.join("detached.nhdr");
    std::fs::write(
        &nhdr,
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nspacings: 1 1 1\nencoding: raw\ndata file: pipe.raw\n",
    )
    .unwrap();
    for (path, named) in [(&fifo_nii, &fifo_nii), (&fifo_nrrd, &fifo_nrrd), (&nhdr, &fifo_raw)] {
        let (p, q) = (path.clone(), path.clone());
        let header = within_a_minute(move || read_volume_header(&p).map(|_| ()));
        let volume = within_a_minute(move || read_volume(&spec(&q)).map(|_| ()));
        // The detached header itself is fine: its data file is the FIFO.
        let errors =
            if path == &nhdr { vec![volume.unwrap_err()] } else { vec![header.unwrap_err(), volume.unwrap_err()] };
        for e in errors {
            assert!(matches!(e, VolumeError::File(_)), "{e:?}");
            let text = e.to_string();
            assert!(text.contains(&named.display().to_string()), "{text}");
            assert!(text.contains("a FIFO (named pipe), not a regular file"), "{text}");
            assert!(!text.to_lowercase().contains("no such file"), "{text}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robustness_nifti_vox_offset_elsewhere_than_the_header_end_fail() {
    let dir = scratch("vox_offset");
    let voxels: Vec<u8> = (1..=8).collect();
    // Voxels at byte 1024 behind 672 bytes of padding, no extension: they used to be read
    // from byte 352, the padding drawn as the volume.
    let padded = dir.join("padded.nii");
    let mut bytes = nifti_header([2, 2, 2], [1.0; 3], 1024.0, 0);
    bytes.resize(1024, 0);
    bytes.extend_from_slice(&voxels);
    std::fs::write(&padded, &bytes).unwrap();
    let e = read_volume_header(&padded).unwrap_err().to_string();
    assert!(e.contains("padded.nii") && e.contains("vox_offset 1024:"), "{e}");
    assert!(e.contains("byte 352 (352 bytes of header and extender, no extensions)"), "{e}");
    // Before the header's end.
    let early = dir.join("early.nii");
    let mut bytes = nifti_header([2, 2, 2], [1.0; 3], 100.0, 0);
    bytes.extend_from_slice(&voxels);
    std::fs::write(&early, &bytes).unwrap();
    let e = read_volume(&spec(&early)).unwrap_err().to_string();
    assert!(e.contains("vox_offset 100:") && e.contains("after the 352 bytes of header"), "{e}");
    // One 32-byte extension and vox_offset 384: honoured, the voxels are the file's.
    let extended = dir.join("extended.nii");
    let mut bytes = nifti_header([2, 2, 2], [1.0; 3], 384.0, 1);
    bytes.extend_from_slice(&32i32.to_le_bytes());
    bytes.extend_from_slice(&4i32.to_le_bytes()); // ecode 4: AFNI
    bytes.resize(384, b' ');
    bytes.extend_from_slice(&voxels);
    std::fs::write(&extended, &bytes).unwrap();
    let v = read_volume(&spec(&extended)).expect("an extension ending at vox_offset reads");
    // Grey levels through the data's range 1..8: (v - 1) * 255 / 7.
    let expect: Vec<u8> = voxels.iter().map(|&x| ((f64::from(x) - 1.0) * 255.0 / 7.0).round() as u8).collect();
    assert_eq!((v.format, v.data.clone()), (VoxelFormat::Grey, expect));
    // The same extension with vox_offset 400: 16 bytes unaccounted for.
    let mut bytes = std::fs::read(&extended).unwrap();
    bytes[108..112].copy_from_slice(&400f32.to_le_bytes());
    std::fs::write(&extended, &bytes).unwrap();
    let e = read_volume_header(&extended).unwrap_err().to_string();
    assert!(e.contains("vox_offset 400:") && e.contains("byte 384 (352 bytes of header and extender, 32 bytes"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robustness_nifti_negative_or_subnormal_spacing_fail() {
    let dir = scratch("spacing");
    for pixdim in [[-1.0, 1.0, 1.0], [1.0, 1e-40, 1.0], [1.0, 1.0, 1e-36], [1.0, 1.0, 0.0]] {
        let path = dir.join("bad.nii");
        let mut bytes = nifti_header([2, 2, 2], pixdim, 352.0, 0);
        bytes.extend_from_slice(&[0u8; 8]);
        std::fs::write(&path, &bytes).unwrap();
        let e = read_volume_header(&path).unwrap_err();
        assert!(matches!(e, VolumeError::Field { field: "pixdim[1..3]", .. }), "{pixdim:?}: {e:?}");
        let text = e.to_string();
        let axis = pixdim.iter().position(|&p| p != 1.0).unwrap();
        let metres = lamina_rt::format_value(f64::from(pixdim[axis]) * 1e-3);
        assert!(text.contains(&format!("axis {axis} spacing is {metres} m")), "{pixdim:?}: {text}");
        assert!(text.contains("from 1.1754943508222875e-38 m to 3.4028234663852886e38 m"), "{text}");
    }
    // A large spacing within f32 passes: 1e30 mm is 1e27 m.
    let path = dir.join("one.nii");
    let mut bytes = nifti_header([1, 1, 1], [1e30, 1.0, 1.0], 352.0, 0);
    bytes.push(9);
    std::fs::write(&path, &bytes).unwrap();
    let g = read_volume_header(&path).expect("1e27 m is an f32");
    assert_eq!(g.spacing_m.x, 1e27);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robustness_nrrd_spacing_and_origin_beyond_f32_fail() {
    let dir = scratch("nrrd_spacing");
    let head = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n";
    // 1e-300 mm in metres, as the message computes and prints it.
    let tiny = format!("axis 2 spacing is {} m", lamina_rt::format_value(1e-300 * 1e-3));
    for (fields, field, line, shown) in [
        ("spacings: 1e300 1 1\n", "spacings", 6, "axis 0 spacing is 1e297 m"),
        ("spacings: 1 -2 1\n", "spacings", 6, "axis 1 spacing is -0.002 m"),
        // Each spacing is an f32, but two voxels of 3e38 m are not: the extent is checked too.
        ("space units: m m m\nspacings: 3e38 1 1\n", "spacings", 7, "axis 0 spacing is 3e38 m"),
        ("space directions: (1,0,0) (0,1,0) (0,0,1e-300)\n", "space directions", 6, &tiny),
        ("spacings: 1 1 1\nspace origin: (1e300,0,0)\n", "space origin", 7, "is [1e297, 0, 0] m"),
    ] {
        let path = dir.join("bad.nrrd");
        let mut bytes = format!("{head}{fields}\n").into_bytes();
        bytes.extend_from_slice(&[0u8; 8]);
        std::fs::write(&path, &bytes).unwrap();
        let e = read_volume_header(&path).unwrap_err().to_string();
        assert!(e.contains(&format!("line {line}:")) && e.contains(&format!("{field} ")), "{fields}: {e}");
        assert!(e.contains(shown), "{fields}: {e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robustness_visual_window_and_origin_beyond_f32_fail() {
    let phantom = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/phantom16.nii");
    let nrrd = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/phantom16.nrrd");
    for path in [&phantom, &nrrd] {
        for window in [[-1e300, 1e300], [0.0, 1e39], [1.0, 1.0 + 1e-12]] {
            let e = read_volume(&VolumeSpec { window: Some(window), ..spec(path) }).unwrap_err().to_string();
            assert!(e.contains("visual.window [") && e.contains("within ±3.4028234663852886e38 (f32)"), "{e}");
        }
        let e = read_volume(&VolumeSpec { origin_m: Some([0.0, -1e300, 0.0]), ..spec(path) }).unwrap_err().to_string();
        assert!(
            e.contains("visual.origin_m [0, -1e300, 0]: each coordinate must be within ±3.4028234663852886e38 m"),
            "{e}"
        );
        // Within f32 both read.
        let v = read_volume(&VolumeSpec { window: Some([0.0, 3e38]), origin_m: Some([0.0; 3]), ..spec(path) });
        assert!(v.is_ok(), "{v:?}");
    }
    // Through a scene's [visual] table, as lamina-viewer --replay --scene reads it.
    let block =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/block.toml")).unwrap();
    let text = format!("{block}\n[visual]\nvolume = {:?}\nwindow = [-1e300, 1e300]\n", phantom.display().to_string());
    let scene = lamina_core::scene::Scene::from_toml_str(&text, None).expect("the core accepts the window");
    let from_scene = VolumeSpec::from_scene(&scene).expect("the scene names a volume");
    let e = read_volume(&from_scene).unwrap_err().to_string();
    assert!(e.contains("visual.window [-1e300, 1e300]"), "{e}");
}

/// A gzip stream of `bytes`.
fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

#[test]
fn robustness_volume_conversion_beyond_the_memory_budget_fail() {
    // 1000^3 uint8 voxels: 0.93 GiB of texture, under the 1 GiB limit, but 7.45 GiB as
    // 64-bit floats. Refused from the header, under a 4 GiB budget, before any voxel is read:
    // the files hold only their headers and a few voxels.
    lamina_input::memory::set_process_limit(4 << 30);
    let dir = scratch("memory");
    let nii = dir.join("huge.nii.gz");
    let mut bytes = nifti_header([1000, 1000, 1000], [0.1; 3], 352.0, 0);
    bytes.extend_from_slice(&[7u8; 64]);
    std::fs::write(&nii, gzip(&bytes)).unwrap();
    let nrrd = dir.join("huge.nrrd");
    let mut bytes =
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1000 1000 1000\nspacings: 0.1 0.1 0.1\nencoding: gzip\n\n"
            .to_vec();
    bytes.extend_from_slice(&gzip(&[7u8; 64]));
    std::fs::write(&nrrd, bytes).unwrap();
    let budget = lamina_input::memory_budget().unwrap();
    for path in [&nii, &nrrd] {
        assert!(read_volume_header(path).is_ok(), "the header alone is fine");
        let e = within_a_minute({
            let p = path.clone();
            move || read_volume(&spec(&p)).map(|_| ())
        })
        .unwrap_err();
        assert!(matches!(e, VolumeError::Memory { .. }), "{e:?}");
        let text = e.to_string();
        assert!(text.contains(&path.display().to_string()) && text.contains("1000x1000x1000 voxels"), "{text}");
        // 1e9 bytes read, 8e9 of floats, 1e9 of texture.
        let needed = lamina_input::format_bytes(10_000_000_000);
        assert!(text.contains(&format!("needs about {needed}, more than the")), "{text}");
        assert!(text.contains("converting them to 64-bit floats (7.45 GiB"), "{text}");
        if budget.source == Some(lamina_input::MemorySource::Process) {
            assert!(text.contains(&lamina_input::format_bytes(4 << 30)), "{text}");
        }
    }
    // The committed phantom (16^3) still reads under the same budget.
    let phantom = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/phantom16.nii");
    assert!(read_volume(&spec(&phantom)).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robustness_nrrd_ascii_text_is_read_within_its_bound_fail() {
    // 8 samples: at most 8 * 64 + 4096 = 4,608 bytes of text are read, not the whole file
    // (up to the 16 GiB a volume file may be); here a megabyte of blanks after one number.
    let dir = scratch("ascii");
    let head = b"NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nspacings: 1 1 1\nencoding: ascii\n\n".to_vec();
    let blanks = dir.join("blanks.nrrd");
    std::fs::write(&blanks, [head.clone(), b"1 ".to_vec(), vec![b' '; 1 << 20], b"2 3 4 5 6 7 8\n".to_vec()].concat())
        .unwrap();
    let e = read_volume(&spec(&blanks)).unwrap_err().to_string();
    assert!(
        e.contains("blanks.nrrd") && e.contains("1 numbers within the first 4608 bytes of text, 8 expected"),
        "{e}"
    );
    // A number cut by the bound is not read as a shorter one: 4,600 bytes of blanks, then a
    // 20-digit number across byte 4,608 of the text.
    let cut = dir.join("cut.nrrd");
    let text = [b"1 2 3 4 5 6 7".to_vec(), vec![b' '; 4590], b"12345678901234567890\n".to_vec()].concat();
    std::fs::write(&cut, [head.clone(), text].concat()).unwrap();
    let e = read_volume(&spec(&cut)).unwrap_err().to_string();
    assert!(e.contains("7 numbers within the first 4608 bytes of text, 8 expected"), "{e}");
    // The same eight numbers close together read.
    let near = dir.join("near.nrrd");
    std::fs::write(&near, [head, b"1 2 3 4 5 6 7 8\n".to_vec()].concat()).unwrap();
    let v = read_volume(&spec(&near)).expect("eight numbers read");
    assert_eq!(v.data, (0..8).map(|k| (f64::from(k) * 255.0 / 7.0).round() as u8).collect::<Vec<_>>());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robustness_nifti_pair_with_a_fifo_or_an_offset_img_fail() {
    // A .hdr/.img pair (magic "ni1"): the voxels are the .img's from byte 0.
    let dir = scratch("pair");
    let hdr = dir.join("pair.hdr");
    let img = dir.join("pair.img");
    let mut header = nifti_header([2, 2, 2], [1.0; 3], 0.0, 0);
    header[344..348].copy_from_slice(b"ni1\0");
    std::fs::write(&hdr, &header[..348]).unwrap();
    std::fs::write(&img, (1..=8).collect::<Vec<u8>>()).unwrap();
    let v = read_volume(&spec(&hdr)).expect("a pair reads");
    assert_eq!((v.size, v.data[7]), ([2, 2, 2], 255));
    // The .img a FIFO: refused, not opened.
    std::fs::remove_file(&img).unwrap();
    mkfifo(&img);
    let p = hdr.clone();
    let e = within_a_minute(move || read_volume_header(&p).map(|_| ())).unwrap_err().to_string();
    assert!(e.contains("pair.img") && e.contains("a FIFO (named pipe), not a regular file"), "{e}");
    // vox_offset 352 in a pair.
    header[108..112].copy_from_slice(&352f32.to_le_bytes());
    std::fs::write(&hdr, &header[..348]).unwrap();
    let e = read_volume_header(&hdr).unwrap_err().to_string();
    assert!(e.contains("vox_offset 352:") && e.contains("from the start of the .img: it must be 0"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
