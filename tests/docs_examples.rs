//! Every TOML and JSON example in the README and `docs/` loads with the real loaders: a fenced
//! ```toml block is a scene file, a ```json block a problem file (a cone problem when it has a
//! `mu` key). A block that is not a whole file says so in its fence (```toml fragment,
//! ```json fragment) and is the only kind skipped.

use lcpbench_contact::Scene;
use lcpbench_solvers::{is_cone_file, parse_cone_problem, parse_problem};
use std::path::{Path, PathBuf};

/// One fenced block: its language, whether it is marked a fragment, its text and where it
/// starts (file and line).
struct Block {
    lang: String,
    fragment: bool,
    text: String,
    at: String,
}

/// The fenced code blocks of a Markdown file (fences may be indented, as inside a list item).
fn blocks(path: &Path) -> Vec<Block> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut out = Vec::new();
    let mut open: Option<(String, bool, usize, usize, Vec<String>)> = None;
    for (k, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        match open.take() {
            None => {
                if let Some(info) = trimmed.strip_prefix("```") {
                    let mut words = info.split_whitespace();
                    let lang = words.next().unwrap_or("").to_owned();
                    let fragment = words.any(|w| w == "fragment");
                    open = Some((lang, fragment, indent, k + 1, Vec::new()));
                }
            }
            Some((lang, fragment, ind, start, mut lines)) => {
                if trimmed.starts_with("```") {
                    out.push(Block {
                        lang,
                        fragment,
                        text: lines.join("\n") + "\n",
                        at: format!("{}:{start}", path.display()),
                    });
                } else {
                    lines.push(line.get(ind.min(indent)..).unwrap_or("").to_owned());
                    open = Some((lang, fragment, ind, start, lines));
                }
            }
        }
    }
    assert!(open.is_none(), "{}: an unclosed code fence", path.display());
    out
}

fn documents() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut docs = vec![root.join("README.md")];
    for entry in std::fs::read_dir(root.join("docs")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            docs.push(path);
        }
    }
    docs.sort();
    docs
}

#[test]
fn every_toml_and_json_example_loads() {
    let mut loaded = (0, 0);
    for doc in documents() {
        for block in blocks(&doc) {
            if block.fragment {
                continue;
            }
            let name = Path::new(&block.at);
            match block.lang.as_str() {
                "toml" => {
                    Scene::parse(&block.text, name)
                        .unwrap_or_else(|e| panic!("{}: the scene does not load: {e}", block.at));
                    loaded.0 += 1;
                }
                "json" => {
                    if is_cone_file(&block.text) {
                        parse_cone_problem(&block.text, name).unwrap_or_else(|e| {
                            panic!("{}: the cone problem does not load: {e}", block.at)
                        });
                    } else {
                        parse_problem(&block.text, name).unwrap_or_else(|e| {
                            panic!("{}: the problem does not load: {e}", block.at)
                        });
                    }
                    loaded.1 += 1;
                }
                _ => {}
            }
        }
    }
    // The scene example of docs/scenes.md, the README's LCP and cone examples.
    assert!(loaded.0 >= 1 && loaded.1 >= 2, "loaded {loaded:?}");
}

/// The extractor sees fences inside list items and skips only what is marked a fragment: a
/// broken example is caught.
#[test]
fn a_broken_example_is_caught() {
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("doc.md");
    std::fs::write(
        &doc,
        "- item\n\n  ```json\n  {\"A\": [[1]], \"b\": [1, 2]}\n  ```\n\n```toml fragment\n[[joints]]\n```\n",
    )
    .unwrap();
    let found = blocks(&doc);
    assert_eq!(found.len(), 2);
    assert!(!found[0].fragment && found[1].fragment);
    assert!(parse_problem(&found[0].text, Path::new("doc.md")).is_err());
}
