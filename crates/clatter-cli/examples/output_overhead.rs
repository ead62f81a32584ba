//! What the safety nets cost per step on a settled pile: the blow-up checks (cheap and
//! full), the last-good snapshot, and writing and reading a checkpoint, against one step.
//!
//! `cargo run --release -p clatter-cli --example output_overhead -- [BODIES] [SHAPE]`
//! (SHAPE: sphere, cube or mixed; defaults 10000 mixed). VTK writing is timed through the
//! binary (`clatter run --format vtk --output-every 1`), see docs/outputs.md.

use std::time::Instant;

use clatter::pile::{PileParams, PileShape, pile};
use clatter::{Checkpoint, Health, World};

fn time<T>(reps: u32, mut f: impl FnMut() -> T) -> f64 {
    let start = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(f());
    }
    start.elapsed().as_secs_f64() / reps as f64 * 1e3
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10_000);
    let shape = match args.get(2).map(String::as_str) {
        Some("sphere") => PileShape::Sphere,
        Some("cube") => PileShape::Cube,
        _ => PileShape::Mixed,
    };
    let mut world = World::new(pile(shape, n, &PileParams::default()));
    for _ in 0..300 {
        world.step().expect("a stable pile");
    }
    let health = Health::new(&world);
    let energy = time(50, || world.kinetic_energy() + world.potential_energy());
    let step = time(50, || world.step().expect("a stable pile"));
    let cheap = time(50, || health.check(&world, false).is_ok());
    let full = time(10, || health.check(&world, true).is_ok());
    let mut snapshot = world.clone();
    let clone = time(20, || snapshot.clone_from(&world));
    let mut bytes = Vec::new();
    let write = time(10, || bytes = world.checkpoint_bytes("pile", "", b""));
    let read = time(10, || Checkpoint::from_bytes(&bytes).is_ok());
    println!(
        "{n} bodies ({shape:?}), {} threads, {} contacts",
        rayon::current_num_threads(),
        world.contact_count()
    );
    println!("step                      {step:8.3} ms");
    println!(
        "cheap check (every 10)    {cheap:8.3} ms  {:5.2}% of a step amortised",
        10.0 * cheap / step
    );
    println!("energy.csv sample         {energy:8.3} ms");
    println!(
        "full check (every 100)    {full:8.3} ms  {:5.2}% of a step amortised",
        full / step
    );
    println!(
        "snapshot (every 100)      {clone:8.3} ms  {:5.2}% of a step amortised",
        clone / step
    );
    println!(
        "checkpoint bytes          {write:8.3} ms  ({:.1} MB)",
        bytes.len() as f64 / 1e6
    );
    println!("checkpoint parse + check  {read:8.3} ms");
}
