//! `include/lamina.h` is what cbindgen generates from the sources with `cbindgen.toml`: the
//! test generates it (cbindgen as a library) and compares it byte for byte with the committed
//! header, so a change of the ABI that is not in the header fails here (and in CI).
//!
//! After changing the ABI: `LAMINA_UPDATE_HEADER=1 cargo test -p lamina-client --test header`
//! writes the new header; commit it.

use std::path::PathBuf;

fn generated() -> String {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("client/cbindgen.toml reads");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_crate(&dir)
        .generate()
        .unwrap_or_else(|e| panic!("cbindgen cannot generate the header: {e}"));
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("cbindgen writes UTF-8")
}

#[test]
fn committed_header_is_what_cbindgen_generates_works() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("include/lamina.h");
    let fresh = generated();
    if std::env::var_os("LAMINA_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &fresh).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    if committed != fresh {
        let line = committed.lines().zip(fresh.lines()).position(|(a, b)| a != b).map_or_else(
            || {
                format!(
                    "the files differ in length ({} and {} lines)",
                    committed.lines().count(),
                    fresh.lines().count()
                )
            },
            |i| {
                format!(
                    "first difference at line {}: committed {:?}, generated {:?}",
                    i + 1,
                    committed.lines().nth(i),
                    fresh.lines().nth(i)
                )
            },
        );
        panic!(
            "client/include/lamina.h is not what cbindgen generates from client/src ({line}); run LAMINA_UPDATE_HEADER=1 cargo test -p lamina-client --test header and commit the header"
        );
    }
    // The header declares every exported function (an independent reading: the source's
    // `no_mangle` functions, found by text).
    let sources =
        ["src/lib.rs"].map(|f| std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(f)).unwrap());
    let mut exported = 0;
    for text in &sources {
        for (i, _) in text.match_indices("#[unsafe(no_mangle)]") {
            let rest = &text[i..];
            let name =
                rest.split("fn ").nth(1).and_then(|s| s.split('(').next()).expect("a function follows no_mangle");
            assert!(committed.contains(&format!("{name}(")), "{name} is not declared in lamina.h");
            exported += 1;
        }
    }
    assert!(exported >= 15, "found {exported} exported functions");
}
