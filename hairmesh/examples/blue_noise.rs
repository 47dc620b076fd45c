//! Times progressive sample elimination and prints the quality of its power-of-two prefixes.
//!
//! `cargo run --release -p hairmesh --example blue_noise -- [COUNT] [SEED]`

use std::time::Instant;

use hairmesh::roots::{EliminationParams, SampleDomain, prefix_quality, progressive_samples};

fn main() {
    let mut args = std::env::args().skip(1);
    let count: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(65536);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    for domain in [SampleDomain::Square, SampleDomain::Triangle] {
        let start = Instant::now();
        let points = progressive_samples(count, domain, seed, &EliminationParams::default());
        let elapsed = start.elapsed().as_secs_f64();
        let worst = prefix_quality(&points, domain).into_iter().map(|(_, q)| q).fold(f64::INFINITY, f64::min);
        println!(
            "{domain:?}: {} progressive samples in {elapsed:.3} s; worst power-of-two prefix normalized min distance {worst:.3}",
            points.len()
        );
    }
}
