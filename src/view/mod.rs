//! Interactive, self-contained HTML pages of recordings and solves (`lcpbench view`).
//!
//! A *replay page* draws a recorded simulation in 3-D with three.js (bodies from their shapes,
//! contact points, normals and impulse vectors coloured by contact status, and joints as a
//! marker at each anchor joined by their drift, coloured by their error), a timeline with
//! per-step plots (uPlot), the selected step's convergence history and its contact table; two
//! recordings of the same scene are shown side by side, synchronised. A *solve page* shows every
//! solver on one problem: convergence histories and the final `f` and `w` per row.
//!
//! Every script, style and datum is inlined (the vendored libraries with their licences, see
//! `src/view/assets/vendor/README.md`), so a page opens without network. Replays are kept under
//! a byte budget by drawing every k-th step in 3-D (the plots keep every step), and the page
//! says so.
//!
//! Test hooks: `window.lcpbenchState` and the element `#lcpbench-state` (attributes
//! `data-ready`, `data-step`, `data-markers`, `data-joints`, `data-joint-markers`), errors
//! collected into `#lcpbench-errors`, and the URL hash: `#step=N` selects a step at load,
//! `hide=joints,normals` (after a `&`) starts with those layers' toggles off.

pub mod recording;
pub mod solve;

use serde_json::Value;
use std::path::PathBuf;
use thiserror::Error;

pub use recording::{header, Recording};
pub use solve::{iteration_unit, problem_data};

/// Errors reading the inputs of a page.
#[derive(Debug, Error)]
pub enum ViewError {
    /// A file could not be read or written.
    #[error("{0}: {1}")]
    Io(PathBuf, #[source] std::io::Error),
    /// A recording line is malformed.
    #[error("{path}: line {line}: {message}")]
    Recording {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// Two recordings compared side by side must come from the same scene.
    #[error("cannot compare recordings of different scenes: `{0}` and `{1}`")]
    DifferentScenes(String, String),
    /// A comparison takes one or two recordings.
    #[error("a replay page shows one recording or two side by side, not {0}")]
    TooManyRecordings(usize),
    /// The size bound of a page is below what its scripts and styles take.
    #[error(
        "a page size bound (--max-bytes) of {max} bytes is below the {min} bytes a page's \
         scripts, styles and smallest data take"
    )]
    BoundTooSmall {
        /// The bound asked for.
        max: usize,
        /// The smallest bound accepted.
        min: usize,
    },
    /// The page does not fit its size bound even with the fewest frames.
    #[error(
        "the page needs {needed} bytes even with the fewest 3-D frames, above its size bound \
         (--max-bytes) of {max} bytes"
    )]
    PageTooLarge {
        /// Bytes of the smallest page.
        needed: usize,
        /// The bound.
        max: usize,
    },
}

/// Default byte budget of a replay page (frames are decimated to fit).
pub const DEFAULT_MAX_BYTES: usize = 6_000_000;

/// The smallest size bound of a replay page (`replay`) or a solve page: the page's fixed part
/// (template, styles, scripts, licences: [`fixed_bytes`]) and the envelope of its data (the
/// data object without a run or a solver, [`data_envelope_bytes`]). Every real page is larger,
/// so no page that could be written is refused by this floor; a bound above it that a page
/// still cannot meet with its fewest frames is refused when the page is built, with the size
/// it needs.
pub fn min_page_bytes(replay: bool) -> usize {
    fixed_bytes(replay) + data_envelope_bytes(replay)
}

/// Bytes of the smallest data object a page holds: its kind, the generator and, for a replay
/// page, the size bound, with no runs (a solve page: no solvers).
fn data_envelope_bytes(replay: bool) -> usize {
    let envelope = if replay {
        serde_json::json!({
            "kind": "replay",
            "generator": concat!("lcpbench ", env!("CARGO_PKG_VERSION")),
            "max_bytes": 0,
            "runs": [],
        })
    } else {
        serde_json::json!({ "kind": "problem", "solvers": [] })
    };
    envelope.to_string().len()
}

const THREE: &str = include_str!("assets/vendor/three.min.js");
const UPLOT: &str = include_str!("assets/vendor/uPlot.iife.min.js");
const UPLOT_CSS: &str = include_str!("assets/vendor/uPlot.min.css");
const LICENSE_THREE: &str = include_str!("assets/vendor/LICENSE-three.txt");
const LICENSE_UPLOT: &str = include_str!("assets/vendor/LICENSE-uplot.txt");
const TEMPLATE: &str = include_str!("assets/page.html");
const CSS: &str = include_str!("assets/page.css");
const COMMON_JS: &str = include_str!("assets/common.js");
const REPLAY_JS: &str = include_str!("assets/replay.js");
const PROBLEM_JS: &str = include_str!("assets/problem.js");

/// Bytes of a page that are not data (scripts, styles, licences).
fn fixed_bytes(replay: bool) -> usize {
    TEMPLATE.len()
        + CSS.len()
        + COMMON_JS.len()
        + UPLOT.len()
        + UPLOT_CSS.len()
        + LICENSE_UPLOT.len()
        + if replay {
            THREE.len() + REPLAY_JS.len() + LICENSE_THREE.len()
        } else {
            PROBLEM_JS.len()
        }
}

/// The replay page of one recording, or of two side by side. The page stays within
/// `max_bytes` by decimating the 3-D frames (the per-step plots keep every step); a bound
/// below [`min_page_bytes`], or one the page cannot meet with its fewest frames, is an error.
pub fn replay_page(recordings: &[Recording], max_bytes: usize) -> Result<String, ViewError> {
    if recordings.is_empty() || recordings.len() > 2 {
        return Err(ViewError::TooManyRecordings(recordings.len()));
    }
    let min = min_page_bytes(true);
    if max_bytes < min {
        return Err(ViewError::BoundTooSmall {
            max: max_bytes,
            min,
        });
    }
    if let [a, b] = recordings {
        if a.header.scene != b.header.scene {
            return Err(ViewError::DifferentScenes(
                a.header.scene.clone(),
                b.header.scene.clone(),
            ));
        }
    }
    // A little room for the page's own text around the data; when the page still comes out
    // above the bound, the frames get that much less room, down to the first and last.
    let mut room = max_bytes.saturating_sub(fixed_bytes(true) + 4_000);
    loop {
        let html = replay_page_with(recordings, max_bytes, room / recordings.len());
        if html.len() <= max_bytes {
            return Ok(html);
        }
        let fewest = room == 0;
        room = room.saturating_sub(html.len() - max_bytes + 1_000);
        if fewest {
            return Err(ViewError::PageTooLarge {
                needed: html.len(),
                max: max_bytes,
            });
        }
    }
}

/// The replay page with `budget` bytes of JSON for each run's data.
fn replay_page_with(recordings: &[Recording], max_bytes: usize, budget: usize) -> String {
    let runs: Vec<Value> = recordings
        .iter()
        .map(|r| {
            let label = if recordings.len() == 2
                && recordings[0].header.solver == recordings[1].header.solver
            {
                r.source
                    .file_name()
                    .map(|f| f.to_string_lossy().into_owned())
                    .unwrap_or_else(|| r.header.solver.clone())
            } else {
                r.header.solver.clone()
            };
            recording::run_data(r, &label, budget)
        })
        .collect();
    let title = match recordings {
        [a] => format!(
            "{} · {}",
            isolate(&a.header.scene),
            isolate(&a.header.solver)
        ),
        [a, b] => format!(
            "{} · {} vs {}",
            isolate(&a.header.scene),
            isolate(&a.header.solver),
            isolate(&b.header.solver)
        ),
        _ => String::new(),
    };
    let data = serde_json::json!({
        "kind": "replay",
        "generator": concat!("lcpbench ", env!("CARGO_PKG_VERSION")),
        "max_bytes": max_bytes,
        "runs": runs,
    });
    page(&title, &data, true)
}

/// The solve page of a problem's data ([`problem_data`]), within `max_bytes` (the default is
/// [`DEFAULT_MAX_BYTES`]).
pub fn problem_page(data: &Value, max_bytes: usize) -> Result<String, ViewError> {
    let min = min_page_bytes(false);
    if max_bytes < min {
        return Err(ViewError::BoundTooSmall {
            max: max_bytes,
            min,
        });
    }
    let name = data
        .get("name")
        .and_then(Value::as_str)
        .unwrap_or("problem");
    let html = page(&format!("{} · every solver", isolate(name)), data, false);
    if html.len() > max_bytes {
        return Err(ViewError::PageTooLarge {
            needed: html.len(),
            max: max_bytes,
        });
    }
    Ok(html)
}

/// JSON text that can sit inside a `<script>` element without changing how the page parses:
/// `<`, `>` and `&` (which JSON has only inside strings) are written as `\u003c`, `\u003e`,
/// `\u0026`, so no name can open a comment (`<!--`), a script (`<script`) or end one
/// (`</script`), and `JSON.parse` reads the same strings back.
pub fn script_json(data: &Value) -> String {
    data.to_string()
        .replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026")
}

/// `template` with each `{{KEY}}` of `values` replaced in one pass: text put in by one
/// replacement (a title holding `{{DATA}}`) is never replaced again.
fn fill(template: &str, values: &[(&str, &str)]) -> String {
    let mut out =
        String::with_capacity(template.len() + values.iter().map(|v| v.1.len()).sum::<usize>());
    let mut rest = template;
    while let Some(i) = rest.find("{{") {
        out.push_str(&rest[..i]);
        let at = &rest[i..];
        match values.iter().find(|(key, _)| at.starts_with(key)) {
            Some((key, value)) => {
                out.push_str(value);
                rest = &at[key.len()..];
            }
            None => {
                out.push_str("{{");
                rest = &at[2..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// Assemble a page: template, styles, vendored scripts, data and the page's own script.
fn page(title: &str, data: &Value, replay: bool) -> String {
    let json = script_json(data);
    let licences = format!(
        "uPlot (https://github.com/leeoniya/uPlot)\n\n{LICENSE_UPLOT}{}",
        if replay {
            format!("\n\nthree.js (https://threejs.org)\n\n{LICENSE_THREE}")
        } else {
            String::new()
        }
    );
    let vendor = if replay {
        format!("{UPLOT}\n</script>\n<script>\n{THREE}")
    } else {
        UPLOT.to_string()
    };
    let app = format!(
        "{COMMON_JS}\n{}",
        if replay { REPLAY_JS } else { PROBLEM_JS }
    );
    fill(
        TEMPLATE,
        &[
            ("{{TITLE}}", &html_escape(title)),
            ("{{CSS}}", &format!("{UPLOT_CSS}\n{CSS}")),
            ("{{LICENSES}}", &html_escape(&licences)),
            ("{{APP}}", &app),
            ("{{VENDOR}}", &vendor),
            ("{{DATA}}", &json),
        ],
    )
}

/// A user-given name (scene, body, problem, recording label) set apart from the text around
/// it by Unicode's first-strong isolate (U+2068 … U+2069, what `<bdi>` does in markup, and
/// usable in `<title>` too): a right-to-left override (U+202E) or right-to-left letters inside
/// the name cannot reorder the rest of the line. The page's scripts do the same (`iso` in
/// `common.js`) wherever they put a name into text.
pub(crate) fn isolate(name: &str) -> String {
    format!("\u{2068}{name}\u{2069}")
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
