//! The contact pipeline: Delassus assembly (`A = J M⁻¹ Jᵀ` from a built contact system) and one
//! whole time step (detect, build, solve with PGS, integrate) of a tower of ten boxes and of a
//! pile of 100 spheres, each taken after the scene has run for a while so contacts are
//! established. The step benchmark keeps stepping the same world, which stays near rest.
//!
//! `cargo bench --bench contact`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use lcpbench_contact::builder;
use lcpbench_contact::scene::Scene;
use lcpbench_contact::step::World;
use std::hint::black_box;
use std::time::Duration;

fn settled(name: &str, steps: usize) -> World {
    let path = format!("{}/bench_scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let scene = Scene::load(&path).expect("bench scene");
    let mut world = scene.world();
    for _ in 0..steps {
        world.step();
    }
    world
}

fn delassus(c: &mut Criterion) {
    let mut group = c.benchmark_group("delassus");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(1));
    for (name, steps) in [("tower_10", 50), ("sphere_pile_100", 100)] {
        let mut world = settled(name, steps);
        let h = world.settings.dt;
        let contacts = world
            .pipeline
            .detect(&world.bodies, world.settings.prediction_distance)
            .expect("bench scenes are within the detection limits");
        let free = builder::free_velocities(&world.bodies, &world.settings.gravity, h);
        let system = builder::build(
            &world.bodies,
            &world.materials,
            &contacts,
            free,
            &world.settings.builder,
            h,
        );
        group.bench_function(BenchmarkId::new(name, system.n()), |b| {
            b.iter(|| black_box(system.delassus()))
        });
    }
    group.finish();
}

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step_pgs");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_secs(2));
    for (name, steps) in [("tower_10", 50), ("sphere_pile_100", 100)] {
        let mut world = settled(name, steps);
        let bodies = world.bodies.len();
        group.bench_function(BenchmarkId::new(name, bodies), |b| {
            b.iter(|| black_box(world.step()))
        });
    }
    group.finish();
}

criterion_group!(benches, delassus, step);
criterion_main!(benches);
