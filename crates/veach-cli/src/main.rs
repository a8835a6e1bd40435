//! `veach`: the command-line front end, one module per subcommand: `veach render` renders a
//! glTF scene headless.

mod bench;
mod console;
mod merge;
mod options;
mod render;
mod scale;
mod scene_tools;
mod view;

use bench::BenchArgs;
use clap::{Parser, Subcommand};
use console::errln;
use merge::MergeArgs;
use render::RenderArgs;
use scale::ScaleArgs;
use scene_tools::{export_mitsuba, generate, info};
use std::path::PathBuf;
use view::ViewArgs;

#[derive(Parser)]
#[command(
    name = "veach",
    version,
    about = "Direct illumination on the GPU: uniform, BRDF, light and MIS sampling compared"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a glTF scene (.gltf or .glb) to an image.
    Render(RenderArgs),
    /// Add renders of disjoint ranges of camera samples (`render --first-sample`) into one image
    Merge(MergeArgs),
    /// Open a scene in the interactive viewer: progressive render, strategy toggles, error plot.
    View(ViewArgs),
    /// Measure error against render time for every strategy (results.csv, plots, report.md).
    Bench(BenchArgs),
    /// Measure how load, BVH build, GPU memory and render time grow with the triangle count,
    /// and render time with the light count (generated scenes; scale.csv and a table).
    Scale(ScaleArgs),
    /// Print what veach sees in a scene: counts, materials, lights, cameras; or, given an image
    /// (.exr, .png, .pfm), its size and the settings veach recorded in its header.
    Info {
        /// glTF scene (.gltf or .glb), or an image
        scene: PathBuf,
    },
    /// Write one of the scenes veach generates as .gltf: the ones shipped in assets/, the stiff
    /// and extreme scenes of the stability suite (stress-*), or with `zoo` the scene zoo (38
    /// scenes in families, from a seed) into a folder, with an index zoo.csv
    Generate {
        /// Scene name, or `zoo`
        #[arg(value_parser = clap::builder::PossibleValuesParser::new(
            veach_scenes::scene_names().into_iter().chain(["zoo"])
        ))]
        name: String,
        /// Output file (.gltf); for `zoo` a folder
        #[arg(short, long)]
        output: PathBuf,
        /// The zoo's seed: another seed, other scenes of the same families
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Write a scene for Mitsuba 3 (scene.xml and PLY meshes), for the peer comparison in
    /// bench/peer_mitsuba.py; refuses materials and lights that would not render the same
    ExportMitsuba {
        /// glTF scene (.gltf or .glb)
        scene: PathBuf,
        /// Output folder
        #[arg(short, long)]
        output: PathBuf,
        /// Camera by name [default: the scene's first]
        #[arg(long)]
        camera: Option<String>,
        /// Write each round light (a tessellated sphere) as an analytic Mitsuba sphere of the same
        /// area, which Mitsuba samples by its cone as `--light-sampling cone` does
        #[arg(long)]
        round_lights_as_spheres: bool,
    },
}

fn main() {
    let cli = Cli::parse();
    quiet_mesa_runtime_dir_warning();
    let result = match cli.command {
        Command::Render(args) => render::render(args),
        Command::Merge(args) => merge::merge(args),
        Command::View(args) => view::view(args),
        Command::Bench(args) => bench::bench(args),
        Command::Scale(args) => scale::scale(args),
        Command::Info { scene } => info(&scene),
        Command::Generate { name, output, seed } => generate(&name, &output, seed),
        Command::ExportMitsuba { scene, output, camera, round_lights_as_spheres } => {
            export_mitsuba(&scene, &output, camera.as_deref(), round_lights_as_spheres)
        }
    };
    if let Err(e) = result {
        errln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid" when it is unset, which reads like
/// an error of ours: point it at a private directory of our own.
fn quiet_mesa_runtime_dir_warning() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let dir = std::env::temp_dir().join("veach-xdg-runtime");
    #[cfg(unix)]
    let created = {
        use std::os::unix::fs::DirBuilderExt;
        std::fs::DirBuilder::new().mode(0o700).create(&dir).is_ok() || dir.is_dir()
    };
    #[cfg(not(unix))]
    let created = false;
    if created {
        // SAFETY: called at the start of main, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}
