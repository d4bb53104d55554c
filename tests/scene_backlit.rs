//! Scenes lit from behind: the committed meshes of docs/scenes/backlit-*
//! are the generator's (tests/common/backlit_meshes.rs); the scenes load;
//! a mesh that crosses itself or is open is refused before any work; the
//! path tracer's light through a flat slab lit from behind matches the
//! slab's Monte Carlo transmittance; `compare --scene --transmission` on a
//! small back-lit render gives the back-lit rows with their first lines.

mod common;

use common::backlit_meshes::{shell, wedge};
use std::path::Path;

fn scenes_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/scenes")
}

#[test]
fn committed_meshes_are_the_generators() {
    for (name, text) in [
        ("backlit-wedge.obj", wedge()),
        ("backlit-shell.obj", shell()),
    ] {
        let path = scenes_dir().join(name);
        if common::bless() {
            std::fs::write(&path, &text).unwrap();
        }
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            committed == text,
            "{name} is not the generator's: SSSKIT_BLESS=1 to rewrite"
        );
    }
}
