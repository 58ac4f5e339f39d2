use super::*;
use crate::problem::metrics::residuals;
use crate::problem::FrictionRow;
use crate::{Settings, SolverKind, Status};
use faer::linalg::solvers::Solve;
use hdf5_pure::GroupBuilder;

/// How a test writes a sparse matrix.
#[derive(Clone, Copy)]
enum Storage {
    Triplet,
    Csc,
    Csr,
}

fn write_ints(g: &mut GroupBuilder, name: &str, v: &[i32]) {
    g.create_dataset(name).with_i32_data(v);
}

fn write_numbers(g: &mut GroupBuilder, name: &str, v: &[f64]) {
    g.create_dataset(name).with_f64_data(v);
}

/// Add group `name` to `parent`, filled by `fill`.
fn add_group(parent: &mut GroupBuilder, name: &str, fill: impl FnOnce(&mut GroupBuilder)) {
    let mut g = parent.create_group(name);
    fill(&mut g);
    parent.add_group(g.finish());
}

/// Write a file whose root holds group `name`, filled by `fill`.
fn write_file(path: &Path, name: &str, fill: impl FnOnce(&mut GroupBuilder)) {
    let mut file = FileBuilder::new();
    let mut g = file.create_group(name);
    fill(&mut g);
    file.add_group(g.finish());
    file.write(path).unwrap();
}

/// Write a dense `rows × cols` matrix (row-major `a`, zeros dropped) in CSparse's layout.
fn write_matrix(g: &mut GroupBuilder, rows: usize, cols: usize, a: &[f64], storage: Storage) {
    let entries: Vec<(usize, usize, f64)> = (0..rows * cols)
        .map(|k| (k / cols, k % cols, a[k]))
        .filter(|e| e.2 != 0.0)
        .collect();
    let nnz = entries.len() as i32;
    write_ints(g, "m", &[rows as i32]);
    write_ints(g, "n", &[cols as i32]);
    write_ints(g, "nzmax", &[nnz]);
    let (nz, p, i, x): (i32, Vec<i32>, Vec<i32>, Vec<f64>) = match storage {
        Storage::Triplet => {
            // Any order: reversed.
            let e: Vec<_> = entries.iter().rev().collect();
            (
                nnz,
                e.iter().map(|e| e.1 as i32).collect(),
                e.iter().map(|e| e.0 as i32).collect(),
                e.iter().map(|e| e.2).collect(),
            )
        }
        Storage::Csc => {
            let mut e = entries.clone();
            e.sort_by_key(|e| (e.1, e.0));
            let p = (0..=cols)
                .map(|j| e.iter().filter(|e| e.1 < j).count() as i32)
                .collect();
            (
                -1,
                p,
                e.iter().map(|e| e.0 as i32).collect(),
                e.iter().map(|e| e.2).collect(),
            )
        }
        Storage::Csr => {
            let p = (0..=rows)
                .map(|r| entries.iter().filter(|e| e.0 < r).count() as i32)
                .collect();
            (
                -2,
                p,
                entries.iter().map(|e| e.1 as i32).collect(),
                entries.iter().map(|e| e.2).collect(),
            )
        }
    };
    write_ints(g, "nz", &[nz]);
    write_ints(g, "p", &p);
    write_ints(g, "i", &i);
    write_numbers(g, "x", &x);
}

/// Two contacts on a plane, uncoupled: contact 0 (`W` block `2 I`, `mu = 0.5`) is pushed
/// tangentially by less than friction holds, so it sticks: `r = (1, 0.2, 0)`, `u = 0`;
/// contact 1 (`W` block `I`, `mu = 0.3`) is pushed harder and slides: `r = (1, -0.3, 0)`,
/// `u_t = 1.7`. A small coupling between the two tangent directions of contact 0 keeps `W`
/// from being diagonal.
fn plane_contacts(path: &Path, storage: Storage) {
    let n = 6;
    let mut w = vec![0.0; n * n];
    for (i, d) in [2.0, 2.0, 2.0, 1.0, 1.0, 1.0].into_iter().enumerate() {
        w[i * n + i] = d;
    }
    w[n + 2] = 0.1;
    w[2 * n + 1] = 0.1;
    // Contact 0's second tangent has q = -0.1 · 0.2 so that r_t2 = 0 is exact.
    let q = [-2.0, -0.4, -0.02, -1.0, 2.0, 0.0];
    write_file(path, "fclib_local", |local| {
        write_ints(local, "spacedim", &[3]);
        add_group(local, "W", |g| write_matrix(g, n, n, &w, storage));
        add_group(local, "vectors", |v| {
            write_numbers(v, "q", &q);
            write_numbers(v, "mu", &[0.5, 0.3]);
        });
    });
}

#[test]
fn local_problem_reads_as_box_friction_lcp_and_solves() {
    let dir = tempfile::tempdir().unwrap();
    for (k, storage) in [Storage::Triplet, Storage::Csc, Storage::Csr]
        .into_iter()
        .enumerate()
    {
        let path = dir.path().join(format!("plane{k}.hdf5"));
        plane_contacts(&path, storage);
        let p = read_fclib(&path).unwrap();
        assert_eq!(p.n(), 6);
        assert!(p.is_sparse());
        assert_eq!(p.name(), Some(format!("plane{k}").as_str()));
        assert_eq!(p.entry(1, 2), 0.1);
        assert_eq!(p.entry(0, 0), 2.0);
        let fr: Vec<_> = p
            .friction()
            .iter()
            .map(|f| (f.row, f.normal, f.mu))
            .collect();
        assert_eq!(fr, [(1, 0, 0.5), (2, 0, 0.5), (4, 3, 0.3), (5, 3, 0.3)]);
        assert_eq!((p.lo()[0], p.hi()[0], p.lo()[3]), (0.0, f64::INFINITY, 0.0));
        let expected = [1.0, 0.2, 0.0, 1.0, -0.3, 0.0];
        assert!(residuals(&p, &expected).natural_map < 1e-15);
        for kind in [SolverKind::Pgs, SolverKind::Sor, SolverKind::Dantzig] {
            let r = kind.create().solve(&p, &Settings::default());
            assert_eq!(r.status, Status::Converged, "{}", kind.name());
            for (a, b) in r.f.iter().zip(expected) {
                assert!((a - b).abs() < 1e-6, "{}: {:?}", kind.name(), r.f);
            }
        }
    }
}

#[test]
fn written_local_files_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.hdf5");
    let t = [(0, 0, 2.0), (1, 1, 1.0), (0, 1, 0.5), (1, 0, 0.5)];
    let t: Vec<_> = t.iter().map(|&(i, j, v)| Triplet::new(i, j, v)).collect();
    let w = SparseColMat::try_new_from_triplets(2, 2, &t).unwrap();
    write_fclib_local(&path, 2, &w, &[-1.0, 0.5], &[0.4]).unwrap();
    let p = read_fclib(&path).unwrap();
    assert_eq!(p.to_dense(), w.to_dense());
    assert_eq!(p.b(), &[-1.0, 0.5]);
    assert_eq!(
        p.friction(),
        &[FrictionRow {
            row: 1,
            normal: 0,
            mu: 0.4
        }]
    );
}

#[test]
fn box_friction_problems_write_as_fclib_and_read_back() {
    // Rows out of contact order: normal 2 with friction rows 0 and 1, normal 3 with 4, 5.
    let n = 6;
    let a = Mat::from_fn(n, n, |i, j| {
        if i == j {
            2.0
        } else if i.abs_diff(j) == 1 {
            0.5
        } else {
            0.0
        }
    });
    let fr = |row, normal, mu| FrictionRow { row, normal, mu };
    let mut lo = vec![0.0; n];
    lo[0] = -1.0;
    let p = Problem::boxed(
        a,
        vec![0.1, 0.2, -1.0, -2.0, 0.3, 0.4],
        lo,
        vec![f64::INFINITY; n],
        vec![fr(0, 2, 0.5), fr(1, 2, 0.5), fr(4, 3, 0.2), fr(5, 3, 0.2)],
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.hdf5");
    let perm = write_problem_as_fclib(&p, &path).unwrap();
    assert_eq!(perm, [2, 0, 1, 3, 4, 5]);
    let back = read_fclib(&path).unwrap();
    let restored = back.permuted(
        &(0..n)
            .map(|i| perm.iter().position(|&k| k == i).unwrap())
            .collect::<Vec<_>>(),
    );
    assert_eq!(restored.to_dense(), p.to_dense());
    assert_eq!(restored.b(), p.b());
    // The same solution, row for row.
    let r = SolverKind::Dantzig.create().solve(&p, &Settings::default());
    let f_back: Vec<f64> = perm.iter().map(|&k| r.f[k]).collect();
    assert!(residuals(&back, &f_back).natural_map_rel < 1e-8);
    // A normal row without friction rows cannot be written.
    let lcp = Problem::lcp(Mat::identity(2, 2), vec![1.0, 1.0]).unwrap();
    let e = write_problem_as_fclib(&lcp, &path).unwrap_err().to_string();
    assert!(e.contains("row 0 has 0 friction rows"), "{e}");
}

#[test]
fn global_problem_is_condensed_to_the_delassus_matrix() {
    // M SPD (5×5, tridiagonal), H 5×3 (one 3-D contact), f, w: W = Hᵀ M⁻¹ H, q = Hᵀ M⁻¹ f + w.
    let nv = 5;
    let m = Mat::from_fn(nv, nv, |i, j| match i.abs_diff(j) {
        0 => 3.0 + i as f64,
        1 => -1.0,
        _ => 0.0,
    });
    let h = Mat::from_fn(nv, 3, |i, j| {
        [
            [1., 0., 0.],
            [0.5, 1., 0.],
            [0., 0., 1.],
            [0., -0.5, 0.],
            [0.2, 0., 0.3],
        ][i][j]
    });
    let f = [1.0, -2.0, 0.5, 0.0, 1.5];
    let w = [0.1, -0.2, 0.3];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.hdf5");
    let row_major = |a: &Mat<f64>| {
        (0..a.nrows())
            .flat_map(|i| (0..a.ncols()).map(move |j| (i, j)))
            .map(|(i, j)| a[(i, j)])
            .collect::<Vec<_>>()
    };
    write_file(&path, "fclib_global", |g| {
        write_ints(g, "spacedim", &[3]);
        add_group(g, "M", |mg| {
            write_matrix(mg, nv, nv, &row_major(&m), Storage::Csc)
        });
        add_group(g, "H", |hg| {
            write_matrix(hg, nv, 3, &row_major(&h), Storage::Triplet)
        });
        add_group(g, "vectors", |v| {
            write_numbers(v, "f", &f);
            write_numbers(v, "w", &w);
            write_numbers(v, "mu", &[0.6]);
        });
    });
    let p = read_fclib(&path).unwrap();
    let minv_h = m.partial_piv_lu().solve(&h);
    let expected_w = h.transpose() * &minv_h;
    let fcol = Mat::from_fn(nv, 1, |i, _| f[i]);
    let minv_f = m.partial_piv_lu().solve(&fcol);
    let expected_q = h.transpose() * &minv_f;
    let a = p.to_dense();
    for i in 0..3 {
        assert!((p.b()[i] - expected_q[(i, 0)] - w[i]).abs() < 1e-12);
        for j in 0..3 {
            assert!((a[(i, j)] - expected_w[(i, j)]).abs() < 1e-12, "{a:?}");
        }
    }
    assert_eq!(p.friction().len(), 2);
}

#[test]
fn errors_name_the_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.hdf5");
    let identity = [1., 0., 0., 0., 1., 0., 0., 0., 1.];
    write_file(&path, "fclib_local", |local| {
        write_ints(local, "spacedim", &[3]);
        add_group(local, "W", |g| {
            write_matrix(g, 3, 3, &identity, Storage::Csc)
        });
        add_group(local, "vectors", |v| {
            write_numbers(v, "q", &[1.0, 2.0]);
            write_numbers(v, "mu", &[0.5]);
        });
    });
    let e = read_fclib(&path).unwrap_err().to_string();
    assert!(
        e.ends_with("field `/fclib_local/vectors/q`: has 2 entries, expected 3"),
        "{e}"
    );
    let path = dir.path().join("none.hdf5");
    write_file(&path, "other", |_| {});
    let e = read_fclib(&path).unwrap_err().to_string();
    assert!(e.contains("without /fclib_local or /fclib_global"), "{e}");
    let path = dir.path().join("text.hdf5");
    std::fs::write(&path, "not hdf5").unwrap();
    let e = read_fclib(&path).unwrap_err().to_string();
    assert!(e.contains("cannot open as HDF5"), "{e}");
}
