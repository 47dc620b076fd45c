//! What every hairkit binary does about its terminal.

/// Makes a closed stdout or stderr end the process quietly, as `cat` or `grep` do, instead of
/// a panic in `println!` (`hairmesh info … | head -1`). Call first thing in `main`.
pub fn exit_quietly_on_closed_pipe() {
    // SAFETY: called before any thread is started; restoring the default action of SIGPIPE
    // (terminate) has no memory-safety effect, Rust's runtime merely sets it to "ignore".
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Warnings to show: the first `shown`, then one line for the rest ("… and 199,998 more"), so a
/// file with a hundred thousand odd primitives does not bury the result.
pub fn summarized(warnings: &[String], shown: usize) -> Vec<String> {
    let mut lines: Vec<String> = warnings.iter().take(shown).cloned().collect();
    if warnings.len() > shown {
        lines.push(format!("… and {} more warnings like these", thousands(warnings.len() - shown)));
    }
    lines
}

/// A byte count for people: `1.5 GB`, `340 MB`, `12 kB`, `512 bytes`.
pub fn bytes(n: u64) -> String {
    let n_f = n as f64;
    for (unit, size) in [("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)] {
        if n_f >= size {
            return format!("{:.1} {unit}", n_f / size);
        }
    }
    format!("{n} bytes")
}

/// `199998` → `199,998`.
pub fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn many_warnings_are_summarized() {
        let warnings: Vec<String> = (0..200_000).map(|i| format!("w{i}")).collect();
        let lines = super::summarized(&warnings, 5);
        assert_eq!(lines.len(), 6);
        assert_eq!(lines[5], "… and 199,995 more warnings like these");
        assert_eq!(super::summarized(&warnings[..3], 5).len(), 3);
        assert_eq!(super::thousands(999), "999");
        assert_eq!(super::thousands(1000), "1,000");
    }
}
