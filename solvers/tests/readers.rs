//! The file readers never panic: arbitrary bytes and mutations of valid files (bytes flipped,
//! inserted, deleted, the file cut short) given to the JSON, cone JSON, Siconos and FCLIB readers
//! come back as `Ok` or as an `Err`, whatever they hold. Fixed seeds and small case counts keep
//! the suite repeatable and fast; the FCLIB reader's bounds on memory are tested in
//! `fclib_files.rs`.

use faer::Mat;
use lcpbench_solvers::{
    cone_problem_to_json, parse_cone_problem, parse_fclib, parse_problem, parse_siconos,
    parse_siconos_lcp, problem_to_json, write_problem_as_fclib, ConeProblem, FrictionRow, Problem,
};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::path::Path;

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(0x000f_11e5),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// One edit of a byte string; positions are taken modulo the length.
#[derive(Debug, Clone)]
enum Edit {
    Flip(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    Truncate(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Flip(i, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Insert(i, b)),
        any::<usize>().prop_map(Edit::Delete),
        any::<usize>().prop_map(Edit::Truncate),
    ]
}

fn mutate(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        let len = bytes.len();
        match *e {
            Edit::Flip(i, b) if len > 0 => bytes[i % len] ^= b.max(1),
            Edit::Insert(i, b) => bytes.insert(i % (len + 1), b),
            Edit::Delete(i) if len > 0 => {
                bytes.remove(i % len);
            }
            Edit::Truncate(i) => bytes.truncate(i % (len + 1)),
            _ => {}
        }
    }
    bytes
}

/// A small boxed problem with a friction row and bounds of every kind.
fn sample_problem() -> Problem {
    let a = Mat::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.5 });
    Problem::boxed(
        a,
        vec![-1.0, 0.2, 0.3],
        vec![0.0, 0.0, f64::NEG_INFINITY],
        vec![f64::INFINITY, 0.0, 1.5],
        vec![FrictionRow {
            row: 1,
            normal: 0,
            mu: 0.5,
        }],
    )
    .unwrap()
}

fn json_sample() -> Vec<u8> {
    problem_to_json(&sample_problem()).into_bytes()
}

fn cone_sample() -> Vec<u8> {
    let w = Mat::from_fn(6, 6, |i, j| if i == j { 2.0 } else { 0.25 });
    let p = ConeProblem::new(w, vec![-1.0, 0.1, 0.0, -0.5, 0.0, 0.1], vec![0.5, 0.8]).unwrap();
    cone_problem_to_json(&p).into_bytes()
}

fn siconos_sample() -> Vec<u8> {
    // Dimension, storage (0: dense), sizes (twice), the matrix column by column, then `q`.
    b"3\n0\n3\n3\n3\t3\n2 1 0\n1 2 1\n0 1 2\n-1 0.5 -0.25\n".to_vec()
}

fn fclib_sample() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sample.hdf5");
    // Two contacts, each a normal row and two friction rows.
    let w = Mat::from_fn(6, 6, |i, j| if i == j { 2.0 } else { 0.25 });
    let friction = [(1, 0), (2, 0), (4, 3), (5, 3)]
        .map(|(row, normal)| FrictionRow {
            row,
            normal,
            mu: 0.5,
        })
        .to_vec();
    let (inf, ninf) = (f64::INFINITY, f64::NEG_INFINITY);
    let problem = Problem::boxed(
        w,
        vec![-1.0, 0.1, 0.0, -0.5, 0.0, 0.1],
        vec![0.0, ninf, ninf, 0.0, ninf, ninf],
        vec![inf; 6],
        friction,
    )
    .unwrap();
    write_problem_as_fclib(&problem, &path).unwrap();
    std::fs::read(&path).unwrap()
}

/// Every reader, on the same bytes. Text readers get the bytes as UTF-8 (lossily: they take
/// `&str`). Only a panic fails; `Ok` and `Err` are both acceptable answers.
fn read_all(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let path = Path::new("fuzz");
    let _ = parse_problem(&text, path);
    let _ = parse_cone_problem(&text, path);
    let _ = parse_siconos(&text, path);
    let _ = parse_siconos_lcp(&text, path);
    let _ = parse_fclib(bytes.to_vec(), path);
}

#[test]
fn the_samples_are_read() {
    let path = Path::new("sample");
    let json = String::from_utf8(json_sample()).unwrap();
    assert_eq!(parse_problem(&json, path).unwrap().n(), 3);
    let cone = String::from_utf8(cone_sample()).unwrap();
    assert_eq!(parse_cone_problem(&cone, path).unwrap().contacts(), 2);
    let dat = String::from_utf8(siconos_sample()).unwrap();
    assert_eq!(parse_siconos_lcp(&dat, path).unwrap().n(), 3);
    assert_eq!(parse_fclib(fclib_sample(), path).unwrap().n(), 6);
}

proptest! {
    #![proptest_config(config(64))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
        read_all(&bytes);
    }

    #[test]
    fn mutated_json_never_panics(edits in proptest::collection::vec(edit(), 1..6)) {
        let bytes = mutate(json_sample(), &edits);
        let _ = parse_problem(&String::from_utf8_lossy(&bytes), Path::new("m.json"));
    }

    #[test]
    fn mutated_cone_json_never_panics(edits in proptest::collection::vec(edit(), 1..6)) {
        let bytes = mutate(cone_sample(), &edits);
        let _ = parse_cone_problem(&String::from_utf8_lossy(&bytes), Path::new("m.json"));
    }

    #[test]
    fn mutated_siconos_never_panics(edits in proptest::collection::vec(edit(), 1..6)) {
        let bytes = mutate(siconos_sample(), &edits);
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_siconos(&text, Path::new("m.dat"));
        let _ = parse_siconos_lcp(&text, Path::new("m.dat"));
    }
}

proptest! {
    // An FCLIB read of a mutated file walks HDF5 structures: fewer cases keep it fast.
    #![proptest_config(config(24))]

    #[test]
    fn mutated_fclib_never_panics(edits in proptest::collection::vec(edit(), 1..4)) {
        let bytes = mutate(fclib_sample(), &edits);
        let _ = parse_fclib(bytes, Path::new("m.hdf5"));
    }
}
