//! The hairkit commands and what only they need: `hairkit` (device info, the demo, crowd
//! scenes), `hair-render` (a scene file to images) and `hair-bench` (benchmarks and plots).
//! The library part holds the code the commands share that is not the renderer's business:
//! writing crowd scenes ([`crowd_scenes`]), drawing charts ([`plots`]) and the benchmark's
//! bare crowd renderer ([`bench_crowd`]).

pub mod bench_crowd;
pub mod crowd_scenes;
pub mod plots;
