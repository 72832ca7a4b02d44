//! A request above the memory available is refused with both sizes; this file caps its
//! process at 1 MiB so the figures do not depend on the machine.

use lamina_input::memory::set_process_limit;
use lamina_input::{FileLimit, FileReadError, MemoryCheckError, MemorySource, check_memory, memory_budget};

#[test]
fn memory_above_limit_fails() {
    set_process_limit(1 << 20);
    let budget = memory_budget().unwrap();
    assert!(budget.bytes.is_some_and(|b| b <= 1 << 20), "{budget:?}");
    assert!(check_memory("a small request", 1 << 19).is_ok());
    let e = check_memory("a 2 MiB request", 2 << 20).unwrap_err();
    assert_eq!(
        e,
        MemoryCheckError::TooLarge {
            what: "a 2 MiB request".into(),
            needed_bytes: 2 << 20,
            available_bytes: 1 << 20,
            source: MemorySource::Process
        }
    );
    assert_eq!(
        e.to_string(),
        "a 2 MiB request needs about 2.00 MiB (2,097,152 bytes), more than the 1.00 MiB (1,048,576 bytes) \
         available (the limit this program set)"
    );

    // A file whose parser takes 1000 bytes per byte: 2 KiB of file is refused.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.xml");
    std::fs::write(&path, vec![b' '; 2048]).unwrap();
    let limit = FileLimit::new("model file", 1 << 30).memory_per_byte(1000);
    let e = lamina_input::read_bytes(&path, &limit).unwrap_err();
    assert!(
        matches!(&e, FileReadError::Memory { error: MemoryCheckError::TooLarge { needed_bytes: 2_048_000, .. }, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("reading this model file (2.00 KiB (2,048 bytes)) needs about"), "{e}");
}
