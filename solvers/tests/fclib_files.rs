//! FCLIB files through the pure-Rust HDF5 reader: the five problems of `bench_scenes/fclib/` read
//! bit for bit as the HDF5 C library reads them, files h5py writes in FCLIB's layouts read
//! (`tests/data/fclib/`, written by `h5py_fixtures.py` there), and damaged files (truncated,
//! bytes flipped) and hostile ones (sizes far beyond the file) refused with an error naming the
//! file, never a panic, within bounded memory.

use faer::Mat;
use lcpbench_solvers::{parse_fclib, read_problem, FrictionRow, Problem};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The system allocator, counting the bytes each thread holds and the most it has held, so a
/// test can bound what one read allocates.
struct Counting;

thread_local! {
    static HELD: Cell<usize> = const { Cell::new(0) };
    static PEAK: Cell<usize> = const { Cell::new(0) };
}

fn note_alloc(size: usize) {
    let _ = HELD.try_with(|held| {
        let now = held.get() + size;
        held.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

fn note_free(size: usize) {
    let _ = HELD.try_with(|held| held.set(held.get().saturating_sub(size)));
}

// SAFETY: every call is forwarded to `System` unchanged; the counters are plain thread-local
// cells that never allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_alloc(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_alloc(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note_free(layout.size());
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_alloc(new_size);
        note_free(layout.size());
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// `f()` and the most bytes this thread held during it beyond what it held before.
fn peak_during<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let before = HELD.with(Cell::get);
    PEAK.with(|p| p.set(before));
    let out = f();
    (out, PEAK.with(Cell::get) - before)
}

/// FNV-1a over a problem: `n`, each row's (column, value bits), then `b`, `lo`, `hi` and the
/// friction rows (row, normal, `mu` bits).
fn digest(p: &Problem) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: u64| {
        for byte in x.to_le_bytes() {
            h ^= u64::from(byte);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(p.n() as u64);
    for i in 0..p.n() {
        for (j, v) in p.row(i).iter() {
            eat(j as u64);
            eat(v.to_bits());
        }
    }
    for &x in p.b().iter().chain(p.lo()).chain(p.hi()) {
        eat(x.to_bits());
    }
    for f in p.friction() {
        eat(f.row as u64);
        eat(f.normal as u64);
        eat(f.mu.to_bits());
    }
    h
}

/// The five FCLIB problems shipped in `bench_scenes/fclib/`: name, rows, stored entries of `A`,
/// and the [`digest`] of the problem read through the HDF5 C library (libhdf5 1.10 via the
/// `hdf5-metno` crate, the same condensation code), whose JSON export is byte-identical too.
const SHIPPED: [(&str, usize, usize, u64); 5] = [
    ("Box_Stacks-i0122-82-5", 246, 2016, 0x67ea_b271_9519_0945),
    ("Capsules-i125-1213", 858, 11772, 0x6c54_ebd8_8a2d_bb49),
    (
        "LMGC_100_PR_PerioBox-i00361-60-03000",
        180,
        9576,
        0x756b_5be7_aa7a_e100,
    ),
    ("Spheres-i099-356-679", 1068, 7168, 0xa873_1573_a3fc_7ee4),
    (
        "spheres-in-a-box-98-i10000-256-10",
        768,
        17424,
        0xc5ad_7fb7_1584_9adf,
    ),
];

fn shipped_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../bench_scenes/fclib")
        .join(format!("{name}.hdf5"))
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fclib")
        .join(name)
}

#[test]
fn shipped_files_read_bit_for_bit_as_the_c_library_reads_them() {
    for (name, n, nnz, expected) in SHIPPED {
        let p = read_problem(&shipped_path(name)).unwrap();
        assert_eq!((p.n(), p.nnz()), (n, nnz), "{name}");
        assert_eq!(digest(&p), expected, "{name}: {:016x}", digest(&p));
    }
}

fn assert_two_plane_contacts(p: &Problem, file: &str) {
    let mut w = Mat::<f64>::zeros(6, 6);
    for (i, d) in [2.0, 2.0, 2.0, 1.0, 1.0, 1.0].into_iter().enumerate() {
        w[(i, i)] = d;
    }
    w[(1, 2)] = 0.1;
    w[(2, 1)] = 0.1;
    assert_eq!(p.to_dense(), w, "{file}");
    assert_eq!(p.b(), &[-2.0, -0.4, -0.02, -1.0, 2.0, 0.0], "{file}");
    let fr = |row, normal, mu| FrictionRow { row, normal, mu };
    assert_eq!(
        p.friction(),
        &[fr(1, 0, 0.5), fr(2, 0, 0.5), fr(4, 3, 0.3), fr(5, 3, 0.3)],
        "{file}"
    );
}

#[test]
fn h5py_files_in_fclib_layouts_read() {
    // W as compressed rows (superblock 0, int32), as triplets (superblock 3, int64 scalars).
    for file in ["local_csr.hdf5", "local_triplets_latest.hdf5"] {
        let p = read_problem(&fixture(file)).unwrap();
        assert_two_plane_contacts(&p, file);
    }
    // A 2-D contact, compressed columns, groups that track creation order.
    let p = read_problem(&fixture("local_2d.hdf5")).unwrap();
    assert_eq!(
        p.to_dense(),
        Mat::from_fn(2, 2, |i, j| [[1.0, 0.25], [0.25, 0.5]][i][j])
    );
    assert_eq!(p.b(), &[-1.0, 0.1]);
    let fr = FrictionRow {
        row: 1,
        normal: 0,
        mu: 0.4,
    };
    assert_eq!(p.friction(), &[fr]);
    // The global form with chunked, shuffled, deflated datasets: W = Hᵀ M⁻¹ H, q = Hᵀ M⁻¹ f + w.
    let p = read_problem(&fixture("global_deflate.hdf5")).unwrap();
    let m = Mat::from_fn(5, 5, |i, j| match i.abs_diff(j) {
        0 => 3.0 + i as f64,
        1 => -1.0,
        _ => 0.0,
    });
    let h_rows = [
        [1., 0., 0.],
        [0.5, 1., 0.],
        [0., 0., 1.],
        [0., -0.5, 0.],
        [0.2, 0., 0.3],
    ];
    let h = Mat::from_fn(5, 3, |i, j| h_rows[i][j]);
    let f = Mat::from_fn(5, 1, |i, _| [1.0, -2.0, 0.5, 0.0, 1.5][i]);
    let lu = m.partial_piv_lu();
    use faer::linalg::solvers::Solve;
    let w = h.transpose() * lu.solve(&h);
    let q = h.transpose() * lu.solve(&f);
    let a = p.to_dense();
    for i in 0..3 {
        assert!((p.b()[i] - q[(i, 0)] - [0.1, -0.2, 0.3][i]).abs() < 1e-12);
        for j in 0..3 {
            assert!((a[(i, j)] - w[(i, j)]).abs() < 1e-12, "{a:?}");
        }
    }
    assert_eq!(p.friction().len(), 2);
}

#[test]
fn sizes_beyond_the_file_are_refused_before_reading() {
    let (e, peak) = peak_during(|| read_problem(&fixture("declared_huge.hdf5")).unwrap_err());
    let e = e.to_string();
    assert!(e.contains("declared_huge.hdf5"), "{e}");
    assert!(
        e.contains("field `/fclib_local/vectors/q`: declares [1000000000] elements of 8 bytes"),
        "{e}"
    );
    assert!(peak < 1 << 20, "{peak} bytes");
    let (e, peak) =
        peak_during(|| read_problem(&fixture("declared_huge_deflate.hdf5")).unwrap_err());
    let e = e.to_string();
    assert!(
        e.contains("field `/fclib_global/vectors/f`: declares [1099511627776] elements"),
        "{e}"
    );
    assert!(e.contains("more than 1032 times its file of"), "{e}");
    assert!(peak < 1 << 20, "{peak} bytes");
}

/// The shipped files' bytes, and the most the reader holds reading each intact.
fn shipped_bytes() -> &'static [(String, Vec<u8>, usize)] {
    static FILES: OnceLock<Vec<(String, Vec<u8>, usize)>> = OnceLock::new();
    FILES.get_or_init(|| {
        SHIPPED
            .iter()
            .map(|&(name, ..)| {
                let bytes = std::fs::read(shipped_path(name)).unwrap();
                let path = PathBuf::from(format!("damaged/{name}.hdf5"));
                let (p, peak) = peak_during(|| parse_fclib(bytes.clone(), &path));
                p.unwrap();
                (name.to_string(), bytes, peak)
            })
            .collect()
    })
}

/// A way to damage a file: cut it at a fraction of its length, or XOR bytes at fractions of its
/// length (`near_start`: of its first 4 KiB, where the superblock and root group live).
#[derive(Debug, Clone)]
enum Damage {
    Truncate(f64),
    Flip {
        near_start: bool,
        bytes: Vec<(f64, u8)>,
    },
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        (0.0..1.0f64).prop_map(Damage::Truncate),
        (
            any::<bool>(),
            prop::collection::vec((0.0..1.0f64, 1..=255u8), 1..8)
        )
            .prop_map(|(near_start, bytes)| Damage::Flip { near_start, bytes }),
    ]
}

fn damaged(bytes: &[u8], damage: &Damage) -> Vec<u8> {
    let at = |x: f64, len: usize| ((x * len as f64) as usize).min(len - 1);
    match damage {
        Damage::Truncate(x) => bytes[..at(*x, bytes.len())].to_vec(),
        Damage::Flip {
            near_start,
            bytes: flips,
        } => {
            let mut b = bytes.to_vec();
            let span = if *near_start {
                b.len().min(4096)
            } else {
                b.len()
            };
            for &(x, mask) in flips {
                b[at(x, span)] ^= mask;
            }
            b
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 120,
        rng_seed: RngSeed::Fixed(0x0fc1_1b35),
        ..ProptestConfig::default()
    })]

    /// A damaged file reads as a problem or gives an error naming the file; the reader never
    /// panics, and holds at most twice what it holds for the intact file plus 64 bytes per byte
    /// of file (a size taken from damaged metadata without a check would blow past this).
    #[test]
    fn damaged_files_give_errors_within_bounded_memory(file in 0..SHIPPED.len(), damage in damage()) {
        let (name, bytes, intact_peak) = &shipped_bytes()[file];
        let path = PathBuf::from(format!("damaged/{name}.hdf5"));
        let input = damaged(bytes, &damage);
        let (result, peak) = peak_during(|| parse_fclib(input, &path));
        if let Err(e) = result {
            let e = e.to_string();
            prop_assert!(e.starts_with(&format!("damaged/{name}.hdf5")), "{}", e);
        }
        prop_assert!(peak <= 2 * intact_peak + 64 * bytes.len(), "{} bytes, intact {}", peak, intact_peak);
    }
}
