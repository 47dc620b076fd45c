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
