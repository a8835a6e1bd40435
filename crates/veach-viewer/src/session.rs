//! The scene on the GPU and the image accumulating for the current settings. Each frame the
//! viewer advances it by dispatches that fit a time budget, so the window stays responsive
//! while the image refines; any change of settings or camera starts a new accumulation.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};
use veach::scene::{Camera, Scene};
use veach::{Accumulation, GpuScene, RenderOutput, RenderSettings, Renderer};

pub struct LoadedScene {
    pub path: PathBuf,
    pub scene: Scene,
    pub gpu: GpuScene,
}

impl LoadedScene {
    pub fn load(renderer: &Renderer, path: &Path) -> veach::Result<LoadedScene> {
        let scene = veach::load_gltf(path)?;
        let gpu = renderer.upload_scene(&scene)?;
        Ok(LoadedScene { path: path.to_owned(), scene, gpu })
    }
}

pub struct RenderSession {
    pub renderer: Arc<Renderer>,
    pub loaded: LoadedScene,
    accumulation: Option<Accumulation>,
    latest: Option<RenderOutput>,
    /// Accumulations started so far (each change of settings or camera starts one).
    pub restarts: u64,
}

impl RenderSession {
    pub fn new(renderer: Arc<Renderer>, loaded: LoadedScene) -> RenderSession {
        RenderSession { renderer, loaded, accumulation: None, latest: None, restarts: 0 }
    }

    /// Replaces the scene; the caller restarts with a camera of the new scene.
    pub fn replace_scene(&mut self, loaded: LoadedScene) {
        self.loaded = loaded;
        self.accumulation = None;
        self.latest = None;
    }

    /// Drops what was accumulated and starts `settings` through `camera` (compiling the kernel
    /// if this feature set has not been used before on this device).
    pub fn restart(&mut self, settings: &RenderSettings, camera: &Camera) -> veach::Result<()> {
        self.accumulation = None;
        self.latest = None;
        self.restarts += 1;
        self.accumulation = Some(Accumulation::new(&self.renderer, &self.loaded.gpu, settings, camera)?);
        Ok(())
    }

    /// Dispatches until about `budget` is spent (at least one dispatch), then reads the image
    /// back. Returns whether there are new samples.
    pub fn advance(&mut self, budget: Duration) -> veach::Result<bool> {
        let Some(acc) = self.accumulation.as_mut() else { return Ok(false) };
        if acc.is_complete() {
            return Ok(false);
        }
        let start = Instant::now();
        // Dispatches of the whole budget (lavapipe spends ~12 ms on any dispatch, so smaller
        // ones would mostly be overhead); another only if the first ended early.
        while !acc.is_complete() && start.elapsed() < budget / 2 {
            acc.dispatch(budget)?;
        }
        self.latest = Some(acc.read()?);
        Ok(true)
    }

    pub fn is_complete(&self) -> bool {
        self.accumulation.as_ref().is_some_and(Accumulation::is_complete)
    }

    pub fn accumulation(&self) -> Option<&Accumulation> {
        self.accumulation.as_ref()
    }

    /// The image read back after the last `advance`.
    pub fn latest(&self) -> Option<&RenderOutput> {
        self.latest.as_ref()
    }
}
