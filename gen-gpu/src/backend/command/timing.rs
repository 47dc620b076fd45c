//! GPU time per pass: what a recorded frame measured ([`FrameTimings`]) and the quartiles of
//! many frames ([`TimingSummary`]).

/// GPU time of one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTiming {
    pub name: String,
    /// Nesting depth (0 for top-level passes).
    pub depth: u32,
    /// GPU time in milliseconds; `None` when the device has no timestamps.
    pub gpu_ms: Option<f64>,
}

/// What one submission cost.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameTimings {
    pub passes: Vec<PassTiming>,
    /// Wall-clock time from submit to fence, milliseconds.
    pub cpu_wait_ms: f64,
}

impl FrameTimings {
    /// GPU time of the first pass named `name`.
    pub fn pass_ms(&self, name: &str) -> Option<f64> {
        self.passes.iter().find(|p| p.name == name).and_then(|p| p.gpu_ms)
    }
}

impl std::fmt::Display for FrameTimings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for p in &self.passes {
            let indent = "  ".repeat(p.depth as usize);
            match p.gpu_ms {
                Some(ms) => writeln!(f, "  {indent}{:<28} {ms:9.3} ms", p.name)?,
                None => writeln!(f, "  {indent}{:<28}       n/a", p.name)?,
            }
        }
        write!(f, "  {:<28} {:9.3} ms (wall, submit to fence)", "total", self.cpu_wait_ms)
    }
}

/// One pass's GPU time over several frames of the same graph (`TimingSummary`).
#[derive(Clone, Debug, PartialEq)]
pub struct PassSummary {
    pub name: String,
    /// Nesting depth (0 for top-level passes).
    pub depth: u32,
    /// Frames that timed the pass (fewer than the summary's when a pass ran in some frames only,
    /// such as shadow maps made once and cached).
    pub frames: usize,
    /// Median, first and third quartile of its GPU time, milliseconds.
    pub median_ms: f64,
    pub q1_ms: f64,
    pub q3_ms: f64,
}

/// Per-pass GPU times over several frames: what a single frame's timings cannot tell on a
/// device whose frames vary (on a CPU device by 5–10 % from frame to frame). Passes are matched
/// from frame to frame by name, depth and occurrence (a crowd frame has a pass per character
/// under one name), in the order they first appear; untimed passes are left out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimingSummary {
    /// Frames summarized.
    pub frames: usize,
    pub passes: Vec<PassSummary>,
    /// Median wall-clock time from submit to fence, milliseconds.
    pub wall_median_ms: f64,
}

/// The p-quantile (0 ≤ p ≤ 1) of sorted values, interpolated between the two nearest ranks
/// (0 for none).
fn quantile(sorted: &[f64], p: f64) -> f64 {
    let Some(last) = sorted.len().checked_sub(1) else { return 0.0 };
    let h = last as f64 * p.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(last);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

impl TimingSummary {
    /// The summary of `frames` (in any order).
    pub fn of(frames: &[FrameTimings]) -> Self {
        // (name, depth, occurrence) -> its index in `keys` and `times`, in order of first
        // appearance.
        let mut index: std::collections::HashMap<(&str, u32, usize), usize> =
            std::collections::HashMap::new();
        let mut keys: Vec<(&str, u32)> = Vec::new();
        let mut times: Vec<Vec<f64>> = Vec::new();
        for frame in frames {
            let mut seen: std::collections::HashMap<(&str, u32), usize> = std::collections::HashMap::new();
            for pass in &frame.passes {
                let occurrence = seen.entry((pass.name.as_str(), pass.depth)).or_insert(0);
                let key = (pass.name.as_str(), pass.depth, *occurrence);
                *occurrence += 1;
                let Some(ms) = pass.gpu_ms.filter(|ms| ms.is_finite()) else { continue };
                let i = *index.entry(key).or_insert_with(|| {
                    keys.push((key.0, key.1));
                    times.push(Vec::new());
                    keys.len() - 1
                });
                times[i].push(ms);
            }
        }
        let passes = keys
            .into_iter()
            .zip(times)
            .map(|((name, depth), mut t)| {
                t.sort_by(f64::total_cmp);
                PassSummary {
                    name: name.to_owned(),
                    depth,
                    frames: t.len(),
                    median_ms: quantile(&t, 0.5),
                    q1_ms: quantile(&t, 0.25),
                    q3_ms: quantile(&t, 0.75),
                }
            })
            .collect();
        let mut wall: Vec<f64> = frames.iter().map(|f| f.cpu_wait_ms).filter(|ms| ms.is_finite()).collect();
        wall.sort_by(f64::total_cmp);
        Self { frames: frames.len(), passes, wall_median_ms: quantile(&wall, 0.5) }
    }
}

impl std::fmt::Display for TimingSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "  GPU time over {} frames: median (first to third quartile)", self.frames)?;
        for p in &self.passes {
            let indent = "  ".repeat(p.depth as usize);
            let partial = match p.frames {
                n if n == self.frames => String::new(),
                1 => ", 1 frame".to_owned(),
                n => format!(", {n} frames"),
            };
            writeln!(
                f,
                "  {indent}{:<28} {:9.3} ms ({:.3}–{:.3}{partial})",
                p.name, p.median_ms, p.q1_ms, p.q3_ms
            )?;
        }
        write!(f, "  {:<28} {:9.3} ms (wall, submit to fence, median)", "total", self.wall_median_ms)
    }
}

#[cfg(test)]
#[cfg(test)]
mod tests {
    use super::*;

    fn pass(name: &str, depth: u32, gpu_ms: Option<f64>) -> PassTiming {
        PassTiming { name: name.into(), depth, gpu_ms }
    }

    fn frame(passes: Vec<PassTiming>, wall: f64) -> FrameTimings {
        FrameTimings { passes, cpu_wait_ms: wall }
    }

    #[test]
    fn quantiles_interpolate_between_ranks() {
        assert_eq!(quantile(&[], 0.5), 0.0);
        assert_eq!(quantile(&[3.0], 0.25), 3.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.5), 3.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.25), 2.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), 2.5);
        assert_eq!(quantile(&[1.0, 2.0], 1.5), 2.0);
    }

    #[test]
    fn passes_are_matched_by_name_depth_and_occurrence() {
        // A crowd frame: one pass name per character, nested under the frame; a shadow pass
        // only in the first frame; an untimed pass.
        let frames: Vec<FrameTimings> = [(10.0, 1.0, 3.0), (30.0, 2.0, 5.0), (20.0, 3.0, 4.0)]
            .into_iter()
            .enumerate()
            .map(|(i, (total, a, b))| {
                let mut passes = vec![pass("scene frame", 0, Some(total))];
                if i == 0 {
                    passes.push(pass("shadow map", 1, Some(7.0)));
                }
                passes.push(pass("raster", 1, Some(a)));
                passes.push(pass("raster", 1, Some(b)));
                passes.push(pass("untimed", 1, None));
                frame(passes, total + 1.0)
            })
            .collect();
        let s = TimingSummary::of(&frames);
        assert_eq!(s.frames, 3);
        let names: Vec<(&str, u32, usize)> =
            s.passes.iter().map(|p| (p.name.as_str(), p.depth, p.frames)).collect();
        assert_eq!(names, [("scene frame", 0, 3), ("shadow map", 1, 1), ("raster", 1, 3), ("raster", 1, 3)]);
        assert_eq!(s.passes[0].median_ms, 20.0);
        assert_eq!((s.passes[0].q1_ms, s.passes[0].q3_ms), (15.0, 25.0));
        // The first character's raster pass is not mixed with the second's.
        assert_eq!((s.passes[2].median_ms, s.passes[3].median_ms), (2.0, 4.0));
        assert_eq!(s.wall_median_ms, 21.0);
        let text = s.to_string();
        assert!(text.contains("over 3 frames") && text.contains("7.000–7.000, 1 frame)"), "{text}");
    }

    #[test]
    fn no_frames_summarize_to_nothing() {
        let s = TimingSummary::of(&[]);
        assert_eq!((s.frames, s.passes.len(), s.wall_median_ms), (0, 0, 0.0));
    }
}
