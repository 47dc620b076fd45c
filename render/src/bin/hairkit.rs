//! `hairkit`: device report and demo.
//!
//! ```text
//! hairkit info [--all] [--device SEL] [--path auto|mesh|compute]
//! hairkit demo [-o DIR] [--strands N] [--size WxH] [--device SEL] [--path auto|mesh|compute]
//! ```

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand};
use gen_gpu::diagnostics::draw_test_strips;
use gen_gpu::{Context, ContextDesc, GenerationPath, PathChoice, Validation};

#[derive(Parser, Debug)]
#[command(name = "hairkit", version, about = "hairkit: hair meshes rendered as strands generated on the GPU")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the Vulkan device's capability report and the generation path it will use.
    Info {
        /// List every Vulkan device on the machine first.
        #[arg(long)]
        all: bool,
        #[command(flatten)]
        device: DeviceArgs,
    },
    /// Run the demo: device report, then strands drawn by each available generation path,
    /// written as PNG, with timings.
    Demo {
        /// Output folder.
        #[arg(short, long, default_value = "target/demo")]
        out: PathBuf,
        /// Number of synthetic strands.
        #[arg(long, default_value_t = 400)]
        strands: u32,
        /// Image size, WIDTHxHEIGHT.
        #[arg(long, default_value = "640x360", value_parser = parse_size)]
        size: (u32, u32),
        #[command(flatten)]
        device: DeviceArgs,
    },
}

#[derive(Args, Debug)]
struct DeviceArgs {
    /// Device index (see `hairkit info --all`) or part of its name; default: HAIRKIT_DEVICE,
    /// else the best device (discrete > integrated > virtual > CPU).
    #[arg(long)]
    device: Option<String>,
    /// Generation path: `mesh` (task+mesh shaders), `compute` (fallback), or `auto`
    /// (HAIRKIT_PATH, else mesh on GPUs and compute on CPU devices).
    #[arg(long, default_value = "auto")]
    path: PathChoice,
    /// Enable the Khronos validation layer (also HAIRKIT_VALIDATION=1).
    #[arg(long)]
    validation: bool,
}

impl DeviceArgs {
    fn context(&self) -> Result<Context> {
        let desc = ContextDesc {
            validation: if self.validation { Validation::On } else { Validation::FromEnv },
            device: self.device.clone(),
            path: self.path,
        };
        Context::new(&desc).context("creating the Vulkan context")
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("`{v}` in `{s}`: {e}"));
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 || w > 8192 || h > 8192 {
        return Err(format!("{w}x{h}: width and height must be 1..=8192"));
    }
    Ok((w, h))
}

fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hairkit: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { all, device } => {
            if all {
                println!("Vulkan devices:");
                for d in Context::list_devices()? {
                    println!("  {d}");
                }
                println!();
            }
            let ctx = device.context()?;
            println!("{}", ctx.capabilities());
            println!(
                "generation path:        {} (default for this device: {})",
                ctx.path(),
                GenerationPath::default_for(ctx.capabilities())
            );
            Ok(())
        }
        Command::Demo { out, strands, size, device } => demo(&out, strands, size, &device),
    }
}

fn demo(out: &std::path::Path, strands: u32, (width, height): (u32, u32), device: &DeviceArgs) -> Result<()> {
    let start = Instant::now();
    let ctx = device.context()?;
    println!("== device\n{}\n", ctx.capabilities());
    println!(
        "context created in {:.1} ms; default path: {}\n",
        start.elapsed().as_secs_f64() * 1e3,
        ctx.path()
    );
    let mut paths = vec![GenerationPath::Compute];
    if ctx.capabilities().mesh_shader.is_some() {
        paths.push(GenerationPath::Mesh);
    } else {
        println!("(no VK_EXT_mesh_shader: the task+mesh path is skipped)\n");
    }
    if device.path != PathChoice::Auto {
        paths.retain(|p| *p == ctx.path());
    }
    if paths.is_empty() {
        bail!("nothing to draw");
    }
    println!("== {strands} synthetic strands, {width}x{height}");
    for path in paths {
        // The first frame pays for pipeline compilation; time a second one too.
        let (_, first) = draw_test_strips(&ctx, path, strands, width, height)?;
        let (image, timings) = draw_test_strips(&ctx, path, strands, width, height)?;
        let file = out.join(format!("strips-{path}.png"));
        render::output::write_png(&file, &image)?;
        println!("{path} path -> {}", file.display());
        println!("  first frame (includes shader compilation): {:.1} ms wall", first.cpu_wait_ms);
        println!("{timings}");
    }
    println!("\ndemo finished in {:.2} s", start.elapsed().as_secs_f64());
    Ok(())
}
