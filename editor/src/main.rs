//! `hair-editor [PATH] [--screenshot OUT.png]`: the editor in a window (eframe on wgpu).
//! `hair-editor --replay SESSION.json -o ASSET [--screenshot OUT.png]`: a session replayed
//! without a window, its asset saved (and its view rendered).
//!
//! PATH is a head or scalp mesh (.glb, .gltf, .obj: converted with the default settings), a
//! hair asset folder or a session file. With `--screenshot`, the editor opens PATH, waits for the first full-quality
//! preview, saves a screenshot of the whole window and exits (for docs and headless checks,
//! e.g. under `xvfb-run`); the screenshot is taken with `xwd` (X11).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Parser;
use editor::app::{EditorApp, ScreenshotRequest};

#[derive(Parser, Debug)]
#[command(name = "hair-editor", version, about = "Shape hair meshes and style hair with a live preview")]
struct Cli {
    /// A head or scalp mesh (.glb, .gltf, .obj), a hair asset folder or a session to open.
    path: Option<PathBuf>,
    /// Open PATH, wait for the first full-quality preview, save a screenshot of the window to
    /// this PNG and exit. With --replay: render the replayed hair in the session's view to
    /// this PNG (no window).
    #[arg(long, value_name = "OUT.png")]
    screenshot: Option<PathBuf>,
    /// Replay this session without a window and save its asset to --out.
    #[arg(long, value_name = "SESSION.json", conflicts_with = "path", requires = "out")]
    replay: Option<PathBuf>,
    /// With --replay: the asset folder to write (replaced only if it is a hair asset).
    #[arg(short, long, value_name = "ASSET_DIR", requires = "replay")]
    out: Option<PathBuf>,
    /// With --replay: replace --out even if it is not a hair asset (never a folder holding an
    /// input).
    #[arg(long, requires = "replay")]
    force: bool,
    /// Window size in points, WIDTHxHEIGHT (with --replay: the picture's size in pixels).
    #[arg(long, default_value = "1280x760", value_parser = parse_size)]
    size: (f32, f32),
    /// `--screenshot`: give up after this many seconds.
    #[arg(long, default_value_t = 300)]
    timeout: u64,
}

fn parse_size(text: &str) -> Result<(f32, f32), String> {
    let (w, h) = text.split_once('x').ok_or_else(|| format!("`{text}`: expected WIDTHxHEIGHT"))?;
    let parse = |v: &str| v.trim().parse::<f32>().map_err(|e| format!("`{v}`: {e}"));
    let (w, h) = (parse(w)?, parse(h)?);
    if !(200.0..=8192.0).contains(&w) || !(150.0..=8192.0).contains(&h) {
        return Err(format!("{w}x{h}: between 200x150 and 8192x8192"));
    }
    Ok((w, h))
}

/// The window's title, by which `--screenshot` finds it.
const WINDOW_TITLE: &str = "hair-editor";

struct Window {
    app: EditorApp,
    started: Instant,
    timeout: Duration,
}

impl eframe::App for Window {
    fn on_exit(&mut self) {
        // The window's teardown (its wgpu surface) blocks forever on lavapipe under Xvfb
        // (measured here); everything is saved by now, so end the process.
        std::process::exit(0);
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.app.ui(ui);
        if let Some(shot) = &self.app.screenshot {
            let done = shot.result.lock().unwrap_or_else(|e| e.into_inner()).take();
            let outcome = match done {
                Some(done) => Some(done.map(|()| shot.out.clone())),
                // A failed preview (a validation message included) fails the run at once.
                None if self.app.preview_error.is_some() || self.app.error.is_some() => Some(Err(self
                    .app
                    .error
                    .as_ref()
                    .or(self.app.preview_error.as_ref())
                    .map_or("", String::as_str)
                    .to_string())),
                None if self.started.elapsed() > self.timeout => {
                    let why = match (&self.app.error, &self.app.preview_error) {
                        (Some(e), _) | (None, Some(e)) => e.clone(),
                        (None, None) => "the preview did not finish".into(),
                    };
                    Some(Err(format!("timed out after {} s: {why}", self.timeout.as_secs())))
                }
                None => None,
            };
            if let Some(outcome) = outcome {
                // Exit here rather than through the window's teardown: on lavapipe under Xvfb,
                // destroying the window's surface blocks forever (measured here), and a
                // screenshot run has nothing to save.
                let code = match outcome {
                    Ok(out) => {
                        println!("wrote {}", out.display());
                        0
                    }
                    Err(e) => {
                        eprintln!("hair-editor: error: {e}");
                        1
                    }
                };
                std::process::exit(code);
            } else {
                // Keep polling while waiting for the preview and the conversion.
                ui.ctx().request_repaint_after(Duration::from_millis(500));
            }
        }
    }
}

fn recent_file() -> Option<PathBuf> {
    let base = std::env::var_os("XDG_CONFIG_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config")))?;
    let dir = base.join("hairkit");
    std::fs::create_dir_all(&dir).ok()?;
    Some(dir.join("recent.json"))
}

fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hair-editor: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// `--replay`: the session's asset (and picture) without a window.
fn replay(session_path: &std::path::Path, out: &std::path::Path, cli: &Cli) -> Result<()> {
    use hairmesh::output::{FileKind, Replace};
    let session = editor::session::Session::read(session_path)?;
    // Before any work: the outputs must be safe to write.
    let replace = Replace::from_force(cli.force);
    hairmesh::output::check_asset_folder(out, &[session_path], replace)?;
    if let Some(shot) = &cli.screenshot {
        hairmesh::output::check_file(shot, FileKind::Png, &[session_path], Replace::OwnOutput)?;
    }
    let started = Instant::now();
    let mut doc = session.replay(session_path, &mut |step| eprintln!("{step}…"))?;
    doc.save_as(out)?;
    println!(
        "replayed {} ({} commands) in {:.1} s: wrote {}",
        session_path.display(),
        session.commands.len(),
        started.elapsed().as_secs_f64(),
        out.display()
    );
    if let Some(shot) = &cli.screenshot {
        let size = [cli.size.0.round() as u32, cli.size.1.round() as u32];
        let image = editor::session::snapshot(&doc, session.camera, size, Duration::from_secs(cli.timeout))?;
        render::output::write_png(shot, &image).with_context(|| format!("writing {}", shot.display()))?;
        println!("wrote {}", shot.display());
    }
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    if let (Some(session), Some(out)) = (&cli.replay, &cli.out) {
        return replay(session, out, &cli);
    }
    if cli.screenshot.is_some() && cli.path.is_none() {
        bail!("--screenshot needs a PATH to open (or --replay SESSION -o ASSET)");
    }
    if let Some(p) = &cli.path
        && !p.exists()
    {
        bail!("{}: no such file or folder", p.display());
    }
    let mut options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size([cli.size.0, cli.size.1])
            .with_title(WINDOW_TITLE),
        ..Default::default()
    };
    // Presenting with vsync blocks forever on lavapipe under Xvfb (measured here: the first
    // present never returns). egui repaints only when something changed, so without vsync it
    // does not spin either.
    options.wgpu_options.surface.present_mode = eframe::wgpu::PresentMode::AutoNoVsync;
    let screenshot = cli.screenshot.clone();
    let path = cli.path.clone();
    let timeout = Duration::from_secs(cli.timeout);
    eframe::run_native(
        "hair-editor",
        options,
        Box::new(move |cc| {
            let mut app =
                EditorApp::new(&cc.egui_ctx, if screenshot.is_some() { None } else { recent_file() });
            if let Some(p) = &path {
                app.open(p);
            }
            app.screenshot = screenshot.map(|out| ScreenshotRequest::new(out, WINDOW_TITLE));
            Ok(Box::new(Window { app, started: Instant::now(), timeout }))
        }),
    )
    .map_err(|e| anyhow::anyhow!("{e}"))
    .context("running the window (a display is needed: on a headless machine use xvfb-run)")?;
    if cli.screenshot.is_some() {
        bail!("the window closed before the screenshot was taken");
    }
    Ok(())
}
