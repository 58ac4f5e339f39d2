//! The plot palette: a fixed colour for each shipped solver, a stable hashed one for any other
//! series (solver variants, cone solvers, faults, reference lines).

use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_solvers::SolverKind;

/// The plot palette (RGB): the solvers with a fixed slot ([`palette_slot`]) take theirs; other
/// series are hashed onto it.
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

/// The fixed palette slot of a shipped solver (`None`: the colour is hashed from the name).
pub fn palette_slot(name: &str) -> Option<usize> {
    if let Some(kind) = BodySolverKind::from_name(name) {
        return Some(match kind {
            BodySolverKind::SequentialImpulses => 6,
            BodySolverKind::MicroImpulses => 7,
            BodySolverKind::Penalty => 8,
            BodySolverKind::AveragedImpulse => 15,
        });
    }
    Some(match SolverKind::from_name(name)? {
        SolverKind::Pgs => 0,
        SolverKind::Sor => 1,
        SolverKind::Lemke => 2,
        SolverKind::Dantzig => 3,
        SolverKind::Clarabel => 4,
        SolverKind::MicroImpulse => 5,
        SolverKind::NewtonFb => 9,
        SolverKind::NewtonMin => 10,
        SolverKind::Apgd => 11,
        SolverKind::Nncg => 12,
        SolverKind::Nsgs => 13,
        SolverKind::Enumeration => 14,
    })
}

/// A stable colour per series key (a solver specification or name): a plain shipped solver
/// gets its fixed slot, anything else (variants, cone solvers, faults) a hashed one.
pub fn colour(key: &str) -> (u8, u8, u8) {
    if let Some(slot) = palette_slot(key) {
        return PALETTE[slot];
    }
    let h = key
        .bytes()
        .fold(7u64, |h, b| h.wrapping_mul(31).wrapping_add(b as u64));
    PALETTE[(h % PALETTE.len() as u64) as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_solvers_keep_their_plot_colours() {
        // Each shipped solver's slot, in palette order: a solver keeps its colour from one
        // report to the next.
        let fixed = [
            "pgs",
            "sor",
            "lemke",
            "dantzig",
            "clarabel",
            "micro",
            "si",
            "body-micro",
            "penalty",
            "newton-fb",
            "newton-min",
            "apgd",
            "nncg",
            "nsgs",
            "enum",
            "avg",
        ];
        for (i, name) in fixed.iter().enumerate() {
            assert_eq!(colour(name), PALETTE[i], "{name}");
        }
        // Variants and unlisted solvers are hashed, and stable.
        assert_eq!(colour("sor@1.5"), colour("sor@1.5"));
        let slots: std::collections::HashSet<_> = fixed.iter().map(|n| colour(n)).collect();
        assert_eq!(slots.len(), fixed.len());
    }
}
