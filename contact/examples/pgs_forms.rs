//! Time projected Gauss–Seidel with assembled rows of `A` against matrix-free sweeps on the
//! `J M⁻¹ Jᵀ` factors, on the contact problem of a scene after some steps.
//!
//! ```text
//! cargo run --release -p lcpbench-contact --example pgs_forms -- SCENE.toml [STEPS] [TOL]
//! ```

use lcpbench_contact::{builder, CollisionPipeline, Scene};
use lcpbench_solvers::{ProjectedSor, Settings, Solver, SweepForm};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .ok_or("usage: pgs_forms SCENE.toml [STEPS] [TOL]")?;
    let steps: usize = args.get(2).map_or(Ok(10), |s| s.parse())?;
    let tolerance: f64 = args.get(3).map_or(Ok(1e-6), |s| s.parse())?;
    let scene = Scene::load(path)?;
    let mut world = scene.world();
    world.run(steps);
    let mut pipeline = CollisionPipeline::new();
    let contacts = pipeline.detect(&world.bodies, world.settings.prediction_distance)?;
    let free = builder::free_velocities(&world.bodies, &world.settings.gravity, world.settings.dt);
    let t0 = Instant::now();
    let system = builder::build(
        &world.bodies,
        &world.materials,
        &contacts,
        free,
        &world.settings.builder,
        world.settings.dt,
    );
    let t_build = t0.elapsed();
    let t0 = Instant::now();
    let problem = system.problem()?;
    let t_assemble = t0.elapsed();
    let t0 = Instant::now();
    let islands = system.islands();
    let t_islands = t0.elapsed();
    println!(
        "{path} after {steps} steps: {} contacts, {} rows, nnz(A) = {}, {} islands; \
         build {:.2} ms, assemble A {:.2} ms, islands {:.2} ms",
        contacts.len(),
        problem.n(),
        problem.nnz(),
        islands.len(),
        t_build.as_secs_f64() * 1e3,
        t_assemble.as_secs_f64() * 1e3,
        t_islands.as_secs_f64() * 1e3,
    );
    let settings = Settings {
        tolerance,
        max_iterations: 10_000,
        ..Settings::default()
    };
    for (name, form) in [
        ("matrix-free", SweepForm::MatrixFree),
        ("assembled", SweepForm::Assembled),
        ("matrix-free", SweepForm::MatrixFree),
    ] {
        let mut solver = ProjectedSor::pgs().with_sweep(form);
        let r = solver.solve(&problem, &settings);
        println!(
            "  pgs {name:12} {:9.2} ms  {:5} sweeps  {:8.3} µs/sweep  residual {:.2e}  {}",
            r.time.as_secs_f64() * 1e3,
            r.iterations,
            r.time.as_secs_f64() * 1e6 / r.iterations.max(1) as f64,
            r.residuals.natural_map_rel,
            r.status
        );
    }
    Ok(())
}
