//! The matrix-free Delassus operator: products with `A = J M⁻¹ Jᵀ`, its rows and entries,
//! applied body by body from the Jacobian rows and inverse masses, without forming `A`.

use super::{BodyVelocity, ContactSystem, InverseMass, JacobianRow};

impl ContactSystem {
    /// The matrix-free operator over this system's Jacobian rows.
    pub fn operator(&self) -> DelassusOperator<'_> {
        DelassusOperator {
            rows: &self.rows,
            inv_mass: &self.inv_mass,
        }
    }
}

/// Matrix-free `A = J M⁻¹ Jᵀ`: applies `J`, `M⁻¹` and `Jᵀ` body by body, never forming `A`.
#[derive(Debug, Clone, Copy)]
pub struct DelassusOperator<'a> {
    rows: &'a [JacobianRow],
    inv_mass: &'a [InverseMass],
}

impl DelassusOperator<'_> {
    /// `(J u)_i`.
    #[inline]
    pub fn row_dot(&self, i: usize, u: &[BodyVelocity]) -> f64 {
        self.rows[i].blocks.iter().map(|b| b.dot(&u[b.body])).sum()
    }

    /// `A_ii = J_i M⁻¹ J_iᵀ`.
    pub fn diagonal(&self, i: usize) -> f64 {
        self.rows[i]
            .blocks
            .iter()
            .map(|b| b.dot(&self.inv_mass[b.body].response(b, 1.0)))
            .sum()
    }

    /// `A_ij = J_i M⁻¹ J_jᵀ` for two Jacobian rows.
    pub fn entry(&self, i: usize, j: usize) -> f64 {
        let mut s = 0.0;
        for bi in &self.rows[i].blocks {
            for bj in &self.rows[j].blocks {
                if bi.body == bj.body {
                    s += bi.dot(&self.inv_mass[bj.body].response(bj, 1.0));
                }
            }
        }
        s
    }

    /// `u += M⁻¹ J_iᵀ impulse` for one row.
    #[inline]
    pub fn apply_row(&self, i: usize, impulse: f64, u: &mut [BodyVelocity]) {
        for b in &self.rows[i].blocks {
            let r = self.inv_mass[b.body].response(b, impulse);
            u[b.body].linear += r.linear;
            u[b.body].angular += r.angular;
        }
    }

    /// `u += M⁻¹ Jᵀ f`.
    pub fn add_response(&self, f: &[f64], u: &mut [BodyVelocity]) {
        for (i, &fi) in f.iter().enumerate() {
            if fi != 0.0 {
                self.apply_row(i, fi, u);
            }
        }
    }

    /// `A f = J (M⁻¹ Jᵀ f)` for the Jacobian rows (pyramid coupling entries excluded).
    pub fn apply(&self, f: &[f64]) -> Vec<f64> {
        let mut u = vec![BodyVelocity::default(); self.inv_mass.len()];
        self.add_response(f, &mut u);
        (0..self.rows.len()).map(|i| self.row_dot(i, &u)).collect()
    }
}
