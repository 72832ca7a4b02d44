//! NRRD volume textures (viewer/src/nrrd.rs), against files written by an independent writer
//! and by hand from the format's specification (<https://teem.sourceforge.net/nrrd/format.html>).
//!
//! 1. The committed phantom written by pynrrd (tests/data/make_phantom_nrrd.py) as a gzip
//!    `.nrrd` and as a big-endian int16 `.nhdr` with its own data file gives the voxels, box
//!    and spacing the committed NIfTI phantom gives (the same anatomy from another writer).
//! 2. Headers written here give the voxels their bytes say: ascii samples through a window,
//!    a colour axis, a time axis (its first volume), skipped lines and bytes.
//! 3. Bad files are refused with the file, the header's line and what is wrong.

use std::path::{Path, PathBuf};

use glam::Vec3;
use lamina_viewer::view_model::VolumeSpec;
use lamina_viewer::volume::{VolumeError, VoxelFormat};
use lamina_viewer::volume_file::{read_volume, read_volume_header};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_nrrd_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

fn spec(path: &Path) -> VolumeSpec {
    VolumeSpec { path: path.to_path_buf(), ..VolumeSpec::default() }
}

/// Writes a `.nrrd` file: `header` lines, a blank line, then `data`.
fn write_nrrd(path: &Path, header: &str, data: &[u8]) {
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend_from_slice(b"\n");
    bytes.extend_from_slice(data);
    std::fs::write(path, bytes).expect("write the test volume");
}

#[test]
fn nrrd_phantom_gives_the_nifti_phantom_works() {
    let nifti = read_volume(&spec(&data("phantom16.nii"))).expect("the NIfTI phantom reads");
    let gzip = read_volume(&spec(&data("phantom16.nrrd"))).expect("the gzip NRRD phantom reads");
    assert_eq!((gzip.format, gzip.size), (VoxelFormat::Grey, [16, 16, 16]));
    assert_eq!(gzip.data, nifti.data, "same grey levels, voxel for voxel");
    assert!((gzip.box_min - nifti.box_min).abs().max_element() < 1e-7, "{} against {}", gzip.box_min, nifti.box_min);
    assert!((gzip.box_size - nifti.box_size).abs().max_element() < 1e-7);

    // Big-endian int16 in a data file of its own, the values times 4 (the window, the data's
    // range, gives the same grey levels), spacing in metres and no origin: the first voxel's
    // centre at 0.
    let detached = read_volume(&spec(&data("phantom16.nhdr"))).expect("the detached NRRD phantom reads");
    assert_eq!(detached.data, nifti.data);
    assert!((detached.box_size - Vec3::splat(0.096)).abs().max_element() < 1e-6, "{}", detached.box_size);
    assert!((detached.box_min + Vec3::splat(0.003)).abs().max_element() < 1e-7, "{}", detached.box_min);
    let header = read_volume_header(&data("phantom16.nhdr")).expect("header");
    assert_eq!(header.dims, [16, 16, 16]);
}

#[test]
fn nrrd_written_by_hand_reads_as_its_bytes_say_works() {
    let dir = scratch_dir("hand");

    // ascii floats, 2 × 2 × 1, spacings in the default unit (mm), origin (1, 2, 3) mm:
    // 0, 10, 20, 40 through the window [10, 30].
    let ascii = dir.join("ascii.nrrd");
    write_nrrd(
        &ascii,
        "NRRD0004\n# a comment\ntype: float\ndimension: 3\nsizes: 2 2 1\nspacings: 0.5 0.5 0.5\nspace origin: (1,2,3)\nencoding: ascii\nnote:=ignored\n",
        b"0 10\n20 40\n",
    );
    let v = read_volume(&VolumeSpec { window: Some([10.0, 30.0]), ..spec(&ascii) }).expect("ascii reads");
    assert_eq!((v.format, v.size, v.data.as_slice()), (VoxelFormat::Grey, [2, 2, 1], &[0u8, 0, 128, 255][..]));
    assert!((v.box_min - Vec3::new(0.00075, 0.00175, 0.00275)).abs().max_element() < 1e-7, "{}", v.box_min);
    assert!((v.box_size - Vec3::new(0.001, 0.001, 0.0005)).abs().max_element() < 1e-7);

    // A colour axis first: RGB bytes per voxel, 2 × 1 × 1, drawn as RGBA.
    let rgb = dir.join("rgb.nrrd");
    write_nrrd(
        &rgb,
        "NRRD0005\ntype: uchar\ndimension: 4\nsizes: 3 2 1 1\nkinds: RGB-color domain domain domain\nspace dimension: 3\nspace directions: none (1,0,0) (0,1,0) (0,0,2)\nspace units: \"cm\" \"cm\" \"cm\"\nencoding: raw\n",
        &[10, 20, 30, 200, 150, 100],
    );
    let v = read_volume(&spec(&rgb)).expect("rgb reads");
    assert_eq!((v.format, v.size), (VoxelFormat::Rgba, [2, 1, 1]));
    assert_eq!(v.data, [10, 20, 30, 255, 200, 150, 100, 255]);
    assert!((v.box_size - Vec3::new(0.02, 0.01, 0.02)).abs().max_element() < 1e-7, "{}", v.box_size);

    // A time axis last: the first of two volumes (little-endian uint16 1, 3; then 1000, 1000).
    let time = dir.join("time.nrrd");
    let samples: Vec<u8> = [1u16, 3, 1000, 1000].iter().flat_map(|v| v.to_le_bytes()).collect();
    write_nrrd(
        &time,
        "NRRD0004\ntype: ushort\ndimension: 4\nsizes: 2 1 1 2\nspace directions: (1,0,0) (0,1,0) (0,0,1) none\nendian: little\nencoding: raw\n",
        &samples,
    );
    assert_eq!(read_volume(&spec(&time)).expect("time reads").data, [0, 255]);

    // A detached data file: two text lines skipped, then 3 bytes skipped, then big-endian
    // int32 -5, 5; and the same data read from the end of a file (byte skip -1).
    let raw = dir.join("samples.raw");
    let mut bytes = b"line one\nline two\nxyz".to_vec();
    bytes.extend([-5i32, 5].iter().flat_map(|v| v.to_be_bytes()));
    std::fs::write(&raw, &bytes).unwrap();
    let common =
        "type: int\ndimension: 3\nsizes: 1 2 1\nspacings: 1 1 1\nendian: big\nencoding: raw\ndata file: samples.raw\n";
    let skipped = dir.join("skipped.nhdr");
    std::fs::write(&skipped, format!("NRRD0004\n{common}line skip: 2\nbyte skip: 3\n")).unwrap();
    assert_eq!(read_volume(&spec(&skipped)).expect("skips read").data, [0, 255]);
    let at_end = dir.join("at_end.nhdr");
    std::fs::write(&at_end, format!("NRRD0004\n{common}byte skip: -1\n")).unwrap();
    assert_eq!(read_volume(&spec(&at_end)).expect("data at the end reads").data, [0, 255]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_nrrd_files_fail() {
    let dir = scratch_dir("bad");
    let err = |name: &str, header: &str, data: &[u8]| -> VolumeError {
        let path = dir.join(name);
        write_nrrd(&path, header, data);
        read_volume(&spec(&path)).expect_err(name)
    };
    let good = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 1 1\nspacings: 1 1 1\nencoding: raw\n";
    assert!(
        read_volume(&spec(&{
            let p = dir.join("good.nrrd");
            write_nrrd(&p, good, &[1, 2]);
            p
        }))
        .is_ok()
    );
    let header_line = |e: VolumeError| match e {
        VolumeError::NrrdHeader { line, message, path } => {
            assert!(path.starts_with(&dir), "{}", path.display());
            (line, message)
        }
        other => panic!("a header error expected, got {other}"),
    };
    // (file, header, what the error says, on which line)
    let cases: [(&str, String, &str, usize); 10] = [
        ("magic.nrrd", good.replace("NRRD0004", "NRRD0009"), "NRRD0001 to NRRD0005", 1),
        ("block.nrrd", good.replace("uchar", "block"), "type \"block\" is not read", 2),
        ("dims.nrrd", good.replace("dimension: 3", "dimension: 2"), "three spatial axes", 3),
        ("sizes.nrrd", good.replace("sizes: 2 1 1", "sizes: 2 1"), "2 entries for 3 axes", 4),
        ("zero.nrrd", good.replace("sizes: 2 1 1", "sizes: 2 0 1"), "at least 1", 4),
        ("spacing.nrrd", good.replace("spacings: 1 1 1", "spacings: 1 nan 1"), "axis 1 spacing is NaN m", 5),
        ("bzip2.nrrd", good.replace("raw", "bzip2"), "encoding \"bzip2\" is not read", 6),
        ("missing.nrrd", good.replace("sizes: 2 1 1\n", ""), "no \"sizes:\" field", 5),
        ("endian.nrrd", good.replace("uchar", "short"), "no \"endian:\" field", 6),
        ("units.nrrd", format!("{good}space units: \"mm\" \"inch\" \"mm\"\n"), "space unit \"inch\"", 7),
    ];
    for (name, header, says, on_line) in cases {
        let (line, message) = header_line(err(name, &header, &[1, 2, 3, 4]));
        assert!(message.contains(says) && line == on_line, "{name}: line {line}: {message}");
    }
    let e = err("nofield.nrrd", "NRRD0004\ntype uchar\n", &[]).to_string();
    assert!(e.contains("nofield.nrrd") && e.contains("line 2") && e.contains("field: value"), "{e}");

    // Sizes beyond the texture limit: refused from the header, before any data.
    let e = err("huge.nrrd", &good.replace("sizes: 2 1 1", "sizes: 4096 4096 4096"), &[]);
    assert!(matches!(e, VolumeError::TooLarge { dims: [4096, 4096, 4096], .. }), "{e}");
    let e = err("overflow.nrrd", &good.replace("sizes: 2 1 1", "sizes: 18446744073709551615 2 2"), &[]).to_string();
    assert!(e.contains("overflow.nrrd") && e.contains("1 GiB limit"), "{e}");
    // Too few bytes, an undecodable gzip stream, a missing data file, a NaN sample.
    let e = err("short.nrrd", good, &[1]).to_string();
    assert!(e.contains("short.nrrd") && e.contains("1 bytes of data, 2 expected"), "{e}");
    let e = err("gzip.nrrd", &good.replace("raw", "gzip"), b"not gzip at all").to_string();
    assert!(e.contains("gzip.nrrd") && e.contains("cannot decode"), "{e}");
    let e = err("detached.nhdr", &format!("{good}data file: nowhere.raw\n"), &[]).to_string();
    assert!(e.contains("nowhere.raw") && e.contains("cannot read"), "{e}");
    let e = err("nan.nrrd", &good.replace("uchar", "float").replace("raw", "ascii"), b"1 nan").to_string();
    assert!(e.contains("nan.nrrd") && e.contains("1 voxels are NaN or infinite") && e.contains("voxel 1"), "{e}");
    // A header that never ends.
    let endless = dir.join("endless.nrrd");
    std::fs::write(&endless, format!("NRRD0004\n{}", "content: x\n".repeat(200_000))).unwrap();
    let (_, message) = header_line(read_volume(&spec(&endless)).unwrap_err());
    assert!(message.contains("no end of the header"), "{message}");
    let _ = std::fs::remove_dir_all(&dir);
}
