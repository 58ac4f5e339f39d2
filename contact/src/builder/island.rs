//! The partition of a step's contacts and joints into islands: groups that share no dynamic
//! body, so that their rows of `A` do not couple and each can be solved on its own.

use super::ContactSystem;

/// An independent group of contacts and joints: no dynamic body is shared with another island,
/// so its rows of `A` couple to no other island's rows ([`ContactSystem::islands`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Island {
    /// Contact indices, increasing.
    pub contacts: Vec<usize>,
    /// Indices into [`ContactSystem::joints`], increasing.
    pub joints: Vec<usize>,
    /// Rows of those contacts, increasing.
    pub rows: Vec<usize>,
    /// Dynamic bodies the contacts and joints touch, in first-seen order.
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

    /// True when there are no contacts and no joints.
    pub fn is_empty(&self) -> bool {
        self.islands.is_empty()
    }
}

impl ContactSystem {
    /// The islands of the step: contacts and joints joined when they touch a common dynamic
    /// body (a static body joins no group). Islands are ordered by their first contact (or
    /// joint, after every island that has a contact); the contacts and joints of each are
    /// increasing, its rows are the contacts' rows then the joints' rows (increasing), its
    /// bodies in first-seen order.
    pub fn islands(&self) -> Partition {
        let (nc, nj) = (self.contacts.len(), self.joints.len());
        // Union–find over the constraints: contacts 0..nc, then joints nc..nc+nj.
        let mut parent: Vec<usize> = (0..nc + nj).collect();
        fn find(parent: &mut [usize], mut x: usize) -> usize {
            while parent[x] != x {
                parent[x] = parent[parent[x]];
                x = parent[x];
            }
            x
        }
        let first_row = |u: usize| {
            if u < nc {
                self.info[u].normal_row
            } else {
                self.joints[u - nc].rows.start
            }
        };
        let mut first_constraint = vec![usize::MAX; self.inv_mass.len()];
        for u in 0..nc + nj {
            for blk in &self.rows[first_row(u)].blocks {
                let other = first_constraint[blk.body];
                if other == usize::MAX {
                    first_constraint[blk.body] = u;
                } else {
                    let (ra, rb) = (find(&mut parent, u), find(&mut parent, other));
                    if ra != rb {
                        parent[ra.max(rb)] = ra.min(rb);
                    }
                }
            }
        }
        let mut island_of = vec![usize::MAX; nc + nj];
        let mut islands: Vec<Island> = Vec::new();
        let mut body_seen = vec![false; self.inv_mass.len()];
        for u in 0..nc + nj {
            let r = find(&mut parent, u);
            if island_of[r] == usize::MAX {
                island_of[r] = islands.len();
                islands.push(Island::default());
            }
            let island = &mut islands[island_of[r]];
            if u < nc {
                island.contacts.push(u);
                island.rows.extend(self.contact_rows(u));
            } else {
                island.joints.push(u - nc);
                island.rows.extend(self.joints[u - nc].rows.clone());
            }
            for blk in &self.rows[first_row(u)].blocks {
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
