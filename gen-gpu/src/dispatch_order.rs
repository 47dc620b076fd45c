//! The order a dispatch's workgroups take their work in: the CPU port of
//! `shaders/dispatch_order.glsl` (see there for why), tested here for what every kernel relies
//! on, that it is a permutation.

/// The work index of workgroup `w` of `n` on a device that runs a dispatch as `workers`
/// contiguous runs of workgroups, one per thread: thread `t` runs `w` in `[t q, (t + 1) q)`
/// (`q = n / workers`), which take the indices `j * workers + t`, `j` from `t q / workers` on,
/// wrapping around, so each thread's run is a comb over the whole dispatch starting at its own
/// place; the remainder keeps its own indices. The identity for one worker.
pub fn dispatch_order(w: u32, n: u32, workers: u32) -> u32 {
    if workers <= 1 {
        return w;
    }
    let q = n / workers;
    // workers * q <= n: no overflow.
    if q == 0 || w >= workers * q {
        return w;
    }
    let t = w / q;
    // i + t q / workers < 2 q, and q <= n / 2.
    let mut j = w - t * q + t * q / workers;
    if j >= q {
        j -= q;
    }
    j * workers + t
}

#[cfg(test)]
mod tests {
    use super::dispatch_order;

    #[test]
    fn the_order_is_a_permutation_for_any_size_and_worker_count() {
        for workers in 1..=9 {
            for n in 0..=300 {
                let mut seen = vec![false; n as usize];
                for w in 0..n {
                    let o = dispatch_order(w, n, workers);
                    assert!(o < n, "w {w} of {n} with {workers} workers -> {o}");
                    assert!(!seen[o as usize], "{o} twice (n {n}, {workers} workers)");
                    seen[o as usize] = true;
                }
            }
        }
        // Near the top of the range (no overflow).
        let n = u32::MAX;
        for w in [0, 1, n / 3, n / 2, n - 3, n - 2, n - 1] {
            assert!(dispatch_order(w, n, 3) < n);
        }
    }

    #[test]
    fn each_worker_run_spans_the_dispatch_from_its_own_place() {
        let (n, workers) = (1000, 4);
        let q = n / workers;
        for t in 0..workers {
            let run: Vec<u32> = (t * q..(t + 1) * q).map(|w| dispatch_order(w, n, workers)).collect();
            // Every workers-th index, all of them ...
            assert!(run.iter().all(|o| o % workers == t));
            assert_eq!(run.iter().min().copied(), Some(t));
            assert!(run.iter().max().is_some_and(|&m| m >= n - workers));
            // ... starting a t-th of the way in.
            assert_eq!(run[0], (t * q / workers) * workers + t);
        }
        assert_eq!(dispatch_order(17, 1000, 1), 17);
    }
}
