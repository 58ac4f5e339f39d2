//! The plots' styles: each series a (colour, marker) pair, no pair repeated in a plot, for any
//! number of series.
//!
//! Every solver of the registry (matrix, body-level, cone, and those registered at run time)
//! has a fixed index from its place in the registry, so it keeps its style from one figure and
//! one report to the next: its colour is its slot in [`PALETTE`], its marker a filled one, and
//! its warm-started form the same colour with the hollow marker (see `solver_index`). Other
//! series (parameter variants, faults, friction models, unknown names) take the next free
//! index of the figure ([`styles`]). Index `i` is the pair (colour `i mod 16`, marker
//! `i div 16`) for the first `16 × 8` indices; beyond them the colours are generated
//! (golden-angle hues), so pairs never repeat however many solvers and series a figure has.

/// The plot palette (RGB): sixteen colours told apart on white.
pub const PALETTE: [(u8, u8, u8); 16] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
    (0, 0, 128),
    (128, 0, 0),
    (0, 100, 0),
    (255, 215, 0),
    (0, 0, 0),
    (255, 0, 255),
];

/// A marker shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Marker {
    /// Filled circle.
    Circle,
    /// Filled triangle.
    Triangle,
    /// Hollow circle.
    HollowCircle,
    /// Hollow triangle.
    HollowTriangle,
    /// Filled square.
    Square,
    /// Filled diamond.
    Diamond,
    /// Hollow square.
    HollowSquare,
    /// Cross.
    Cross,
}

/// The markers, in index order (see the module doc).
pub const MARKERS: [Marker; 8] = [
    Marker::Circle,
    Marker::Triangle,
    Marker::HollowCircle,
    Marker::HollowTriangle,
    Marker::Square,
    Marker::Diamond,
    Marker::HollowSquare,
    Marker::Cross,
];

/// A series' style.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Style {
    /// RGB colour.
    pub colour: (u8, u8, u8),
    /// Marker.
    pub marker: Marker,
}

/// The style of index `i`.
pub fn style_at(i: usize) -> Style {
    let (row, col) = (i / PALETTE.len(), i % PALETTE.len());
    let colour = if row < MARKERS.len() {
        PALETTE[col]
    } else {
        generated_colour(i)
    };
    Style {
        colour,
        marker: MARKERS[row % MARKERS.len()],
    }
}

/// A colour of golden-angle hue `i` (saturation and value varied with `i` too), for indices
/// past the fixed pairs.
fn generated_colour(i: usize) -> (u8, u8, u8) {
    let h = (i as f64 * 137.507_764_050_037_86).rem_euclid(360.0);
    let s = 0.55 + 0.4 * ((i * 7 % 11) as f64 / 10.0);
    let v = 0.45 + 0.4 * ((i * 3 % 7) as f64 / 6.0);
    let c = v * s;
    let x = c * (1.0 - ((h / 60.0).rem_euclid(2.0) - 1.0).abs());
    let (r, g, b) = match (h / 60.0) as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let to = |u: f64| ((u + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    (to(r), to(g), to(b))
}

/// Every solver's name, in the order of their fixed indices: the registry's order (built-ins,
/// then those registered at run time).
fn shipped_names() -> Vec<&'static str> {
    lcpbench_contact::registry::entries()
        .iter()
        .map(|e| e.name)
        .collect()
}

/// The fixed index of the `b`-th solver of the registry, cold or warm-started. Solvers come
/// in groups of sixteen, one colour each; groups pair up in blocks of four marker rows: the
/// first group of a block cold on row 0 of the block (filled circle) and warm on row 2 (hollow
/// circle), the second cold on row 1 (filled triangle) and warm on row 3 (hollow triangle). So
/// the first 32 solvers keep the styles they have always had, 64 solvers fill the sixteen
/// colours × eight markers, and beyond that [`style_at`] generates colours.
fn solver_index(b: usize, warm: bool) -> usize {
    let (group, col) = (b / PALETTE.len(), b % PALETTE.len());
    let row = 4 * (group / 2) + group % 2 + if warm { 2 } else { 0 };
    row * PALETTE.len() + col
}

/// The fixed index of a solver's specification (`pgs`, `pgs+warm`, `nsgs-cone`), or `None`
/// for anything else (parameters, faults, names no solver has). Cold: the filled marker of its
/// colour; warm: the same colour with the hollow marker ([`solver_index`]).
pub fn fixed_index(key: &str) -> Option<usize> {
    let (base, warm) = match key.strip_suffix("+warm") {
        Some(b) => (b, true),
        None => (key, false),
    };
    let b = shipped_names().iter().position(|n| *n == base)?;
    Some(solver_index(b, warm))
}

/// The first index of the series without a fixed one: past the marker rows the registry's
/// solvers take (four rows per 32 solvers).
fn free_from(solvers: usize) -> usize {
    4 * PALETTE.len() * solvers.div_ceil(2 * PALETTE.len()).max(1)
}

/// A style for each key, in order: equal keys share one, different keys never do. Shipped
/// solvers take their fixed index, the others the free indices in order of first appearance.
pub fn styles<S: AsRef<str>>(keys: &[S]) -> Vec<Style> {
    let mut assigned: Vec<(String, usize)> = Vec::new();
    let mut next = free_from(shipped_names().len());
    keys.iter()
        .map(|k| {
            let k = k.as_ref();
            if let Some((_, i)) = assigned.iter().find(|(name, _)| name == k) {
                return style_at(*i);
            }
            let i = fixed_index(k).unwrap_or_else(|| {
                let i = next;
                next += 1;
                i
            });
            assigned.push((k.to_owned(), i));
            style_at(i)
        })
        .collect()
}

/// The colour of a series key on its own (the fixed one of a shipped solver; otherwise that
/// of the first free index): for figures with one series per colour, such as bars.
pub fn colour(key: &str) -> (u8, u8, u8) {
    styles(&[key])[0].colour
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn shipped_solvers_keep_their_styles_and_warm_forms_differ() {
        assert_eq!(style_at(fixed_index("pgs").unwrap()).colour, PALETTE[0]);
        assert_eq!(style_at(fixed_index("sor").unwrap()).colour, PALETTE[1]);
        let pgs = styles(&["pgs", "pgs+warm", "sor", "newton-fb", "newton-min"]);
        assert_eq!(pgs[0].colour, pgs[1].colour);
        assert_ne!(pgs[0].marker, pgs[1].marker);
        let set: HashSet<Style> = pgs.iter().copied().collect();
        assert_eq!(set.len(), pgs.len());
    }

    /// Forty solvers, and four hundred series, get distinct (colour, marker) pairs; a key
    /// repeated gets its first style.
    #[test]
    fn any_number_of_series_gets_distinct_pairs() {
        let mut keys: Vec<String> = shipped_names().iter().map(|s| s.to_string()).collect();
        keys.extend(shipped_names().iter().map(|s| format!("{s}+warm")));
        keys.truncate(40);
        keys.extend((0..360).map(|i| format!("sor@{i}")));
        for n in [40, keys.len()] {
            let s = styles(&keys[..n]);
            let set: HashSet<Style> = s.iter().copied().collect();
            assert_eq!(set.len(), n, "{n} series");
        }
        let again = styles(&["x", "pgs", "x"]);
        assert_eq!(again[0], again[2]);
        assert_ne!(again[0], again[1]);
    }

    /// Sixty-four solvers, cold and warm, get distinct pairs from their fixed indices alone
    /// (as many as the registry could hold after 34 more registrations), and the free indices
    /// start past them.
    #[test]
    fn sixty_four_solvers_get_distinct_pairs() {
        let mut seen = HashSet::new();
        for b in 0..64 {
            for warm in [false, true] {
                let i = solver_index(b, warm);
                assert!(i < free_from(64), "{b} {warm}");
                assert!(seen.insert(style_at(i)), "solver {b} warm {warm}");
            }
        }
        assert!(free_from(64) >= 128 && free_from(30) == 64);
        let names: Vec<String> = (0..64).map(|i| format!("solver-{i}")).collect();
        let s = styles(&names);
        assert_eq!(s.iter().copied().collect::<HashSet<Style>>().len(), 64);
        // The first 32 keep the layout they always had: cold on rows 0 and 1, warm on 2 and 3.
        assert_eq!(solver_index(0, false), 0);
        assert_eq!(solver_index(0, true), 2 * 16);
        assert_eq!(solver_index(17, false), 16 + 1);
        assert_eq!(solver_index(17, true), 3 * 16 + 1);
    }
}
