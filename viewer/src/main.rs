//! The Lamina viewer process (renderer). Not built yet: see issue 8.
fn main() {
    eprintln!("lamina-viewer: the renderer is not implemented yet (issue 8)");
    std::process::exit(2);
}
