//! Scene helpers shared by the contact test binaries (each binary compiles this module and
//! uses part of it).
#![allow(dead_code)]

use lcpbench_contact::Scene;
use std::path::PathBuf;

/// A scene from TOML text (as a scene file would hold it), or a panic naming the error.
pub fn inline(text: &str) -> Scene {
    Scene::parse(text, &PathBuf::from("inline.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// A chain of `links` 1 kg links (4 × 4 × 10 cm) hanging at rest from the world by ball
/// joints at z = 2 m, each 10 cm below the last, with an `end` kg box (10 cm) on the last
/// link; `settings` is the scene's `[settings]` table (its lines, without the header).
pub fn hanging_chain(links: usize, end: f64, settings: &str) -> Scene {
    let mut text = format!("[settings]\n{settings}\n");
    for i in 0..links {
        let z = 2.0 - 0.05 - 0.1 * i as f64;
        text += &format!(
            "[[bodies]]\nname = \"link_{i}\"\nshape = {{ type = \"box\", half_extents = [0.02, 0.02, 0.05] }}\nmass = 1.0\nposition = [0.0, 0.0, {z}]\n"
        );
    }
    let bottom = 2.0 - 0.1 * links as f64;
    text += &format!(
        "[[bodies]]\nname = \"end\"\nshape = {{ type = \"box\", half_extents = [0.05, 0.05, 0.05] }}\nmass = {end}\nposition = [0.0, 0.0, {}]\n",
        bottom - 0.05
    );
    for i in 0..=links {
        let a = if i == 0 {
            "world".to_owned()
        } else {
            format!("link_{}", i - 1)
        };
        let b = if i == links {
            "end".to_owned()
        } else {
            format!("link_{i}")
        };
        let z = 2.0 - 0.1 * i as f64;
        text += &format!(
            "[[joints]]\ntype = \"ball\"\nbodies = [\"{a}\", \"{b}\"]\nanchor = [0.0, 0.0, {z}]\n"
        );
    }
    inline(&text)
}
