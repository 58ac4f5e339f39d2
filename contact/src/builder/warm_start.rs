//! The warm-start cache: per-contact impulses of the previous step, kept by
//! [`Contact::key`](crate::collision::Contact::key), and the warm start of a new step's rows
//! built from them.

use super::ContactSystem;
use nalgebra::Vector3;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Per-contact impulse kept for warm starting: normal magnitude and world tangential impulse.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactImpulse {
    /// Normal impulse `f_n`.
    pub normal: f64,
    /// Tangential impulse, world frame.
    pub tangent: Vector3<f64>,
}

/// Impulses of the previous step, by [`Contact::key`](crate::collision::Contact::key), and each
/// joint's row impulses by joint index.
#[derive(Debug, Clone, Default)]
pub struct WarmStartCache {
    map: HashMap<u64, ContactImpulse, BuildHasherDefault<KeyHasher>>,
    joints: HashMap<usize, [f64; 6]>,
}

/// The hasher of [`WarmStartCache`]: a contact key is already a well-mixed 64-bit hash
/// ([`crate::collision::narrow_phase::contact_key`]), so it is its own hash (a general-purpose
/// hasher would cost more than the lookup).
#[derive(Debug, Clone, Copy, Default)]
pub struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(b);
        }
    }

    fn write_u64(&mut self, key: u64) {
        self.0 = key;
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

impl WarmStartCache {
    /// The impulse stored for `key`.
    pub fn get(&self, key: u64) -> Option<&ContactImpulse> {
        self.map.get(&key)
    }

    /// Replace the cache with the impulses of `system` solved as `f`.
    pub fn store(&mut self, system: &ContactSystem, f: &[f64]) {
        self.map.clear();
        for (c, contact) in system.contacts.iter().enumerate() {
            self.map.insert(contact.key, system.contact_impulse(c, f));
        }
        self.joints.clear();
        for j in &system.joints {
            let mut rows = [0.0; 6];
            for (r, i) in rows.iter_mut().zip(j.rows.clone()) {
                *r = f[i];
            }
            self.joints.insert(j.joint, rows);
        }
    }

    /// Number of contacts stored.
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    /// Forget everything.
    pub fn clear(&mut self) {
        self.map.clear();
        self.joints.clear();
    }
}

impl ContactSystem {
    /// A warm start from the cache: normal and tangential impulses of contacts seen last step
    /// (pyramid directions: the positive parts of the projections; slack rows zero) and the
    /// row impulses of each joint.
    pub fn warm_start(&self, cache: &WarmStartCache) -> Vec<f64> {
        let mut f = vec![0.0; self.n()];
        for (c, contact) in self.contacts.iter().enumerate() {
            let Some(imp) = cache.get(contact.key) else {
                continue;
            };
            let info = &self.info[c];
            f[info.normal_row] = imp.normal.max(0.0);
            let pyramid = info.slack_row.is_some();
            let k = info.friction_rows.len() as f64;
            for (j, r) in info.friction_rows.clone().enumerate() {
                let p = self.friction_direction(c, j).dot(&imp.tangent);
                f[r] = if pyramid { 2.0 * p.max(0.0) / k } else { p };
            }
        }
        for j in &self.joints {
            if let Some(rows) = cache.joints.get(&j.joint) {
                for (i, &v) in j.rows.clone().zip(rows) {
                    f[i] = v;
                }
            }
        }
        f
    }
}
