//! The partition of a step's contacts into islands: groups that share no dynamic body, so
//! that their rows of `A` do not couple and each can be solved on its own.

use super::ContactSystem;

/// An independent group of contacts: no dynamic body is shared with another island, so its
/// rows of `A` couple to no other island's rows ([`ContactSystem::islands`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Island {
    /// Contact indices, increasing.
    pub contacts: Vec<usize>,
    /// Rows of those contacts, increasing.
    pub rows: Vec<usize>,
    /// Dynamic bodies the contacts touch, in first-seen order.
    pub bodies: Vec<usize>,
}

/// The islands of a step with one numbering shared by all: every row and dynamic body
/// belongs to exactly one island, so one global → local map serves them all.
#[derive(Debug, Clone, Default)]
pub struct Partition {
    /// The islands.
    pub islands: Vec<Island>,
    /// Global row → row within its island.
    pub(super) local_row: Vec<usize>,
    /// Global body → body within its island (`usize::MAX` for bodies in no island).
    pub(super) local_body: Vec<usize>,
}

impl Partition {
    /// Number of islands.
    pub fn len(&self) -> usize {
        self.islands.len()
    }

    /// True when there are no contacts.
    pub fn is_empty(&self) -> bool {
        self.islands.is_empty()
    }
}

impl ContactSystem {
    /// touch (a static body joins no group). Islands are ordered by their first contact; the
    /// contacts, rows and bodies of each are increasing, first-seen and increasing respectively.
    pub fn islands(&self) -> Partition {
        let nc = self.contacts.len();
        let mut parent: Vec<usize> = (0..nc).collect();
        fn find(parent: &mut [usize], mut x: usize) -> usize {
            while parent[x] != x {
                parent[x] = parent[parent[x]];
                x = parent[x];
            }
            x
        }
        let mut first_contact = vec![usize::MAX; self.inv_mass.len()];
        for (c, info) in self.info.iter().enumerate() {
            for blk in &self.rows[info.normal_row].blocks {
                let other = first_contact[blk.body];
                if other == usize::MAX {
                    first_contact[blk.body] = c;
                } else {
                    let (ra, rb) = (find(&mut parent, c), find(&mut parent, other));
                    if ra != rb {
                        parent[ra.max(rb)] = ra.min(rb);
                    }
                }
            }
        }
        let mut island_of = vec![usize::MAX; nc];
        let mut islands: Vec<Island> = Vec::new();
        let mut body_seen = vec![false; self.inv_mass.len()];
        for c in 0..nc {
            let r = find(&mut parent, c);
            if island_of[r] == usize::MAX {
                island_of[r] = islands.len();
                islands.push(Island::default());
            }
            let island = &mut islands[island_of[r]];
            island.contacts.push(c);
            island.rows.extend(self.contact_rows(c));
            for blk in &self.rows[self.info[c].normal_row].blocks {
                if !body_seen[blk.body] {
                    body_seen[blk.body] = true;
                    island.bodies.push(blk.body);
                }
            }
        }
        let mut local_row = vec![usize::MAX; self.n()];
        let mut local_body = vec![usize::MAX; self.inv_mass.len()];
        for island in &islands {
            for (k, &i) in island.rows.iter().enumerate() {
                local_row[i] = k;
            }
            for (k, &b) in island.bodies.iter().enumerate() {
                local_body[b] = k;
            }
        }
        Partition {
            islands,
            local_row,
            local_body,
        }
    }
}
