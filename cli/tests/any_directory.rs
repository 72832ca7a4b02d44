//! The `lamina` command works from any working directory: `lamina fit` finds its tissue
//! targets without `config/` under the working directory (the copy compiled in), and a scene
//! names its surfaces relative to itself, so `lamina generate --scene .../thigh.toml` run from
//! elsewhere reads the repository's BodyParts3D leg.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// An empty scratch directory, the working directory of the commands under test.
fn elsewhere(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_any_dir_{tag}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn lamina(cwd: &Path, args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_lamina")).current_dir(cwd).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "lamina {args:?} in {}: {}\n{}",
        cwd.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn fit_without_config_folder_uses_built_in_targets_works() {
    let dir = elsewhere("fit");
    let out = lamina(&dir, &["fit", "--grid-sizes", "12x3", "--model-grid", "12x3", "--max-evaluations", "10"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("tissue targets: built in"), "{stdout}");
    // The shipped skin target (config/materials/skin.toml: Ní Annaidh et al. 2012) is the one fitted.
    let skin_initial = stdout.lines().find(|l| l.starts_with("skin") && l.contains("initial_modulus_pa"));
    assert!(skin_initial.is_some_and(|l| l.contains(" 1.20000e6 ")), "{stdout}");
    let model = lamina_core::io::read_model(dir.join("out/fit/limb_12x3_fitted.xml")).unwrap();
    assert_eq!(model.nodes.len(), 12 * (7 * 3 + 1), "W(7H+1) masses");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fit_missing_materials_folder_fails() {
    let dir = elsewhere("fit_missing");
    let out = Command::new(env!("CARGO_BIN_EXE_lamina"))
        .current_dir(&dir)
        .args(["fit", "--materials", "nowhere", "--grid-sizes", "12x3", "--model-grid", "12x3"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("nowhere/skin.toml"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn generate_thigh_scene_from_another_directory_works() {
    let dir = elsewhere("thigh");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/thigh.toml");
    lamina(&dir, &["generate", "--scene", scene.to_str().unwrap(), "--out", "thigh.xml"]);
    let model = lamina_core::io::read_model(dir.join("thigh.xml")).unwrap();
    // The scene's grid: 39 columns by 10 rows.
    assert_eq!(model.nodes.len(), 39 * (7 * 10 + 1), "W(7H+1) masses");
    let _ = std::fs::remove_dir_all(&dir);
}
