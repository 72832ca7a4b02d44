//! The XML model reader on broken input: every defect in `tests/data/io/broken/` gives the
//! right error at the right line, and no input makes the reader panic.

use lamina_core::io::{ModelReadError, model_from_str, read_model};
use proptest::prelude::*;
use std::path::PathBuf;

fn data(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/io").join(path)
}

/// Reads `broken/<file>` and checks the error's variant (by name) and line.
fn check(file: &str, variant: &str, line: u32) {
    let path = data(&format!("broken/{file}"));
    let err = match read_model(&path) {
        Ok(_) => panic!("{file}: read without error"),
        Err(e) => e,
    };
    let name = format!("{err:?}");
    let name = name.split([' ', '{', '(']).next().unwrap_or_default();
    assert_eq!(name, variant, "{file}: wrong variant: {err}");
    assert_eq!(err.line(), Some(line), "{file}: wrong line: {err}");
    let loc = err.location().expect("located");
    assert!(loc.file.ends_with(file), "{file}: error names file {}", loc.file);
    assert!(err.to_string().starts_with(&format!("{}:{line}:", path.display())), "{err}");
}

/// File, expected variant, expected line.
const BROKEN: &[(&str, &str, u32)] = &[
    ("not_well_formed.xml", "Syntax", 20),
    ("truncated_in_springs.xml", "Truncated", 25),
    ("truncated_in_tag.xml", "Truncated", 23),
    ("unknown_element.xml", "UnknownElement", 21),
    ("unknown_attribute.xml", "UnknownAttribute", 17),
    ("missing_attribute.xml", "MissingAttribute", 18),
    ("bad_number.xml", "BadNumber", 17),
    ("non_finite.xml", "NonFinite", 19),
    ("layer_out_of_range.xml", "IndexOutOfRange", 19),
    ("spring_end_out_of_range.xml", "IndexOutOfRange", 23),
    ("duplicate_index.xml", "DuplicateIndex", 18),
    ("index_out_of_order.xml", "IndexOutOfOrder", 18),
    ("count_mismatch.xml", "CountMismatch", 20),
    ("unknown_law.xml", "UnknownValue", 23),
    ("unknown_kind.xml", "UnknownValue", 16),
    ("unknown_tissue.xml", "UnknownValue", 10),
    ("wrong_units.xml", "UnknownValue", 3),
    ("wrong_version.xml", "UnknownValue", 3),
    ("section_out_of_order.xml", "MisplacedElement", 8),
    ("missing_section.xml", "MissingElement", 33),
    ("zero_mass.xml", "Invalid", 19),
    ("spring_to_itself.xml", "Invalid", 23),
    ("turn_below_rest.xml", "Invalid", 24),
    ("bad_ppu.xml", "BadPpu", 25),
    ("stray_text.xml", "UnexpectedText", 20),
    ("triangle_out_of_range.xml", "IndexOutOfRange", 35),
    ("triangle_count_mismatch.xml", "CountMismatch", 36),
    ("empty.xml", "MissingElement", 1),
    ("second_root.xml", "MisplacedElement", 44),
    ("law_parameter_without_law.xml", "MissingAttribute", 22),
    ("missing_default_damping.xml", "MissingAttribute", 22),
];

#[test]
fn io_xml_broken_corpus_reports_variant_and_line_works() {
    for (file, variant, line) in BROKEN {
        check(file, variant, *line);
    }
}

#[test]
fn io_xml_broken_corpus_is_all_in_table_works() {
    let mut on_disk: Vec<String> = std::fs::read_dir(data("broken"))
        .expect("corpus directory")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = BROKEN.iter().map(|(f, _, _)| f.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
}

#[test]
fn io_xml_valid_example_reads_works() {
    let model = read_model(data("valid/small.xml")).expect("valid example");
    assert_eq!(model.nodes.len(), 4);
    assert_eq!(model.springs.len(), 3);
    assert_eq!(model.surfaces[0].triangles, vec![[0, 1, 3], [0, 3, 2]]);
    assert_eq!(model.surfaces[0].grid, Some((2, 2, vec![0, 1, 2, 3])));
}

#[test]
fn io_xml_bad_number_message_names_node_attribute_and_column_fails() {
    let err = read_model(data("broken/bad_number.xml")).unwrap_err();
    let msg = err.to_string();
    assert!(msg.ends_with("node 1: attribute 'mass' = 'abc' is not a number"), "{msg}");
    // `mass` starts in column 46 of `    <node index="1" x="0.01" y="0.0" z="0.0" mass="abc" ...`.
    assert_eq!(err.location().map(|l| l.column), Some(46), "{msg}");
}

#[test]
fn io_xml_missing_file_fails() {
    let err = read_model(data("no/such/file.xml")).unwrap_err();
    assert!(matches!(err, ModelReadError::Io { .. }), "{err}");
    assert!(err.to_string().contains("file.xml"), "{err}");
}

#[test]
fn io_xml_in_memory_error_names_string_fails() {
    let err =
        model_from_str("<lamina-model version=\"1\" units=\"SI (m, kg, s, N)\">\n  <nodes count=\"x\"/>").unwrap_err();
    assert!(matches!(err, ModelReadError::BadNumber { .. }), "{err}");
    assert_eq!(err.to_string(), "<string>:2:10: nodes: attribute 'count' = 'x' is not a number");
}

#[test]
fn io_xml_huge_declared_count_fails() {
    // A count no file could hold must not make the reader allocate it.
    let text = "<lamina-model version=\"1\" units=\"SI (m, kg, s, N)\"><layers count=\"18446744073709551615\"/>";
    let err = model_from_str(text).unwrap_err();
    assert!(matches!(err, ModelReadError::CountMismatch { .. }), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Cut, overwritten or spliced documents give an error or a model, never a panic.
    #[test]
    fn io_xml_mangled_input_never_panics_works(
        cut in 0usize..3000,
        at in 0usize..3000,
        bytes in proptest::collection::vec(any::<u8>(), 0..8),
        mode in 0u8..3,
    ) {
        let base = std::fs::read(data("valid/small.xml")).expect("example");
        let mut text = base.clone();
        let at = at.min(text.len());
        match mode {
            0 => text.truncate(cut.min(base.len())),
            1 => {
                for (k, b) in bytes.iter().enumerate() {
                    if at + k < text.len() {
                        text[at + k] = *b;
                    }
                }
            }
            _ => {
                text.splice(at..at, bytes.iter().copied());
            }
        }
        let text = String::from_utf8_lossy(&text);
        if let Err(e) = model_from_str(&text) {
            prop_assert!(e.line().is_some_and(|l| l >= 1), "{e}");
            let _ = e.to_string();
        }
    }
}
